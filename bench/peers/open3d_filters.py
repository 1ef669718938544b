#!/usr/bin/python3
"""Open3D peer for bench/filters_bench (protocol: peer_protocol.py).

  voxel_down_sample  inputs.cloud (PLY with colours, read untimed); timed:
                     PointCloud.voxel_down_sample(parameters.voxel).
Run with Debian's interpreter (/usr/bin/python3), which has python3-open3d.
"""
import open3d as o3d

from peer_protocol import serve


def prepare(task):
    return o3d.io.read_point_cloud(task["inputs"]["cloud"])


def voxel_down_sample(cloud, task):
    down = cloud.voxel_down_sample(task["parameters"]["voxel"])
    return {"points": len(cloud.points), "voxels": len(down.points)}


if __name__ == "__main__":
    serve("open3d " + o3d.__version__, {"voxel_down_sample": (prepare, voxel_down_sample)})
