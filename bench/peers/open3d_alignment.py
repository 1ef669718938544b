#!/usr/bin/python3
"""Open3D peer for bench/alignment_bench: whole-sequence alignment of the same frames.

Run with Debian's interpreter (/usr/bin/python3), which has python3-open3d 0.16.

  open3d_alignment.py PIPELINE FRAMES_FILE INTRINSICS_JSON OUT_TRAJECTORY
      FRAMES_FILE: one "frame_index timestamp color.jpg depth.png" per line, in order.
      INTRINSICS_JSON: {"width","height","fx","fy","cx","cy","depth_scale"}.
      PIPELINE:
        icp       multi-scale point-to-plane ICP chain frame to frame (voxel 4/2/1 cm, gates
                  8/4/2 cm, from the previous relative motion), loop edges by ICP between
                  keyframes (every 5th frame) within 1 m of each other and at least 10 frames
                  apart (fitness >= 0.3), LM global optimisation (line process, prune 0.25).
        odometry  hybrid RGB-D odometry (compute_rgbd_odometry, Jacobian hybrid term) frame to
                  frame, loop edges by RGB-D odometry between keyframes as above, LM global
                  optimisation as above.
Writes the estimated trajectory (TUM format) and prints one JSON object with the wall time.
"""
import json
import sys
import time

import numpy as np
import open3d as o3d

reg = o3d.pipelines.registration


def read_frames(path):
    frames = []
    with open(path) as f:
        for line in f:
            if line.strip():
                index, stamp, color, depth = line.split()
                frames.append((int(index), float(stamp), color, depth))
    return frames


def write_tum(path, frames, poses):
    with open(path, "w") as f:
        f.write("# timestamp tx ty tz qx qy qz qw\n")
        for (index, stamp, _, _), T in zip(frames, poses):
            R = T[:3, :3]
            t = T[:3, 3]
            w = np.sqrt(max(1e-12, 1.0 + R[0, 0] + R[1, 1] + R[2, 2])) / 2.0
            x = (R[2, 1] - R[1, 2]) / (4 * w)
            y = (R[0, 2] - R[2, 0]) / (4 * w)
            z = (R[1, 0] - R[0, 1]) / (4 * w)
            f.write(f"{stamp:.6f} {t[0]:.9f} {t[1]:.9f} {t[2]:.9f} {x:.9f} {y:.9f} {z:.9f} {w:.9f}\n")


def load_rgbd(color, depth, scale):
    c = o3d.io.read_image(color)
    d = o3d.io.read_image(depth)
    return o3d.geometry.RGBDImage.create_from_color_and_depth(
        c, d, depth_scale=scale, depth_trunc=4.0, convert_rgb_to_intensity=True)


def cloud_of(rgbd, intrinsic, voxel):
    pcd = o3d.geometry.PointCloud.create_from_rgbd_image(rgbd, intrinsic)
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


def main():
    pipeline, frames_path, intrinsics_path, out_path = sys.argv[1:5]
    frames = read_frames(frames_path)
    with open(intrinsics_path) as f:
        k = json.load(f)
    intrinsic = o3d.camera.PinholeCameraIntrinsic(k["width"], k["height"], k["fx"], k["fy"],
                                                  k["cx"], k["cy"])
    scale = k.get("depth_scale", 1000.0)
    start = time.perf_counter()
    rgbds = [load_rgbd(c, d, scale) for _, _, c, d in frames]
    clouds = [cloud_of(r, intrinsic, 0.01) for r in rgbds] if pipeline == "icp" else None

    graph = reg.PoseGraph()
    poses = [np.identity(4)]
    graph.nodes.append(reg.PoseGraphNode(np.identity(4)))
    motion = np.identity(4)  # T_prev_current of the last step
    option = o3d.pipelines.odometry.OdometryOption()
    for i in range(1, len(frames)):
        if pipeline == "icp":
            T, _, info = multiscale_icp(clouds[i], clouds[i - 1], motion)
        else:
            ok, T, info = o3d.pipelines.odometry.compute_rgbd_odometry(
                rgbds[i], rgbds[i - 1], intrinsic, motion,
                o3d.pipelines.odometry.RGBDOdometryJacobianFromHybridTerm(), option)
            if not ok:
                T, info = motion, np.identity(6)
        motion = T
        poses.append(poses[-1] @ T)
        graph.nodes.append(reg.PoseGraphNode(poses[-1]))
        graph.edges.append(reg.PoseGraphEdge(i, i - 1, T, info, uncertain=False))
    keyframes = list(range(0, len(frames), 5))
    for a in keyframes:
        for b in keyframes:
            if b - a < 10:
                continue
            if np.linalg.norm(poses[a][:3, 3] - poses[b][:3, 3]) > 1.0:
                continue
            init = np.linalg.inv(poses[a]) @ poses[b]
            if pipeline == "icp":
                T, fitness, info = multiscale_icp(clouds[b], clouds[a], init)
                if fitness < 0.3:
                    continue
            else:
                ok, T, info = o3d.pipelines.odometry.compute_rgbd_odometry(
                    rgbds[b], rgbds[a], intrinsic, init,
                    o3d.pipelines.odometry.RGBDOdometryJacobianFromHybridTerm(), option)
                if not ok:
                    continue
            graph.edges.append(reg.PoseGraphEdge(b, a, T, info, uncertain=True))
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    reg.global_optimization(
        graph, reg.GlobalOptimizationLevenbergMarquardt(),
        reg.GlobalOptimizationConvergenceCriteria(),
        reg.GlobalOptimizationOption(max_correspondence_distance=0.015,
                                     edge_prune_threshold=0.25, reference_node=0))
    seconds = time.perf_counter() - start
    write_tum(out_path, frames, [n.pose for n in graph.nodes])
    print(json.dumps({"pipeline": pipeline, "frames": len(frames), "seconds": seconds,
                      "edges": len(graph.edges)}))


if __name__ == "__main__":
    main()
