# Run inside Blender (blender -b --factory-startup --python blender_probe.py -- FILE FORMAT UP):
# imports one exported mesh with Blender's own importer and prints what a user would see, as
# one JSON line prefixed "LOCARD_PROBE ": vertex and face counts, the world bounding box in
# metres (Blender's scene unit is the metre, z up), the colour attributes with their values
# per corner, and the material's texture image sampled at each corner's UV.
# FORMAT: glb, fbx or obj; UP: the up axis the OBJ was written with (y or z; ignored otherwise:
# glTF is y-up by specification, FBX says so in its GlobalSettings).
import json
import sys

import numpy

# Debian 12's numpy (1.24) removed the numpy.bool alias Blender 3.4's glTF add-on still uses.
numpy.bool = bool

import bpy  # noqa: E402

MAX_CORNERS = 200000


def import_file(path, fmt, up):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if fmt == "glb":
        bpy.ops.import_scene.gltf(filepath=path)
    elif fmt == "fbx":
        bpy.ops.import_scene.fbx(filepath=path)
    elif fmt == "obj":
        # OBJ cannot say which axis is up: tell the importer what the file was written with.
        if up == "y":
            bpy.ops.wm.obj_import(filepath=path, forward_axis="NEGATIVE_Z", up_axis="Y")
        else:
            bpy.ops.wm.obj_import(filepath=path, forward_axis="Y", up_axis="Z")
    else:
        raise SystemExit("unknown format " + fmt)
    return [o for o in bpy.context.scene.objects if o.type == "MESH"]


def world_vertices(obj):
    mesh = obj.data
    co = numpy.empty(3 * len(mesh.vertices), dtype=numpy.float64)
    mesh.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    m = numpy.array(obj.matrix_world)
    return co @ m[:3, :3].T + m[:3, 3]


def corner_vertex_index(mesh):
    idx = numpy.empty(len(mesh.loops), dtype=numpy.int64)
    mesh.loops.foreach_get("vertex_index", idx)
    return idx


def colour_attributes(mesh):
    out = []
    for attr in mesh.color_attributes:
        n = len(attr.data)
        linear = numpy.empty(4 * n, dtype=numpy.float64)
        srgb = numpy.empty(4 * n, dtype=numpy.float64)
        attr.data.foreach_get("color", linear)
        attr.data.foreach_get("color_srgb", srgb)
        out.append({"name": attr.name, "domain": attr.domain, "type": attr.data_type,
                    "linear": linear.reshape(-1, 4)[:, :3], "srgb": srgb.reshape(-1, 4)[:, :3]})
    return out


def texture_image(obj):
    for slot in obj.material_slots:
        mat = slot.material
        if mat is None or not mat.use_nodes:
            continue
        for node in mat.node_tree.nodes:
            if node.type == "TEX_IMAGE" and node.image is not None and node.image.size[0] > 0:
                return node.image
    return None


def sample_texture(image, uv):
    """Colour (0..255, the image's stored sRGB bytes) at each UV, bilinear like a GPU."""
    w, h = image.size
    px = numpy.empty(w * h * image.channels, dtype=numpy.float32)
    image.pixels.foreach_get(px)  # rows bottom to top, floats 0..1 of the stored bytes
    px = px.reshape(h, w, image.channels)[:, :, :3]
    x = uv[:, 0] * w - 0.5
    y = uv[:, 1] * h - 0.5
    x0 = numpy.clip(numpy.floor(x).astype(int), 0, w - 1)
    y0 = numpy.clip(numpy.floor(y).astype(int), 0, h - 1)
    x1 = numpy.clip(x0 + 1, 0, w - 1)
    y1 = numpy.clip(y0 + 1, 0, h - 1)
    fx = numpy.clip(x - x0, 0, 1)[:, None]
    fy = numpy.clip(y - y0, 0, 1)[:, None]
    c = (px[y0, x0] * (1 - fx) * (1 - fy) + px[y0, x1] * fx * (1 - fy) +
         px[y1, x0] * (1 - fx) * fy + px[y1, x1] * fx * fy)
    return 255.0 * c


def probe(objects):
    result = {"objects": len(objects), "vertices": 0, "faces": 0, "colour_attributes": [],
              "texture": None, "unit_system": bpy.context.scene.unit_settings.system,
              "unit_scale": bpy.context.scene.unit_settings.scale_length}
    positions, corner_pos, corner_colours, corner_tex = [], [], {}, []
    for obj in objects:
        mesh = obj.data
        result["vertices"] += len(mesh.vertices)
        result["faces"] += len(mesh.polygons)
        world = world_vertices(obj)
        positions.append(world)
        corners = world[corner_vertex_index(mesh)]
        corner_pos.append(corners)
        for attr in colour_attributes(mesh):
            values = attr["linear"], attr["srgb"]
            if attr["domain"] == "POINT":
                values = tuple(v[corner_vertex_index(mesh)] for v in values)
            key = (attr["name"], attr["domain"], attr["type"])
            corner_colours.setdefault(key, []).append(values)
        image = texture_image(obj)
        if image is not None and mesh.uv_layers.active is not None:
            uv = numpy.empty(2 * len(mesh.loops), dtype=numpy.float64)
            mesh.uv_layers.active.data.foreach_get("uv", uv)
            corner_tex.append(sample_texture(image, uv.reshape(-1, 2)))
            result["texture"] = {"image": image.name, "size": list(image.size)}
    return result, positions, corner_pos, corner_colours, corner_tex


def main():
    argv = sys.argv[sys.argv.index("--") + 1:]
    path, fmt, up = argv[0], argv[1], argv[2]
    objects = import_file(path, fmt, up)
    result, positions, corner_pos, corner_colours, corner_tex = probe(objects)
    if positions:
        allpos = numpy.concatenate(positions)
        result["bbox_min"] = allpos.min(axis=0).tolist()
        result["bbox_max"] = allpos.max(axis=0).tolist()
        corners = numpy.concatenate(corner_pos)
        # Corners and their colours, 0..255, for the caller to compare with the reference; a
        # large case's are thinned to every k-th (the JSON stays a few MB).
        pick = slice(None, None, max(1, -(-len(corners) // MAX_CORNERS)))
        result["corners"] = corners[pick].round(6).tolist()
        for (name, domain, kind), parts in corner_colours.items():
            linear = numpy.concatenate([p[0] for p in parts])
            srgb = numpy.concatenate([p[1] for p in parts])
            result["colour_attributes"].append(
                {"name": name, "domain": domain, "type": kind,
                 "linear": (255.0 * linear[pick]).round(2).tolist(),
                 "srgb": (255.0 * srgb[pick]).round(2).tolist()})
        if corner_tex:
            result["texture"]["corner_colours"] = numpy.concatenate(corner_tex)[pick].round(2).tolist()
    print("LOCARD_PROBE " + json.dumps(result))


main()
