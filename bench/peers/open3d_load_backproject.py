#!/usr/bin/python3
"""Open3D peer for bench/load_backproject_bench (protocol: peer_protocol.py).

  load_backproject  inputs.frames: [{"color", "depth"}] image files; nothing is read untimed.
                    Timed: for every frame, read_image (colour, depth),
                    RGBDImage.create_from_color_and_depth (parameters.depth_scale,
                    depth_trunc = parameters.depth_max, colour kept) and
                    PointCloud.create_from_rgbd_image with the parameters' pinhole intrinsics,
                    frame by frame as an Open3D user would (these calls hold the GIL, so a
                    thread pool gains nothing). Output: point count per frame and, for every
                    parameters.checked_every-th frame, the sums of x, y, z and of r, g, b (0-255).
Open3D drops depth 0 and depth beyond depth_trunc; parameters.depth_min (0) cuts nothing more.
Run with Debian's interpreter (/usr/bin/python3), which has python3-open3d.
"""
import numpy as np
import open3d as o3d

from peer_protocol import serve


def prepare(task):
    p = task["parameters"]
    if p["depth_min"] > 0:
        raise SystemExit("open3d_load_backproject.py: depth_min > 0 is not supported")
    intrinsic = o3d.camera.PinholeCameraIntrinsic(p["width"], p["height"], p["fx"], p["fy"],
                                                  p["cx"], p["cy"])
    frames = [(f["color"], f["depth"]) for f in task["inputs"]["frames"]]
    return intrinsic, frames


def load_backproject(state, task):
    intrinsic, frames = state
    p = task["parameters"]
    every = p["checked_every"]
    points, sums = [], []
    for i, (color_file, depth_file) in enumerate(frames):
        color = o3d.io.read_image(color_file)
        depth = o3d.io.read_image(depth_file)
        rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
            color, depth, depth_scale=p["depth_scale"], depth_trunc=p["depth_max"],
            convert_rgb_to_intensity=False)
        cloud = o3d.geometry.PointCloud.create_from_rgbd_image(rgbd, intrinsic)
        points.append(len(cloud.points))
        if i % every == 0:
            xyz = np.asarray(cloud.points).sum(axis=0)
            rgb = 255.0 * np.asarray(cloud.colors).sum(axis=0)
            sums.append([float(v) for v in xyz] + [float(v) for v in rgb])
    return {"frames": len(frames), "points": sum(points), "frame_points": points,
            "checked_sums": sums}


if __name__ == "__main__":
    serve("open3d " + o3d.__version__, {"load_backproject": (prepare, load_backproject)})
