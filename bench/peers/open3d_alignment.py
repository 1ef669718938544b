#!/usr/bin/python3
"""Open3D peer for bench/alignment_bench (protocol: peer_protocol.py), kernel "align_sequence".

Run with Debian's interpreter (/usr/bin/python3), which has python3-open3d 0.16.

  open3d_alignment.py [--rgbd-odometry] TASK.json
inputs:     frames (one "frame_index timestamp color depth" per line, in order), intrinsics
            {"width","height","fx","fy","cx","cy","depth_scale"}
parameters: min_depth_m, max_depth_m, loop_policy {keyframe_interval, loop_min_separation,
            loop_max_distance_m, loop_max_angle_deg, loop_candidates_per_keyframe,
            max_loop_candidates, loop_min_fitness}
Timed pass (frame reading included, as on Locard's side):
  tracking  multi-scale point-to-plane ICP chain frame to frame (voxel 4/2/1 cm, gates
            8/4/2 cm, from the previous relative motion); with --rgbd-odometry, Open3D's hybrid
            RGB-D odometry instead.
  loops     the same candidate policy as Locard (loop_closure.cpp proximity_candidates): from
            the tracked poses, keyframes every keyframe_interval frames plus the last, pairs at
            least loop_min_separation frames apart whose cameras are within loop_max_distance_m
            and whose viewing directions are within loop_max_angle_deg; for each keyframe its
            loop_candidates_per_keyframe nearest earlier ones (score d / d_max + angle /
            angle_max), then max_loop_candidates nearest first overall. Each verified by the
            tracking registration from the tracked relative pose (ICP fitness >=
            loop_min_fitness; odometry: success).
  graph     Open3D's LM global optimisation (line process, prune 0.25, reference node 0).
Output: {"trajectory": [[frame_index, 16 row-major numbers], ...], "loop_edges", "candidates",
"frames"}.
"""
import json
import sys

import numpy as np
import open3d as o3d

from peer_protocol import serve

reg = o3d.pipelines.registration
RGBD_ODOMETRY = "--rgbd-odometry" in sys.argv[1:-1]


def prepare(task):
    frames = []
    with open(task["inputs"]["frames"]) as f:
        for line in f:
            if line.strip():
                index, stamp, color, depth = line.split()
                frames.append((int(index), float(stamp), color, depth))
    k = task["inputs"]["intrinsics"]
    intrinsic = o3d.camera.PinholeCameraIntrinsic(k["width"], k["height"], k["fx"], k["fy"],
                                                  k["cx"], k["cy"])
    return frames, intrinsic, k.get("depth_scale", 1000.0)


def load_rgbd(color, depth, scale, max_depth):
    return o3d.geometry.RGBDImage.create_from_color_and_depth(
        o3d.io.read_image(color), o3d.io.read_image(depth), depth_scale=scale,
        depth_trunc=max_depth, convert_rgb_to_intensity=True)


def cloud_of(rgbd, intrinsic, voxel, min_depth):
    pcd = o3d.geometry.PointCloud.create_from_rgbd_image(rgbd, intrinsic)
    points = np.asarray(pcd.points)
    pcd = pcd.select_by_index(np.flatnonzero(points[:, 2] >= min_depth))
    pcd = pcd.voxel_down_sample(voxel)
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2.5 * voxel, max_nn=30))
    pcd.orient_normals_towards_camera_location(np.zeros(3))
    return pcd


def multiscale_icp(source, target, init):
    T = init
    result = None
    for voxel, gate, iters in ((0.04, 0.08, 30), (0.02, 0.04, 20), (0.01, 0.02, 15)):
        s = source.voxel_down_sample(voxel) if voxel > 0.01 else source
        t = target.voxel_down_sample(voxel) if voxel > 0.01 else target
        result = reg.registration_icp(s, t, gate, T, reg.TransformationEstimationPointToPlane(),
                                      reg.ICPConvergenceCriteria(max_iteration=iters))
        T = result.transformation
    info = reg.get_information_matrix_from_point_clouds(source, target, 0.015, T)
    return T, result.fitness, info


def register(data, i, j, init, policy):
    """T_j_i (frame i into frame j's camera), information, accepted."""
    if RGBD_ODOMETRY:
        rgbds, intrinsic = data
        ok, T, info = o3d.pipelines.odometry.compute_rgbd_odometry(
            rgbds[i], rgbds[j], intrinsic, init,
            o3d.pipelines.odometry.RGBDOdometryJacobianFromHybridTerm(),
            o3d.pipelines.odometry.OdometryOption())
        return T, info, ok
    clouds = data
    T, fitness, info = multiscale_icp(clouds[i], clouds[j], init)
    return T, info, fitness >= policy["loop_min_fitness"]


def loop_candidates(poses, policy):
    n = len(poses)
    keyframes = list(range(0, n, policy["keyframe_interval"]))
    if keyframes[-1] != n - 1:
        keyframes.append(n - 1)
    near = []
    for b in range(len(keyframes)):
        mine = []
        for a in range(b):
            i, j = keyframes[a], keyframes[b]
            if j - i < policy["loop_min_separation"]:
                continue
            d = np.linalg.norm(poses[i][:3, 3] - poses[j][:3, 3])
            cos = np.clip(np.dot(poses[i][:3, 2], poses[j][:3, 2]), -1.0, 1.0)
            angle = np.degrees(np.arccos(cos))
            if d > policy["loop_max_distance_m"] or angle > policy["loop_max_angle_deg"]:
                continue
            mine.append((d / policy["loop_max_distance_m"] + angle / policy["loop_max_angle_deg"],
                         j, i))
        mine.sort(key=lambda c: c[0])  # stable, as Locard's stable_sort
        near.extend(mine[:policy["loop_candidates_per_keyframe"]])
    near.sort(key=lambda c: c[0])
    return near[:policy["max_loop_candidates"]]


def align(prepared, task):
    frames, intrinsic, scale = prepared
    p = task["parameters"]
    policy = p["loop_policy"]
    rgbds = [load_rgbd(c, d, scale, p["max_depth_m"]) for _, _, c, d in frames]
    if RGBD_ODOMETRY:
        data = (rgbds, intrinsic)
    else:
        data = [cloud_of(r, intrinsic, 0.01, p["min_depth_m"]) for r in rgbds]
    graph = reg.PoseGraph()
    poses = [np.identity(4)]
    graph.nodes.append(reg.PoseGraphNode(np.identity(4)))
    motion = np.identity(4)  # T_prev_current of the last step
    for i in range(1, len(frames)):
        T, info, ok = register(data, i, i - 1, motion, {"loop_min_fitness": 0.0})
        if not ok:
            T, info = motion, np.identity(6)
        motion = T
        poses.append(poses[-1] @ T)
        graph.nodes.append(reg.PoseGraphNode(poses[-1]))
        graph.edges.append(reg.PoseGraphEdge(i, i - 1, T, info, uncertain=False))
    candidates = loop_candidates(poses, policy)
    loops = 0
    for _, j, i in candidates:
        init = np.linalg.inv(poses[i]) @ poses[j]
        T, info, ok = register(data, j, i, init, policy)
        if ok:
            graph.edges.append(reg.PoseGraphEdge(j, i, T, info, uncertain=True))
            loops += 1
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    reg.global_optimization(
        graph, reg.GlobalOptimizationLevenbergMarquardt(),
        reg.GlobalOptimizationConvergenceCriteria(),
        reg.GlobalOptimizationOption(max_correspondence_distance=0.015,
                                     edge_prune_threshold=0.25, reference_node=0))
    kept = sum(1 for e in graph.edges if e.uncertain)
    trajectory = [[frames[k][0]] + np.asarray(node.pose).reshape(-1).tolist()
                  for k, node in enumerate(graph.nodes)]
    return {"trajectory": trajectory, "loop_edges": kept, "loops_verified": loops,
            "candidates": len(candidates), "frames": len(frames)}


if __name__ == "__main__":
    name = "open3d " + o3d.__version__ + (" rgbd-odometry" if RGBD_ODOMETRY else " icp")
    serve(name, {"align_sequence": (prepare, align)})
