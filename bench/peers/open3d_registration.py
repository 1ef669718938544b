#!/usr/bin/python3
"""Open3D peer for bench/registration_bench (protocol: peer_protocol.py).

Clouds are the PLY files the benchmark wrote (with normals); features are raw little-endian
float32, 33 per point, in the clouds' point order. Everything is read untimed. Every kernel
returns {"transforms": [row-major 4x4, ...]} in the workload's order (pair-major, seed-minor
for RANSAC), scored by the benchmark's one evaluator.

  ransac_feature_matching  inputs.pairs[]: source, target, source_features, target_features.
      Timed, for every pair and every seed of parameters.seeds: o3d.utility.random.seed(seed),
      registration_ransac_based_on_feature_matching (mutual filter = parameters.mutual,
      point-to-point Kabsch, ransac_n, edge-length and distance checkers,
      RANSACConvergenceCriteria(max_iterations, confidence)); descriptor matching included, as
      on Locard's side.
  ransac_correspondences   inputs.pairs[]: source, target, correspondences (text, one "s t"
      per line). Timed, for every pair and seed: registration_ransac_based_on_correspondence
      with the same estimation, checkers and criteria: RANSAC alone, on identical input.
  icp_point_to_plane       inputs.pairs[]: source, target. Timed, per pair: registration_icp
      point-to-plane from the identity (KD-tree build included) with
      ICPConvergenceCriteria(relative_fitness, relative_rmse, max_iterations); Open3D has no
      step-size criterion (rotation_eps_deg, translation_eps_m are not used).
Run with Debian's interpreter (/usr/bin/python3), which has python3-open3d.
"""
import sys

import numpy as np
import open3d as o3d

from peer_protocol import serve

reg = o3d.pipelines.registration


def load(path):
    cloud = o3d.io.read_point_cloud(path)
    if not cloud.has_normals():
        sys.exit(f"{path}: the cloud has no normals")
    return cloud


def load_features(path, points):
    data = np.fromfile(path, dtype="<f4")
    if data.size != 33 * points:
        sys.exit(f"{path}: {data.size} floats, {33 * points} expected")
    feature = reg.Feature()
    feature.data = data.reshape(points, 33).T.astype(np.float64)
    return feature


def row_major(transformation):
    return np.asarray(transformation).reshape(-1).tolist()


def ransac_setup(task):
    p = task["parameters"]
    checkers = [reg.CorrespondenceCheckerBasedOnEdgeLength(p["edge_length_ratio"]),
                reg.CorrespondenceCheckerBasedOnDistance(p["max_correspondence_distance"])]
    criteria = reg.RANSACConvergenceCriteria(p["max_iterations"], p["confidence"])
    return checkers, criteria


def prepare_ransac_feature_matching(task):
    pairs = []
    for pair in task["inputs"]["pairs"]:
        source, target = load(pair["source"]), load(pair["target"])
        pairs.append((source, target,
                      load_features(pair["source_features"], len(source.points)),
                      load_features(pair["target_features"], len(target.points))))
    return pairs, ransac_setup(task)


def ransac_feature_matching(state, task):
    pairs, (checkers, criteria) = state
    p = task["parameters"]
    transforms = []
    for source, target, fs, ft in pairs:
        for seed in p["seeds"]:
            o3d.utility.random.seed(seed)
            result = reg.registration_ransac_based_on_feature_matching(
                source, target, fs, ft, p["mutual"], p["max_correspondence_distance"],
                reg.TransformationEstimationPointToPoint(False), p["ransac_n"], checkers,
                criteria)
            transforms.append(row_major(result.transformation))
    return {"transforms": transforms}


def prepare_ransac_correspondences(task):
    pairs = []
    for pair in task["inputs"]["pairs"]:
        matches = np.loadtxt(pair["correspondences"], dtype=np.int32, ndmin=2)
        pairs.append((load(pair["source"]), load(pair["target"]),
                      o3d.utility.Vector2iVector(matches)))
    return pairs, ransac_setup(task)


def ransac_correspondences(state, task):
    pairs, (checkers, criteria) = state
    p = task["parameters"]
    transforms = []
    for source, target, corres in pairs:
        for seed in p["seeds"]:
            o3d.utility.random.seed(seed)
            result = reg.registration_ransac_based_on_correspondence(
                source, target, corres, p["max_correspondence_distance"],
                reg.TransformationEstimationPointToPoint(False), p["ransac_n"], checkers,
                criteria)
            transforms.append(row_major(result.transformation))
    return {"transforms": transforms}


def prepare_icp(task):
    p = task["parameters"]
    pairs = [(load(pair["source"]), load(pair["target"])) for pair in task["inputs"]["pairs"]]
    criteria = reg.ICPConvergenceCriteria(relative_fitness=p["relative_fitness"],
                                          relative_rmse=p["relative_rmse"],
                                          max_iteration=p["max_iterations"])
    return pairs, criteria


def icp_point_to_plane(state, task):
    pairs, criteria = state
    distance = task["parameters"]["max_correspondence_distance"]
    estimation = reg.TransformationEstimationPointToPlane()
    transforms = []
    for source, target in pairs:
        result = reg.registration_icp(source, target, distance, np.identity(4), estimation,
                                      criteria)
        transforms.append(row_major(result.transformation))
    return {"transforms": transforms}


if __name__ == "__main__":
    serve("open3d " + o3d.__version__,
          {"ransac_feature_matching": (prepare_ransac_feature_matching, ransac_feature_matching),
           "ransac_correspondences": (prepare_ransac_correspondences, ransac_correspondences),
           "icp_point_to_plane": (prepare_icp, icp_point_to_plane)})
