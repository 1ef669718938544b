#!/usr/bin/python3
"""Open3D peer for Locard's feature tests and bench/features_bench.

Run with Debian's interpreter (/usr/bin/python3), which has python3-open3d.

  open3d_features.py fpfh  CLOUD RADIUS MAX_NN OUT
      CLOUD is a PLY with normals (or an .xyzn text file). Computes Open3D's FPFH with the
      cloud's own normals and writes the descriptors to OUT as raw little-endian float32,
      33 per point, in point order.
  open3d_features.py iss   CLOUD SALIENT_RADIUS NON_MAX_RADIUS GAMMA21 GAMMA32 MIN_NEIGHBORS OUT
      Open3D's ISS keypoints; writes their positions to OUT as raw float32 x y z triples.
  open3d_features.py bench CLOUD NORMAL_RADIUS NORMAL_MAX_NN FPFH_RADIUS FPFH_MAX_NN REPEATS
      Times normals (KDTreeSearchParamHybrid, oriented towards the origin like Locard's
      default) followed by FPFH, best of REPEATS by time.perf_counter (wall) and
      time.process_time (CPU, all threads), and prints JSON.
"""
import json
import sys
import time

import numpy as np
import open3d as o3d


def read(path):
    fmt = "xyzn" if path.endswith(".xyzn") else "auto"
    return o3d.io.read_point_cloud(path, format=fmt)


def fpfh(path, radius, max_nn, out):
    cloud = read(path)
    if not cloud.has_normals():
        sys.exit(f"{path}: the cloud has no normals")
    feature = o3d.pipelines.registration.compute_fpfh_feature(
        cloud, o3d.geometry.KDTreeSearchParamHybrid(radius=radius, max_nn=max_nn))
    np.asarray(feature.data).T.astype("<f4").tofile(out)
    print(json.dumps({"points": len(cloud.points)}))


def iss(path, salient_radius, non_max_radius, gamma21, gamma32, min_neighbors, out):
    cloud = read(path)
    keypoints = o3d.geometry.keypoint.compute_iss_keypoints(
        cloud, salient_radius=salient_radius, non_max_radius=non_max_radius, gamma_21=gamma21,
        gamma_32=gamma32, min_neighbors=min_neighbors)
    np.asarray(keypoints.points).astype("<f4").tofile(out)
    print(json.dumps({"keypoints": len(keypoints.points)}))


def bench(path, normal_radius, normal_max_nn, fpfh_radius, fpfh_max_nn, repeats):
    source = read(path)
    points = np.asarray(source.points)
    best_normals = best_fpfh = best_total = best_cpu = float("inf")
    for _ in range(repeats):
        cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
        cpu_start = time.process_time()
        start = time.perf_counter()
        cloud.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(
            radius=normal_radius, max_nn=normal_max_nn))
        cloud.orient_normals_towards_camera_location(np.zeros(3))
        middle = time.perf_counter()
        feature = o3d.pipelines.registration.compute_fpfh_feature(
            cloud, o3d.geometry.KDTreeSearchParamHybrid(radius=fpfh_radius, max_nn=fpfh_max_nn))
        end = time.perf_counter()
        best_cpu = min(best_cpu, time.process_time() - cpu_start)
        assert feature.data.shape[1] == len(points)
        best_normals = min(best_normals, middle - start)
        best_fpfh = min(best_fpfh, end - middle)
        best_total = min(best_total, end - start)
    print(json.dumps({"peer": "open3d " + o3d.__version__, "points": len(points),
                      "normals_seconds": best_normals, "fpfh_seconds": best_fpfh,
                      "seconds": best_total, "cpu_seconds": best_cpu}))


def main():
    mode = sys.argv[1]
    if mode == "fpfh":
        fpfh(sys.argv[2], float(sys.argv[3]), int(sys.argv[4]), sys.argv[5])
    elif mode == "iss":
        iss(sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5]),
            float(sys.argv[6]), int(sys.argv[7]), sys.argv[8])
    elif mode == "bench":
        bench(sys.argv[2], float(sys.argv[3]), int(sys.argv[4]), float(sys.argv[5]),
              int(sys.argv[6]), int(sys.argv[7]))
    else:
        sys.exit(f"unknown mode {mode}")


if __name__ == "__main__":
    main()
