#!/usr/bin/python3
"""Open3D peer for bench/filters_bench: voxel down-sampling of the same PLY cloud.

  open3d_filters.py CLOUD VOXEL_SIZE REPEATS

Reads CLOUD (written by Locard's PLY writer, with colours), then times
PointCloud.voxel_down_sample(VOXEL_SIZE) REPEATS times with time.perf_counter (wall) and
time.process_time (CPU, all threads) and prints JSON with the best of each. Run with Debian's interpreter (/usr/bin/python3), which has python3-open3d.
"""
import json
import sys
import time

import open3d as o3d


def main():
    path, voxel, repeats = sys.argv[1], float(sys.argv[2]), int(sys.argv[3])
    cloud = o3d.io.read_point_cloud(path)
    best, best_cpu, out_points = float("inf"), float("inf"), 0
    for _ in range(repeats):
        cpu_start = time.process_time()
        start = time.perf_counter()
        down = cloud.voxel_down_sample(voxel)
        best = min(best, time.perf_counter() - start)
        best_cpu = min(best_cpu, time.process_time() - cpu_start)
        out_points = len(down.points)
    print(json.dumps({"peer": "open3d " + o3d.__version__, "points": len(cloud.points),
                      "output_points": out_points, "seconds": best, "cpu_seconds": best_cpu}))


if __name__ == "__main__":
    main()
