#!/usr/bin/python3
"""Open3D peer for bench/registration_bench: the same registrations on the same clouds.

Run with Debian's interpreter (/usr/bin/python3), which has python3-open3d.

  open3d_registration.py icp PAIRS MAX_DISTANCE MAX_ITERATIONS REPEATS
      PAIRS is a text file, one "SOURCE.ply TARGET.ply" per line (clouds with normals).
      Point-to-plane registration_icp from the identity, Open3D's default convergence criteria
      (relative fitness and RMSE 1e-6) with MAX_ITERATIONS. Times every pair (KD-tree build
      included, file reading excluded); total seconds = best of REPEATS.
  open3d_registration.py ransac PAIRS FPFH_RADIUS FPFH_MAX_NN MAX_DISTANCE SEEDS
      PAIRS as above. FPFH with the clouds' own normals (not timed), then for every seed in
      0..SEEDS-1: o3d.utility.random.seed(seed) and
      registration_ransac_based_on_feature_matching (mutual filter, point-to-point Kabsch,
      ransac_n 3, edge-length 0.9 and distance checkers, RANSACConvergenceCriteria(100000,
      0.999)), timed (descriptor matching included, as Locard's side).
  open3d_registration.py ransac_corr PAIRS MAX_DISTANCE SEEDS
      PAIRS lines are "SOURCE.ply TARGET.ply MATCHES.txt", MATCHES holding one "s t" index pair
      per line (the correspondences Locard's RANSAC gets). For every seed:
      registration_ransac_based_on_correspondence with the same estimation, checkers and
      criteria as above, timed: RANSAC alone, on identical input.
Prints one JSON object with the transforms (row-major 4x4), fitness and RMSE per run.
"""
import json
import sys
import time

import numpy as np
import open3d as o3d

reg = o3d.pipelines.registration


def read_pairs(path):
    pairs = []
    with open(path) as f:
        for line in f:
            if line.strip():
                source, target = line.split()
                pairs.append((source, target))
    return pairs


def load(path):
    cloud = o3d.io.read_point_cloud(path)
    if not cloud.has_normals():
        sys.exit(f"{path}: the cloud has no normals")
    return cloud


def icp(pairs_path, max_distance, max_iterations, repeats):
    pairs = [(load(s), load(t)) for s, t in read_pairs(pairs_path)]
    criteria = reg.ICPConvergenceCriteria(relative_fitness=1e-6, relative_rmse=1e-6,
                                          max_iteration=max_iterations)
    estimation = reg.TransformationEstimationPointToPlane()
    best = float("inf")
    runs = []
    for _ in range(repeats):
        total = 0.0
        runs = []
        for source, target in pairs:
            start = time.perf_counter()
            result = reg.registration_icp(source, target, max_distance, np.identity(4),
                                          estimation, criteria)
            total += time.perf_counter() - start
            runs.append({"T": np.asarray(result.transformation).reshape(-1).tolist(),
                         "fitness": result.fitness, "rmse": result.inlier_rmse})
        best = min(best, total)
    print(json.dumps({"peer": "open3d " + o3d.__version__, "pairs": len(pairs),
                      "seconds": best, "runs": runs}))


def ransac(pairs_path, fpfh_radius, fpfh_max_nn, max_distance, seeds):
    search = o3d.geometry.KDTreeSearchParamHybrid(radius=fpfh_radius, max_nn=fpfh_max_nn)
    checkers = [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9),
                reg.CorrespondenceCheckerBasedOnDistance(max_distance)]
    criteria = reg.RANSACConvergenceCriteria(100000, 0.999)
    total = 0.0
    runs = []
    for source_path, target_path in read_pairs(pairs_path):
        source, target = load(source_path), load(target_path)
        fs = reg.compute_fpfh_feature(source, search)
        ft = reg.compute_fpfh_feature(target, search)
        for seed in range(seeds):
            o3d.utility.random.seed(seed)
            start = time.perf_counter()
            result = reg.registration_ransac_based_on_feature_matching(
                source, target, fs, ft, True, max_distance,
                reg.TransformationEstimationPointToPoint(False), 3, checkers, criteria)
            total += time.perf_counter() - start
            runs.append({"T": np.asarray(result.transformation).reshape(-1).tolist(),
                         "fitness": result.fitness, "rmse": result.inlier_rmse})
    print(json.dumps({"peer": "open3d " + o3d.__version__, "seconds": total, "runs": runs}))


def ransac_corr(pairs_path, max_distance, seeds):
    checkers = [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9),
                reg.CorrespondenceCheckerBasedOnDistance(max_distance)]
    criteria = reg.RANSACConvergenceCriteria(100000, 0.999)
    total = 0.0
    runs = []
    with open(pairs_path) as f:
        lines = [line.split() for line in f if line.strip()]
    for source_path, target_path, matches_path in lines:
        source, target = load(source_path), load(target_path)
        matches = np.loadtxt(matches_path, dtype=np.int32, ndmin=2)
        corres = o3d.utility.Vector2iVector(matches)
        for seed in range(seeds):
            o3d.utility.random.seed(seed)
            start = time.perf_counter()
            result = reg.registration_ransac_based_on_correspondence(
                source, target, corres, max_distance,
                reg.TransformationEstimationPointToPoint(False), 3, checkers, criteria)
            total += time.perf_counter() - start
            runs.append({"T": np.asarray(result.transformation).reshape(-1).tolist(),
                         "fitness": result.fitness, "rmse": result.inlier_rmse})
    print(json.dumps({"peer": "open3d " + o3d.__version__, "seconds": total, "runs": runs}))


def main():
    mode = sys.argv[1]
    if mode == "icp":
        icp(sys.argv[2], float(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5]))
    elif mode == "ransac":
        ransac(sys.argv[2], float(sys.argv[3]), int(sys.argv[4]), float(sys.argv[5]),
               int(sys.argv[6]))
    elif mode == "ransac_corr":
        ransac_corr(sys.argv[2], float(sys.argv[3]), int(sys.argv[4]))
    else:
        sys.exit(f"unknown mode {mode}")


if __name__ == "__main__":
    main()
