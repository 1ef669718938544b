#!/usr/bin/python3
"""Open3D peer for Locard's feature tests and bench/features_bench.

Run with Debian's interpreter (/usr/bin/python3), which has python3-open3d.

Tests (src/features/fpfh_test.cpp, iss_keypoints_test.cpp):
  open3d_features.py fpfh  CLOUD RADIUS MAX_NN OUT
      CLOUD is a PLY with normals (or an .xyzn text file). Computes Open3D's FPFH with the
      cloud's own normals and writes the descriptors to OUT as raw little-endian float32,
      33 per point, in point order.
  open3d_features.py iss   CLOUD SALIENT_RADIUS NON_MAX_RADIUS GAMMA21 GAMMA32 MIN_NEIGHBORS OUT
      Open3D's ISS keypoints; writes their positions to OUT as raw float32 x y z triples.

Benchmark (protocol: peer_protocol.py; open3d_features.py TASK.json):
  normals       inputs.cloud (PLY, positions only; read untimed). Timed: a fresh cloud from
                those positions, estimate_normals (KDTreeSearchParamHybrid(normal_radius,
                normal_max_nn)), orient_normals_towards_camera_location(viewpoint).
  normals_fpfh  the same, then compute_fpfh_feature (KDTreeSearchParamHybrid(fpfh_radius,
                fpfh_max_nn)) of every point.
  Output: points, descriptors (normals_fpfh), and the normals ("normals", x y z flat) and
  descriptors ("fpfh", 33 values flat) of points 0, sample_every, 2 * sample_every, ...
"""
import json
import sys

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


# --- benchmark kernels -------------------------------------------------------------------------

def prepare(task):
    cloud = read(task["inputs"]["cloud"])
    if cloud.has_normals():
        sys.exit("open3d_features.py: the benchmark cloud must come without normals")
    return cloud.points  # Vector3dVector; every pass starts from a copy


def normals_of(points, p):
    cloud = o3d.geometry.PointCloud(points)
    cloud.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(
        radius=p["normal_radius"], max_nn=p["normal_max_nn"]))
    cloud.orient_normals_towards_camera_location(np.asarray(p["viewpoint"], dtype=float))
    return cloud


def sampled_normals(cloud, p):
    return np.asarray(cloud.normals)[::p["sample_every"]].ravel().tolist()


def normals(points, task):
    p = task["parameters"]
    cloud = normals_of(points, p)
    return {"points": len(cloud.points), "normals": sampled_normals(cloud, p)}


def normals_fpfh(points, task):
    p = task["parameters"]
    cloud = normals_of(points, p)
    feature = o3d.pipelines.registration.compute_fpfh_feature(
        cloud, o3d.geometry.KDTreeSearchParamHybrid(radius=p["fpfh_radius"],
                                                    max_nn=p["fpfh_max_nn"]))
    data = np.asarray(feature.data)  # 33 x points
    return {"points": len(cloud.points), "descriptors": int(data.shape[1]),
            "normals": sampled_normals(cloud, p),
            "fpfh": data[:, ::p["sample_every"]].T.ravel().tolist()}


def main():
    mode = sys.argv[1] if len(sys.argv) > 1 else ""
    if mode == "fpfh":
        fpfh(sys.argv[2], float(sys.argv[3]), int(sys.argv[4]), sys.argv[5])
    elif mode == "iss":
        iss(sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5]),
            float(sys.argv[6]), int(sys.argv[7]), sys.argv[8])
    else:
        from peer_protocol import serve
        serve("open3d " + o3d.__version__,
              {"normals": (prepare, normals), "normals_fpfh": (prepare, normals_fpfh)})


if __name__ == "__main__":
    main()
