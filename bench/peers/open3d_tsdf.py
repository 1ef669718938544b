#!/usr/bin/python3
"""Open3D peer for bench/tsdf_bench: ScalableTSDFVolume integration of the 7-Scenes subset at
the ground-truth poses, then extract_triangle_mesh, with the same voxel size, truncation, depth
range and frames as Locard. Images are decoded before the clock starts (as in the Locard
benchmark); the time is integrate + extract. Prints one JSON object, including ru_maxrss.

Usage: /usr/bin/python3 open3d_tsdf.py DATA_DIR VOXEL TRUNC MAX_DEPTH FRAME_STEP
"""
import glob
import json
import os
import resource
import sys
import time

import numpy as np
import open3d as o3d


def main():
    folder = sys.argv[1]
    voxel, trunc, max_depth = float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
    step = int(sys.argv[5]) if len(sys.argv) > 5 else 1
    depth_files = sorted(glob.glob(os.path.join(folder, "frame-*.depth.png")))[::step]
    intrinsic = o3d.camera.PinholeCameraIntrinsic(640, 480, 585.0, 585.0, 320.0, 240.0)
    rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    volume = o3d.pipelines.integration.ScalableTSDFVolume(
        voxel_length=voxel, sdf_trunc=trunc,
        color_type=o3d.pipelines.integration.TSDFVolumeColorType.RGB8)
    integrate_s = 0.0
    frames = 0
    for d in depth_files:
        c = d.replace(".depth.png", ".color.jpg")
        pose = np.loadtxt(d.replace(".depth.png", ".pose.txt"))
        depth = np.asarray(o3d.io.read_image(d)).copy()
        depth[depth == 65535] = 0  # 7-Scenes' "no reading"
        rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
            o3d.io.read_image(c), o3d.geometry.Image(depth), depth_scale=1000.0,
            depth_trunc=max_depth, convert_rgb_to_intensity=False)
        extrinsic = np.linalg.inv(pose)
        start = time.perf_counter()
        volume.integrate(rgbd, intrinsic, extrinsic)
        integrate_s += time.perf_counter() - start
        frames += 1
    start = time.perf_counter()
    mesh = volume.extract_triangle_mesh()
    extract_s = time.perf_counter() - start
    print(json.dumps({
        "peer": "open3d " + o3d.__version__, "frames": frames,
        "integrate_seconds": integrate_s, "extract_seconds": extract_s,
        "seconds": integrate_s + extract_s,
        "vertices": len(mesh.vertices), "triangles": len(mesh.triangles),
        "max_rss_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
        "rss_before_kib": rss_before}))


if __name__ == "__main__":
    main()
