#!/usr/bin/python3
"""Open3D peer for bench/tsdf_bench (protocol: peer_protocol.py), kernel "tsdf_fusion".

inputs:     frames [{"color", "depth", "T_world_camera" (16 row-major)}], intrinsics, depth_scale
parameters: voxel, truncation, max_depth_m
prepare decodes every image (untimed, as on Locard's side); a timed pass is a fresh
ScalableTSDFVolume (RGB8 colour), integrate every frame at its pose, extract_triangle_mesh.
The output carries ru_maxrss and the resident size before the first volume.
Run with Debian's interpreter (/usr/bin/python3), which has python3-open3d.
"""
import resource

import numpy as np
import open3d as o3d

from peer_protocol import serve


def prepare(task):
    inputs = task["inputs"]
    k = inputs["intrinsics"]
    intrinsic = o3d.camera.PinholeCameraIntrinsic(k["width"], k["height"], k["fx"], k["fy"],
                                                  k["cx"], k["cy"])
    frames = []
    for f in inputs["frames"]:
        depth = np.asarray(o3d.io.read_image(f["depth"])).copy()
        depth[depth == 65535] = 0  # 7-Scenes' "no reading"
        rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
            o3d.io.read_image(f["color"]), o3d.geometry.Image(depth),
            depth_scale=inputs["depth_scale"], depth_trunc=task["parameters"]["max_depth_m"],
            convert_rgb_to_intensity=False)
        pose = np.asarray(f["T_world_camera"], dtype=float).reshape(4, 4)
        frames.append((rgbd, np.linalg.inv(pose)))
    return {"intrinsic": intrinsic, "frames": frames,
            "rss_before_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}


def fuse(state, task):
    import time
    p = task["parameters"]
    volume = o3d.pipelines.integration.ScalableTSDFVolume(
        voxel_length=p["voxel"], sdf_trunc=p["truncation"],
        color_type=o3d.pipelines.integration.TSDFVolumeColorType.RGB8)
    start = time.perf_counter()
    for rgbd, extrinsic in state["frames"]:
        volume.integrate(rgbd, state["intrinsic"], extrinsic)
    integrated = time.perf_counter()
    mesh = volume.extract_triangle_mesh()
    end = time.perf_counter()
    return {"frames": len(state["frames"]), "integrate_seconds": integrated - start,
            "extract_seconds": end - integrated, "vertices": len(mesh.vertices),
            "triangles": len(mesh.triangles),
            "max_rss_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
            "rss_before_kib": state["rss_before_kib"]}


if __name__ == "__main__":
    serve("open3d " + o3d.__version__, {"tsdf_fusion": (prepare, fuse)})
