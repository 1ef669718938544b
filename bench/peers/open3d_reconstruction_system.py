#!/usr/bin/python3
"""Open3D peer for bench/reconstruct_bench (protocol: peer_protocol.py).

Open3D's reconstruction system (examples/python/reconstruction_system: make_fragments.py,
register_fragments.py, refine_registration.py, integrate_scene.py, optimize_posegraph.py and
the defaults of initialize_config.py) is not installed with Debian's python3-open3d 0.16.1, so
its four stages are rebuilt here with Open3D's API, stage for stage and with its default
configuration, which the workload passes in parameters.config (n_frames_per_fragment 100,
n_keyframes_per_n_frame 5, max_depth 3.0, depth_scale 1000, max_depth_diff 0.07, voxel_size
0.05, preference_loop_closure_odometry 0.1, preference_loop_closure_registration 5.0,
tsdf_cubic_size 3.0, icp_method "color", global_registration "ransac",
python_multi_threading true):

  make_fragments      per fragment of n_frames_per_fragment consecutive frames: hybrid RGB-D
                      odometry (photometric + geometric term, max_depth_diff) between neighbours,
                      chained into the fragment's poses; keyframe pairs (every
                      n_keyframes_per_n_frame-th frame, all pairs) started from OpenCV's ORB +
                      5-point essential matrix + 3D RANSAC pose (opencv_pose_estimation.py) and
                      refined by the same odometry, as uncertain loop edges. Without OpenCV
                      (cv2) the original skips keyframe pairs; so does this peer, and its output
                      says which. Pose graph: Levenberg-Marquardt with line processes
                      (max_correspondence_distance = max_depth_diff, edge_prune_threshold 0.25,
                      preference_loop_closure_odometry). The fragment's frames fused into a
                      ScalableTSDFVolume (tsdf_cubic_size / 512 voxels, sdf_trunc 0.04, RGB8);
                      its mesh's vertices with colours are the fragment's point cloud (PLY).
  register_fragments  every pair of fragments: voxel_size down-sampling, normals, FPFH;
                      neighbours (t = s + 1) by coloured ICP from the inverse of fragment s's
                      last pose, the others by RANSAC on FPFH matches (mutual filter, 3 points,
                      edge-length 0.9 and distance checkers, 1e6 iterations, 0.999), accepted
                      when the information's [5, 5] / min(points) >= 0.3; pose graph optimised
                      (max_correspondence_distance = 1.4 voxel_size, preference 5.0).
  refine_registration every edge the scene pose graph kept: multi-scale coloured ICP (voxel,
                      voxel / 2, voxel / 4; 50, 30, 14 iterations) from the edge's transform; a
                      new pose graph optimised as above. Camera poses = fragment pose x the
                      frame's pose in its fragment.
  integrate_scene     every frame fused at its pose into one ScalableTSDFVolume (as above);
                      the mesh (with vertex normals) written as PLY.

Like the original (python_multi_threading, joblib), fragments and refinement pairs run in
parallel processes (min(threads, jobs) of them; global registration min(threads // 2, jobs)),
started with multiprocessing's spawn method inside the timed pass, each with OpenMP limited
to threads // processes (as joblib's loky backend limits its workers). The harness's CPU time
counts this process only: the workers' CPU seconds are in the output ("worker_cpu_s").

Inputs: frames (text file, one "frame_index color depth" per line, the frames in order),
intrinsics (Open3D PinholeCameraIntrinsic JSON), output_folder (each pass writes its
fragments/, scene/ and scene/integrated.ply into output_folder/pass-K). Untimed preparation
lists the frames; reading the images is part of the timed pass, as it is of the system (and of
Locard's side). Differences from the original that do not change its results: each image is
read once per stage instead of once per pair, and each fragment's FPFH features are computed
once instead of once per pair when global registration runs in this process.

Run with Debian's interpreter (/usr/bin/python3), which has python3-open3d (python3-opencv
for the keyframe loop closures).
"""
import math
import multiprocessing
import os
import resource
import time

# OpenMP threads sleep while they wait instead of spinning (unless the caller chose): on a
# shared machine spinning threads of several processes slowed Open3D's odometry and TSDF
# integration 3-4 times; on idle cores the difference is a few microseconds per region.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import numpy as np  # noqa: E402
import open3d as o3d  # noqa: E402

from peer_protocol import serve  # noqa: E402

try:
    import cv2  # noqa: E402
except ImportError:  # the original's initialize_opencv(): no keyframe loop closures then
    cv2 = None

reg = o3d.pipelines.registration
odometry = o3d.pipelines.odometry
integration = o3d.pipelines.integration

# initialize_config.py's defaults; the workload's parameters.config overrides them.
DEFAULT_CONFIG = {
    "n_frames_per_fragment": 100,
    "n_keyframes_per_n_frame": 5,
    "min_depth": 0.3,
    "max_depth": 3.0,
    "voxel_size": 0.05,
    "max_depth_diff": 0.07,
    "depth_scale": 1000.0,
    "preference_loop_closure_odometry": 0.1,
    "preference_loop_closure_registration": 5.0,
    "tsdf_cubic_size": 3.0,
    "icp_method": "color",
    "global_registration": "ransac",
    "python_multi_threading": True,
}


# ---------------------------------------------------------------------------- shared helpers

def read_rgbd(color, depth, config, intensity):
    return o3d.geometry.RGBDImage.create_from_color_and_depth(
        color, depth, depth_scale=config["depth_scale"], depth_trunc=config["max_depth"],
        convert_rgb_to_intensity=intensity)


def read_images(frame):
    _, color_path, depth_path = frame
    return o3d.io.read_image(color_path), o3d.io.read_image(depth_path)


def intrinsic_of(job):
    return o3d.io.read_pinhole_camera_intrinsic(job["intrinsics"])


def optimize(graph, max_correspondence_distance, preference_loop_closure):
    """optimize_posegraph.py's run_posegraph_optimization, in memory."""
    option = reg.GlobalOptimizationOption(
        max_correspondence_distance=max_correspondence_distance, edge_prune_threshold=0.25,
        preference_loop_closure=preference_loop_closure, reference_node=0)
    reg.global_optimization(graph, reg.GlobalOptimizationLevenbergMarquardt(),
                            reg.GlobalOptimizationConvergenceCriteria(), option)
    return graph


def new_volume(config):
    return integration.ScalableTSDFVolume(
        voxel_length=config["tsdf_cubic_size"] / 512.0, sdf_trunc=0.04,
        color_type=integration.TSDFVolumeColorType.RGB8)


def fragment_path(folder, template, fragment_id):
    return os.path.join(folder, "fragments", template % fragment_id)


def parallel_map(function, jobs, processes, threads):
    """joblib.Parallel in the original: worker processes (spawned: fork is unsafe once OpenMP
    has run), each with OpenMP limited to threads // processes, as joblib's loky backend
    limits its workers' inner thread pools; one process: in this process, all threads."""
    processes = min(processes, len(jobs))
    if processes <= 1:
        return [function(*args) for args in jobs]
    previous = os.environ.get("OMP_NUM_THREADS")
    os.environ["OMP_NUM_THREADS"] = str(max(1, threads // processes))
    try:
        pool = multiprocessing.get_context("spawn").Pool(processes)
    finally:
        if previous is None:
            del os.environ["OMP_NUM_THREADS"]
        else:
            os.environ["OMP_NUM_THREADS"] = previous
    try:
        return pool.starmap(function, jobs)
    finally:
        pool.close()
        pool.join()


# ---------------------------------------------------------------------------- make_fragments

def keyframe_initial_pose(source, target, intrinsic, rng):
    """opencv_pose_estimation.py's pose_estimation: ORB matches, 5-point RANSAC, then a rigid
    3D RANSAC on the back-projected inliers. Returns (success, T_target_source)."""
    color_s = np.uint8(np.asarray(source.color) * 255.0)
    color_t = np.uint8(np.asarray(target.color) * 255.0)
    orb = cv2.ORB_create(scaleFactor=1.2, nlevels=8, edgeThreshold=31, firstLevel=0, WTA_K=2,
                         scoreType=cv2.ORB_HARRIS_SCORE, nfeatures=100, patchSize=31)
    kp_s, des_s = orb.detectAndCompute(color_s, None)
    kp_t, des_t = orb.detectAndCompute(color_t, None)
    if not kp_s or not kp_t or des_s is None or des_t is None:
        return False, np.identity(4)
    matches = cv2.BFMatcher(cv2.NORM_HAMMING, crossCheck=True).match(des_s, des_t)
    if len(matches) < 5:
        return False, np.identity(4)
    pts_s = np.array([kp_s[m.queryIdx].pt for m in matches])
    pts_t = np.array([kp_t[m.trainIdx].pt for m in matches])
    K = intrinsic.intrinsic_matrix
    focal = (K[0, 0] + K[1, 1]) / 2.0
    pp = (K[0, 2], K[1, 2])
    _, mask = cv2.findEssentialMat(np.int32(pts_s + 0.5), np.int32(pts_t + 0.5), focal=focal,
                                   pp=pp, method=cv2.RANSAC, prob=0.999, threshold=1.0)
    if mask is None:
        return False, np.identity(4)
    keep = mask.ravel() != 0
    xyz_s = back_project(pts_s[keep], np.asarray(source.depth), pp, focal)
    xyz_t = back_project(pts_t[keep], np.asarray(target.depth), pp, focal)
    return rigid_ransac(xyz_s, xyz_t, rng)


def back_project(pts, depth, pp, focal):
    """get_xyz_from_pts: bilinear depth, (0, 0, 0) near the border."""
    out = np.zeros((len(pts), 3))
    h, w = depth.shape
    for i, (u, v) in enumerate(pts):
        u0, v0 = int(u), int(v)
        if 0 < u0 < w - 1 and 0 < v0 < h - 1:
            du, dv = u - u0, v - v0
            d = ((1 - dv) * (depth[v0, u0 + 1] * du + depth[v0, u0] * (1 - du)) +
                 dv * (depth[v0 + 1, u0 + 1] * du + depth[v0 + 1, u0] * (1 - du)))
            out[i] = ((u - pp[0]) / focal * d, (v - pp[1]) / focal * d, d)
    return out


def rigid_ransac(xyz_s, xyz_t, rng, iterations=1000, max_distance=0.05, sample=5):
    """estimate_3D_transform_RANSAC, vectorised over its 1000 iterations: the first sample with
    the most inliers (more than `sample`) whose rotation has a positive diagonal."""
    n = len(xyz_s)
    if n < sample:
        return False, np.identity(4)
    idx = rng.integers(n, size=(iterations, sample))
    s, t = xyz_s[idx], xyz_t[idx]  # (iterations, sample, 3)
    ms, mt = s.mean(axis=1, keepdims=True), t.mean(axis=1, keepdims=True)
    H = np.einsum("kni,knj->kij", s - ms, t - mt)
    U, _, Vt = np.linalg.svd(H)
    D = np.tile(np.identity(3), (iterations, 1, 1))
    D[:, 2, 2] = np.sign(np.linalg.det(np.einsum("kji,klj->kil", Vt, U)))
    D[D[:, 2, 2] == 0, 2, 2] = 1.0
    R = np.einsum("kji,kjl,klm->kim", Vt, D, np.transpose(U, (0, 2, 1)))
    trans = mt[:, 0, :] - np.einsum("kij,kj->ki", R, ms[:, 0, :])
    moved = np.einsum("kij,nj->kni", R, xyz_s) + trans[:, None, :]
    inliers = (np.linalg.norm(moved - xyz_t[None], axis=2) < max_distance).sum(axis=1)
    valid = (inliers > sample) & (np.diagonal(R, axis1=1, axis2=2) > 0).all(axis=1)
    if not valid.any():
        return False, np.identity(4)
    best = int(np.argmax(np.where(valid, inliers, -1)))
    T = np.identity(4)
    T[:3, :3] = R[best]
    T[:3, 3] = trans[best]
    return True, T


def rgbd_odometry(source, target, intrinsic, init, config):
    option = odometry.OdometryOption()
    option.depth_diff_max = config["max_depth_diff"]
    return odometry.compute_rgbd_odometry(source, target, intrinsic, init,
                                          odometry.RGBDOdometryJacobianFromHybridTerm(), option)


def make_fragment(job, fragment_id):
    """make_fragments.py's process_single_fragment: pose graph, optimisation, fragment cloud."""
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    config, frames = job["config"], job["frames"]
    intrinsic = intrinsic_of(job)
    per = config["n_frames_per_fragment"]
    every = config["n_keyframes_per_n_frame"]
    sid, eid = fragment_id * per, min((fragment_id + 1) * per, len(frames))
    images = [read_images(frames[i]) for i in range(sid, eid)]  # colour and depth, once
    gray = {}

    def intensity(i):
        if i not in gray:
            gray[i] = read_rgbd(*images[i - sid], config, True)
        return gray[i]

    # Odometry between neighbours and keyframe pairs (all pairs of multiples of `every`), as
    # make_posegraph_for_fragment's double loop pairs them; results are pair by pair.
    pairs = {}
    for s in range(sid, eid - 1):
        pairs[(s, s + 1)] = rgbd_odometry(intensity(s), intensity(s + 1), intrinsic,
                                          np.identity(4), config)
        if s % every:
            gray.pop(s, None)  # only keyframes are needed again
    tried = accepted = 0
    if cv2 is not None:
        keys = [k for k in range(sid, eid) if k % every == 0]
        for a, s in enumerate(keys):
            for t in keys[a + 1:]:
                if t == s + 1:
                    continue  # already an odometry pair
                tried += 1
                rng = np.random.default_rng(job["seed"] * 1000003 + s * 1009 + t)
                ok, init = keyframe_initial_pose(intensity(s), intensity(t), intrinsic, rng)
                if ok:
                    pairs[(s, t)] = rgbd_odometry(intensity(s), intensity(t), intrinsic, init,
                                                  config)
                    accepted += bool(pairs[(s, t)][0])
    gray.clear()

    graph = reg.PoseGraph()
    graph.nodes.append(reg.PoseGraphNode(np.identity(4)))
    chain = np.identity(4)  # frame sid's coordinates -> the current frame's
    failed_odometry = 0
    for s in range(sid, eid):
        for t in range(s + 1, eid):
            if t == s + 1:
                success, trans, info = pairs[(s, t)]
                failed_odometry += not success
                chain = trans @ chain
                graph.nodes.append(reg.PoseGraphNode(np.linalg.inv(chain)))
                graph.edges.append(reg.PoseGraphEdge(s - sid, t - sid, trans, info,
                                                     uncertain=False))
            elif (s, t) in pairs and pairs[(s, t)][0]:
                _, trans, info = pairs[(s, t)]
                graph.edges.append(reg.PoseGraphEdge(s - sid, t - sid, trans, info,
                                                     uncertain=True))
    folder = job["folder"]
    o3d.io.write_pose_graph(fragment_path(folder, "fragment_%03d.json", fragment_id), graph)
    optimize(graph, config["max_depth_diff"], config["preference_loop_closure_odometry"])
    o3d.io.write_pose_graph(
        fragment_path(folder, "fragment_optimized_%03d.json", fragment_id), graph)

    volume = new_volume(config)
    for k, node in enumerate(graph.nodes):
        volume.integrate(read_rgbd(*images[k], config, False), intrinsic, np.linalg.inv(node.pose))
    mesh = volume.extract_triangle_mesh()
    mesh.compute_vertex_normals()
    cloud = o3d.geometry.PointCloud()
    cloud.points = mesh.vertices
    cloud.colors = mesh.vertex_colors
    o3d.io.write_point_cloud(fragment_path(folder, "fragment_%03d.ply", fragment_id), cloud,
                             False, True)
    return {"frames": eid - sid, "keyframe_pairs": tried, "loop_edges": accepted,
            "failed_odometry": failed_odometry}


# ---------------------------------------------------------------------------- register / refine

_PREPROCESSED = {}  # (ply path) -> (down-sampled cloud, FPFH), per process


def preprocess(path, voxel):
    if path not in _PREPROCESSED:
        cloud = o3d.io.read_point_cloud(path)
        down = cloud.voxel_down_sample(voxel)
        down.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=voxel * 2.0, max_nn=30))
        fpfh = reg.compute_fpfh_feature(
            down, o3d.geometry.KDTreeSearchParamHybrid(radius=voxel * 5.0, max_nn=100))
        _PREPROCESSED[path] = (down, fpfh)
    return _PREPROCESSED[path]


def multiscale_icp(source, target, voxels, iterations, config, init):
    """refine_registration.py's multiscale_icp with icp_method "color" (or the others)."""
    T = init
    distance = config["voxel_size"] * 1.4
    information = np.identity(6)
    for k, (voxel, count) in enumerate(zip(voxels, iterations)):
        s = source.voxel_down_sample(voxel)
        t = target.voxel_down_sample(voxel)
        method = config["icp_method"]
        if method == "point_to_point":
            result = reg.registration_icp(s, t, distance, T,
                                          reg.TransformationEstimationPointToPoint(),
                                          reg.ICPConvergenceCriteria(max_iteration=count))
        else:
            search = o3d.geometry.KDTreeSearchParamHybrid(radius=voxel * 2.0, max_nn=30)
            s.estimate_normals(search)
            t.estimate_normals(search)
            if method == "point_to_plane":
                result = reg.registration_icp(s, t, distance, T,
                                              reg.TransformationEstimationPointToPlane(),
                                              reg.ICPConvergenceCriteria(max_iteration=count))
            elif method == "color":
                result = reg.registration_colored_icp(
                    s, t, distance, T, reg.TransformationEstimationForColoredICP(),
                    reg.ICPConvergenceCriteria(relative_fitness=1e-6, relative_rmse=1e-6,
                                               max_iteration=count))
            else:
                result = reg.registration_generalized_icp(
                    s, t, distance, T, reg.TransformationEstimationForGeneralizedICP(),
                    reg.ICPConvergenceCriteria(relative_fitness=1e-6, relative_rmse=1e-6,
                                               max_iteration=count))
        T = result.transformation
        if k == len(voxels) - 1:
            information = reg.get_information_matrix_from_point_clouds(s, t, voxel * 1.4, T)
    return T, information


def global_registration(source, target, source_fpfh, target_fpfh, config, seed):
    """register_fragments.py's register_point_cloud_fpfh."""
    distance = config["voxel_size"] * 1.4
    o3d.utility.random.seed(seed)
    if config["global_registration"] == "fgr":
        result = reg.registration_fgr_based_on_feature_matching(
            source, target, source_fpfh, target_fpfh,
            reg.FastGlobalRegistrationOption(maximum_correspondence_distance=distance))
    else:
        result = reg.registration_ransac_based_on_feature_matching(
            source, target, source_fpfh, target_fpfh, True, distance,
            reg.TransformationEstimationPointToPoint(False), 3,
            [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9),
             reg.CorrespondenceCheckerBasedOnDistance(distance)],
            reg.RANSACConvergenceCriteria(1000000, 0.999))
    if np.trace(result.transformation) == 4.0:
        return False, np.identity(4), np.zeros((6, 6))
    information = reg.get_information_matrix_from_point_clouds(source, target, distance,
                                                               result.transformation)
    if information[5, 5] / min(len(source.points), len(target.points)) < 0.3:
        return False, np.identity(4), np.zeros((6, 6))
    return True, result.transformation, information


def register_pair(job, s, t):
    """register_fragments.py's register_point_cloud_pair."""
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    config, folder = job["config"], job["folder"]
    source, source_fpfh = preprocess(fragment_path(folder, "fragment_%03d.ply", s),
                                     config["voxel_size"])
    target, target_fpfh = preprocess(fragment_path(folder, "fragment_%03d.ply", t),
                                     config["voxel_size"])
    if t == s + 1:  # odometry case: start from fragment s's last pose
        graph = o3d.io.read_pose_graph(fragment_path(folder, "fragment_optimized_%03d.json", s))
        init = np.linalg.inv(graph.nodes[len(graph.nodes) - 1].pose)
        T, information = multiscale_icp(source, target, [config["voxel_size"]], [50], config,
                                        init)
        return True, T, information
    return global_registration(source, target, source_fpfh, target_fpfh, config,
                               job["seed"] * 1009 + s * 31 + t)


def refine_pair(job, s, t, init):
    """refine_registration.py's register_point_cloud_pair (local_refinement)."""
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    config, folder = job["config"], job["folder"]
    source = o3d.io.read_point_cloud(fragment_path(folder, "fragment_%03d.ply", s))
    target = o3d.io.read_point_cloud(fragment_path(folder, "fragment_%03d.ply", t))
    v = config["voxel_size"]
    return multiscale_icp(source, target, [v, v / 2.0, v / 4.0], [50, 30, 14], config,
                          np.asarray(init))


def scene_graph(results):
    """update_posegraph_for_scene over the pair results, in their order."""
    graph = reg.PoseGraph()
    chain = np.identity(4)
    graph.nodes.append(reg.PoseGraphNode(chain))
    for s, t, T, information in results:
        if t == s + 1:
            chain = T @ chain
            graph.nodes.append(reg.PoseGraphNode(np.linalg.inv(chain)))
            graph.edges.append(reg.PoseGraphEdge(s, t, T, information, uncertain=False))
        else:
            graph.edges.append(reg.PoseGraphEdge(s, t, T, information, uncertain=True))
    return graph


# ---------------------------------------------------------------------------- the kernel

def prepare(task):
    frames = []
    with open(task["inputs"]["frames"]) as f:
        for line in f:
            if line.strip():
                index, color, depth = line.split()
                frames.append((int(index), color, depth))
    config = dict(DEFAULT_CONFIG)
    config.update(task["parameters"].get("config", {}))
    return {"frames": frames, "config": config, "passes": 0}


def children_cpu():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def reconstruction_system(state, task):
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    config, frames = state["config"], state["frames"]
    state["passes"] += 1
    folder = os.path.join(task["inputs"]["output_folder"], f"pass-{state['passes']}")
    os.makedirs(os.path.join(folder, "fragments"), exist_ok=True)
    os.makedirs(os.path.join(folder, "scene"), exist_ok=True)
    job = {"config": config, "frames": frames, "intrinsics": task["inputs"]["intrinsics"],
           "folder": folder, "seed": int(task["parameters"].get("seed", 0))}
    threads = max(1, int(task.get("threads") or os.cpu_count()))
    parallel = bool(config["python_multi_threading"])
    per = config["n_frames_per_fragment"]
    n_fragments = int(math.ceil(len(frames) / per))
    stage_s = []  # [name, seconds] in the order the stages ran
    cpu0 = children_cpu()

    # 1. make fragments
    start = time.perf_counter()
    made = parallel_map(make_fragment, [(job, i) for i in range(n_fragments)],
                        threads if parallel else 1, threads)
    stage_s.append(["make_fragments", time.perf_counter() - start])

    # 2. register fragments (the original: cpu_count // 2 processes)
    start = time.perf_counter()
    _PREPROCESSED.clear()
    pairs = [(s, t) for s in range(n_fragments) for t in range(s + 1, n_fragments)]
    found = parallel_map(register_pair, [(job, s, t) for s, t in pairs],
                         max(1, threads // 2) if parallel else 1, threads)
    _PREPROCESSED.clear()
    graph = scene_graph([(s, t, T, info) for (s, t), (ok, T, info) in zip(pairs, found) if ok])
    optimize(graph, config["voxel_size"] * 1.4, config["preference_loop_closure_registration"])
    o3d.io.write_pose_graph(os.path.join(folder, "scene", "global_registration_optimized.json"),
                            graph)
    global_edges = len(graph.edges)
    stage_s.append(["register_fragments", time.perf_counter() - start])

    # 3. refine registration: every edge the optimisation kept
    start = time.perf_counter()
    edges = [(e.source_node_id, e.target_node_id, np.asarray(e.transformation))
             for e in graph.edges]
    refined = parallel_map(refine_pair, [(job, s, t, T) for s, t, T in edges],
                           threads if parallel else 1, threads)
    graph = scene_graph([(s, t, T, info) for (s, t, _), (T, info) in zip(edges, refined)])
    optimize(graph, config["voxel_size"] * 1.4, config["preference_loop_closure_registration"])
    o3d.io.write_pose_graph(os.path.join(folder, "scene", "refined_registration_optimized.json"),
                            graph)
    fragment_poses = [np.asarray(node.pose) for node in graph.nodes]
    poses = []
    for fragment_id in range(len(fragment_poses)):
        inner = o3d.io.read_pose_graph(
            fragment_path(folder, "fragment_optimized_%03d.json", fragment_id))
        for k, node in enumerate(inner.nodes):
            poses.append((fragment_id * per + k, fragment_poses[fragment_id] @ node.pose))
    stage_s.append(["refine_registration", time.perf_counter() - start])

    # 4. integrate the scene
    start = time.perf_counter()
    intrinsic = intrinsic_of(job)
    volume = new_volume(config)
    for k, pose in poses:
        volume.integrate(read_rgbd(*read_images(frames[k]), config, False), intrinsic,
                         np.linalg.inv(pose))
    mesh = volume.extract_triangle_mesh()
    mesh.compute_vertex_normals()
    mesh_path = os.path.join(folder, "scene", "integrated.ply")
    o3d.io.write_triangle_mesh(mesh_path, mesh, False, True)
    stage_s.append(["integrate_scene", time.perf_counter() - start])

    return {
        "trajectory": [[frames[k][0]] + [float(x) for x in np.asarray(T).reshape(-1)]
                       for k, T in poses],
        "frames": len(frames),
        "fragments": n_fragments,
        "fragments_placed": len(fragment_poses),
        "mesh": mesh_path,
        "vertices": len(mesh.vertices),
        "triangles": len(mesh.triangles),
        "stage_seconds": stage_s,
        "worker_cpu_s": children_cpu() - cpu0,
        "workers": min(threads, n_fragments) if parallel else 1,  # make_fragments' processes
        "keyframe_loop_closures": "opencv " + cv2.__version__ if cv2 is not None
                                  else "none (no OpenCV, as in the original)",
        "keyframe_pairs": sum(m["keyframe_pairs"] for m in made),
        "loop_edges": sum(m["loop_edges"] for m in made),
        "failed_odometry": sum(m["failed_odometry"] for m in made),
        "scene_pairs": len(pairs),
        "scene_edges_found": sum(1 for ok, _, _ in found if ok),
        "scene_edges_kept": global_edges,
        "config": config,
    }


if __name__ == "__main__":
    serve("open3d " + o3d.__version__, {"reconstruction_system": (prepare, reconstruction_system)})
