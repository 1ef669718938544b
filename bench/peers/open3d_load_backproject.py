#!/usr/bin/python3
"""Open3D peer for bench/load_backproject_bench: reads every 7-Scenes frame that has images and
back-projects it with colour, the way an Open3D user would, and prints JSON timings.

Run with Debian's interpreter (/usr/bin/python3), which has python3-open3d.
"""
import glob
import json
import os
import sys
import time

import open3d as o3d


def main():
    folder, repeats = sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 3
    depth_files = sorted(glob.glob(os.path.join(folder, "frame-*.depth.png")))
    pairs = []
    for d in depth_files:
        c = d.replace(".depth.png", ".color.jpg")
        if not os.path.exists(c):
            c = d.replace(".depth.png", ".color.png")
        if os.path.exists(c):
            pairs.append((c, d))
    intrinsic = o3d.camera.PinholeCameraIntrinsic(640, 480, 585.0, 585.0, 320.0, 240.0)
    best, points = float("inf"), 0
    for _ in range(repeats):
        start = time.perf_counter()
        points = 0
        for c, d in pairs:
            color = o3d.io.read_image(c)
            depth = o3d.io.read_image(d)
            rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
                color, depth, depth_scale=1000.0, depth_trunc=10.0,
                convert_rgb_to_intensity=False)
            cloud = o3d.geometry.PointCloud.create_from_rgbd_image(rgbd, intrinsic)
            points += len(cloud.points)
        best = min(best, time.perf_counter() - start)
    print(json.dumps({"peer": "open3d " + o3d.__version__, "frames": len(pairs),
                      "seconds": best, "fps": len(pairs) / best, "points": points}))


if __name__ == "__main__":
    main()
