#!/usr/bin/env python3
"""How consistent are the 7-Scenes reference poses with their own depth images?

For pairs of frames that see the same part of the room far apart in time (revisits), Open3D's
point-to-plane ICP is started AT the reference relative pose inv(T_w_a) T_w_b. If the
reference poses agreed with the depth, ICP would stay there (a few millimetres of noise). It
moves by how far the reference relative pose is from the best geometric fit; fitness and inlier
RMSE are printed at both poses (higher fitness, lower RMSE: the data prefer ICP's pose).

Open3D is only the independent referee here (a reference peer, never a Locard dependency).

    /usr/bin/python3 bench/peers/seven_scenes_ground_truth_check.py ../shared/data/7scenes-tsdf-fusion/data
"""
import sys

import numpy as np
import open3d as o3d

# Revisits: frame pairs 5 to 30 s apart that overlap (found by Locard's loop closure).
PAIRS = [(0, 150), (0, 270), (0, 510), (60, 675), (180, 615), (225, 930)]
VOXEL = 0.01
GATE = 0.02


def cloud(folder, k, intrinsic):
    depth = o3d.io.read_image(f"{folder}/frame-{k:06d}.depth.png")
    pc = o3d.geometry.PointCloud.create_from_depth_image(depth, intrinsic, depth_scale=1000.0,
                                                         depth_trunc=4.0)
    pc = pc.voxel_down_sample(VOXEL)
    pc.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=5 * VOXEL, max_nn=30))
    return pc


def main():
    folder = sys.argv[1] if len(sys.argv) > 1 else "../shared/data/7scenes-tsdf-fusion/data"
    intrinsic = o3d.camera.PinholeCameraIntrinsic(640, 480, 585.0, 585.0, 320.0, 240.0)
    pose = lambda k: np.loadtxt(f"{folder}/frame-{k:06d}.pose.txt")
    moved = []
    print(f"voxel {VOXEL} m, ICP gate {GATE} m, started at the reference relative pose")
    for a, b in PAIRS:
        A, B = cloud(folder, a, intrinsic), cloud(folder, b, intrinsic)
        G = np.linalg.inv(pose(a)) @ pose(b)
        at_ref = o3d.pipelines.registration.evaluate_registration(B, A, GATE, G)
        r = o3d.pipelines.registration.registration_icp(
            B, A, GATE, G, o3d.pipelines.registration.TransformationEstimationPointToPlane(),
            o3d.pipelines.registration.ICPConvergenceCriteria(max_iteration=60))
        E = np.linalg.inv(G) @ r.transformation
        angle = np.degrees(np.arccos(np.clip((np.trace(E[:3, :3]) - 1) / 2, -1, 1)))
        moved.append(1000 * np.linalg.norm(E[:3, 3]))
        print(f"frames {a:3d}-{b:3d}: ICP moves {moved[-1]:5.1f} mm {angle:4.2f} deg from the "
              f"reference; fitness {at_ref.fitness:.3f} -> {r.fitness:.3f}, "
              f"RMSE {1000 * at_ref.inlier_rmse:.1f} -> {1000 * r.inlier_rmse:.1f} mm")
    print(f"median {np.median(moved):.1f} mm, largest {max(moved):.1f} mm")


if __name__ == "__main__":
    main()
