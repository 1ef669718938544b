#!/usr/bin/env python3
"""Exports re-imported into the tools investigators use (CTest label `reimport`).

    reimport.py fixture --locard LOCARD --work DIR   the reference room and its exports
    reimport.py blender|assimp|cloudcompare|meshlab --work DIR [--tool PATH] [--reference PLY]

`fixture` writes a coloured room (floor and three walls, 4 x 3 x 2.5 m, z up, welded) as
room.ply and has `locard convert` export it: room.glb, room_y.fbx, room_z.fbx, room_y.obj,
room_z.obj (the suffix is --up). Its colour is a known linear function of position,
(255 x / 4, 255 y / 3, 255 z / 2.5), so every tool's colours are checked against the place
they sit, in Locard's frame: a turned, shifted, scaled or mirrored model, or colours on the
wrong triangles, fail. Each tool check prints one line per file (what docs/export-formats.md
tabulates) and exits 1 on any difference beyond its tolerance:

  vertex and face counts equal to what was written; bounding box within 1 mm of the room's in
  metres, z up; colour present and within a few 8-bit steps of the reference at every corner
  or sampled point (the tolerance of each check is stated where it is made).

`--reference PLY` checks a case's own exports instead (mesh.glb, mesh.fbx, mesh.obj beside
it, OBJ and FBX written y-up; mesh_z.fbx, mesh_z.obj z-up where present): counts and box from the PLY, colours against the PLY's colour
at the same position.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

import numpy

ROOM = numpy.array([4.0, 3.0, 2.5])
GRID = 40  # cells per side of each face: a leg changes colour by 255 / 40 = 6.4 steps
HERE = os.path.dirname(os.path.abspath(__file__))
FAILURES = []


def check(ok, what):
    if not ok:
        FAILURES.append(what)
        print("  FAIL " + what)


# --- reference -------------------------------------------------------------------------------

def room_mesh():
    """Floor and three walls of the room, welded; triangles counter-clockwise seen inside."""
    index, vertices, triangles = {}, [], []

    def vertex(p):
        key = tuple(numpy.round(p, 6))
        if key not in index:
            index[key] = len(vertices)
            vertices.append(p)
        return index[key]

    faces = [((0, 0, 0), (4, 0, 0), (0, 3, 0)),      # floor z = 0
             ((0, 0, 0), (0, 3, 0), (0, 0, 2.5)),    # wall x = 0
             ((0, 3, 0), (4, 0, 0), (0, 0, 2.5)),    # wall y = 3
             ((4, 0, 0), (0, 3, 0), (0, 0, 2.5))]    # wall x = 4
    for origin, a, b in faces:
        o, a, b = (numpy.array(v, dtype=numpy.float64) for v in (origin, a, b))
        ids = [[vertex(o + a * i / GRID + b * j / GRID) for i in range(GRID + 1)]
               for j in range(GRID + 1)]
        for j in range(GRID):
            for i in range(GRID):
                triangles.append((ids[j][i], ids[j][i + 1], ids[j + 1][i + 1]))
                triangles.append((ids[j][i], ids[j + 1][i + 1], ids[j + 1][i]))
    positions = numpy.array(vertices, dtype=numpy.float32)
    return positions, numpy.rint(expected_colour(positions)).astype(int), triangles


def expected_colour(positions):
    return 255.0 * numpy.asarray(positions, dtype=numpy.float64) / ROOM


def write_ply(path, positions, colours, triangles):
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
                "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
                "element face %d\nproperty list uchar int vertex_indices\nend_header\n"
                % (len(positions), len(triangles)))
        for p, c in zip(positions, colours):
            f.write("%r %r %r %d %d %d\n" % (float(p[0]), float(p[1]), float(p[2]), *c))
        for t in triangles:
            f.write("3 %d %d %d\n" % t)


def read_ply(path):
    """Vertices (x y z), colours (0..255 or None) and face count of an ASCII or binary PLY."""
    with open(path, "rb") as f:
        header = []
        while True:
            line = f.readline().decode("ascii", "replace").strip()
            header.append(line)
            if line == "end_header":
                break
        body = f.read()
    fmt = next(l.split()[1] for l in header if l.startswith("format"))
    elements, current = [], None
    for line in header:
        parts = line.split()
        if parts and parts[0] == "element":
            current = {"name": parts[1], "count": int(parts[2]), "props": []}
            elements.append(current)
        elif parts and parts[0] == "property" and current is not None:
            current["props"].append(parts[1:])
    vertex = next(e for e in elements if e["name"] == "vertex")
    faces = next((e["count"] for e in elements if e["name"] == "face"), 0)
    names = [p[-1] for p in vertex["props"]]
    if fmt == "ascii":
        rows = body.decode("ascii").split("\n")[:vertex["count"]]
        data = numpy.array([[float(v) for v in r.split()[:len(names)]] for r in rows])
    else:
        types = {"float": "f4", "double": "f8", "uchar": "u1", "uint8": "u1", "int": "i4",
                 "uint": "u4", "float32": "f4", "char": "i1", "short": "i2", "ushort": "u2"}
        endian = "<" if fmt == "binary_little_endian" else ">"
        dtype = numpy.dtype([(p[-1], endian + types[p[0]]) for p in vertex["props"]])
        raw = numpy.frombuffer(body, dtype=dtype, count=vertex["count"])
        data = numpy.stack([raw[n].astype(numpy.float64) for n in names], axis=1)
    col = {n: i for i, n in enumerate(names)}
    xyz = data[:, [col["x"], col["y"], col["z"]]]
    colours = None
    if "red" in col:
        colours = data[:, [col["red"], col["green"], col["blue"]]]
    return xyz, colours, faces


def read_obj(path):
    """Vertex positions and face count of an OBJ."""
    xyz, faces = [], 0
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                xyz.append([float(v) for v in line.split()[1:4]])
            elif line.startswith("f "):
                faces += 1
    return numpy.array(xyz), faces


class Reference:
    """What was written: counts, box and colour at a position (analytic or from a PLY)."""

    def __init__(self, ply):
        self.positions, colours, self.faces = read_ply(ply)
        self.vertices = len(self.positions)
        self.lo, self.hi = self.positions.min(axis=0), self.positions.max(axis=0)
        self.analytic = os.path.basename(ply) == "room.ply"
        keys = numpy.rint(self.positions * 1e4).astype(numpy.int64)
        self.lookup = {tuple(k): c for k, c in zip(keys, colours)}

    def colours_at(self, positions):
        """Reference colour at each position: the room's function, or the PLY vertex there
        (NaN where no vertex is within 0.1 mm)."""
        if self.analytic:
            return expected_colour(positions)
        out = numpy.full((len(positions), 3), numpy.nan)
        for i, k in enumerate(numpy.rint(numpy.asarray(positions) * 1e4).astype(numpy.int64)):
            c = self.lookup.get(tuple(k))
            if c is not None:
                out[i] = c
        return out


def nearest_vertex_colours(reference, positions, cell=0.01):
    """The colour of the reference vertex nearest each position (within 2 cells), NaN if none:
    for points sampled inside triangles of a case's mesh, where no exact colour is known."""
    if not hasattr(reference, "grid"):
        reference.grid = {}
        for i, k in enumerate(numpy.floor(reference.positions / cell).astype(numpy.int64)):
            reference.grid.setdefault(tuple(k), []).append(i)
        reference.colour_list = numpy.array([reference.lookup[tuple(k)] for k in
                                             numpy.rint(reference.positions * 1e4).astype(numpy.int64)])
    out = numpy.full((len(positions), 3), numpy.nan)
    for n, p in enumerate(numpy.asarray(positions)):
        k = numpy.floor(p / cell).astype(numpy.int64)
        near = [i for d in numpy.ndindex(3, 3, 3)
                for i in reference.grid.get(tuple(k + numpy.array(d) - 1), [])]
        if near:
            j = near[int(numpy.argmin(((reference.positions[near] - p) ** 2).sum(axis=1)))]
            out[n] = reference.colour_list[j]
    return out


def colour_error(reference, positions, colours):
    """Largest and mean difference (8-bit steps) between colours and the reference's."""
    diff = numpy.abs(numpy.asarray(colours, dtype=numpy.float64) - reference.colours_at(positions))
    diff = diff[~numpy.isnan(diff).any(axis=1)]
    if len(diff) == 0:
        return float("inf"), float("inf")
    return float(diff.max()), float(diff.mean())


def check_box(name, reference, lo, hi):
    err = max(numpy.abs(numpy.asarray(lo) - reference.lo).max(),
              numpy.abs(numpy.asarray(hi) - reference.hi).max())
    check(err <= 1e-3, "%s: bounding box off by %.4f m (tolerance 1 mm): %s - %s, expected %s - %s"
          % (name, err, numpy.round(lo, 4), numpy.round(hi, 4), reference.lo, reference.hi))
    return err


def to_locard(xyz, up):
    """File axes -> Locard's z-up frame (y-up files are turned -90 degrees about x)."""
    xyz = numpy.asarray(xyz, dtype=numpy.float64)
    if up == "y":
        return numpy.stack([xyz[:, 0], -xyz[:, 2], xyz[:, 1]], axis=1)
    return xyz


# --- the files each tool checks --------------------------------------------------------------

def exports(work, reference_ply):
    """(file, format, up) of every export to check."""
    if reference_ply:  # a case's exports (y-up), and z-up ones as mesh_z.* where present
        d = os.path.dirname(reference_ply)
        files = [(os.path.join(d, "mesh.glb"), "glb", "y"), (os.path.join(d, "mesh.fbx"), "fbx", "y"),
                 (os.path.join(d, "mesh.obj"), "obj", "y"), (os.path.join(d, "mesh_z.fbx"), "fbx", "z"),
                 (os.path.join(d, "mesh_z.obj"), "obj", "z")]
        return [f for f in files if os.path.exists(f[0])]
    return [(os.path.join(work, "room.glb"), "glb", "y")] + [
        (os.path.join(work, "room_%s.%s" % (up, fmt)), fmt, up)
        for fmt in ("fbx", "obj") for up in ("y", "z")]


def run(cmd, **kw):
    print("  $ " + " ".join(cmd))
    return subprocess.run(cmd, capture_output=True, text=True, timeout=600, **kw)


def fixture(args):
    os.makedirs(args.work, exist_ok=True)
    positions, colours, triangles = room_mesh()
    ply = os.path.join(args.work, "room.ply")
    write_ply(ply, positions, colours, triangles)
    for path, fmt, up in exports(args.work, None):
        r = run([args.locard, "--quiet", "convert", ply, path, "--up", up, "--force"])
        check(r.returncode == 0, "locard convert to %s failed: %s" % (path, r.stderr.strip()))
    print("room: %d vertices, %d triangles" % (len(positions), len(triangles)))


def blender(args, reference):
    for path, fmt, up in exports(args.work, args.reference):
        name = os.path.basename(path)
        r = run([args.tool or "blender", "-b", "--factory-startup", "--python",
                 os.path.join(HERE, "blender_probe.py"), "--", path, fmt, up])
        line = next((l for l in r.stdout.splitlines() if l.startswith("LOCARD_PROBE ")), None)
        check(line is not None, "%s: Blender did not import it: %s" % (name, r.stdout[-2000:] + r.stderr[-2000:]))
        if line is None:
            continue
        d = json.loads(line[len("LOCARD_PROBE "):])
        check(d["vertices"] == reference.vertices and d["faces"] == reference.faces,
              "%s: Blender has %d vertices, %d faces; written %d, %d"
              % (name, d["vertices"], d["faces"], reference.vertices, reference.faces))
        box = check_box(name, reference, d.get("bbox_min", [0, 0, 0]), d.get("bbox_max", [0, 0, 0]))
        corners = numpy.array(d.get("corners", []))
        seen = []
        # glTF colours are linear by specification (Blender keeps them so); FBX and OBJ vertex
        # colours are the sRGB bytes. Blender stores corner colours as bytes: 1.5 steps.
        field = "linear" if fmt == "glb" else "srgb"
        for attr in d["colour_attributes"]:
            worst, mean = colour_error(reference, corners, attr[field])
            check(worst <= 1.5, "%s: colour attribute %r off by up to %.1f steps" % (name, attr["name"], worst))
            seen.append("colour attribute %s (%s), max error %.1f" % (attr["name"], attr["domain"].lower(), worst))
        if d["texture"]:
            # Bilinear sampling of the atlas returns the vertex colours' interpolation: 2 steps.
            worst, mean = colour_error(reference, corners, d["texture"]["corner_colours"])
            check(worst <= 2.0, "%s: texture colours off by up to %.1f steps" % (name, worst))
            seen.append("texture %dx%d, max error %.1f" % (*d["texture"]["size"], worst))
        check(bool(seen), "%s: Blender shows no colour" % name)
        print("blender %s: %d vertices, %d faces, box %s - %s m (within %.1g m), z up; %s"
              % (name, d["vertices"], d["faces"], numpy.round(d["bbox_min"], 3),
                 numpy.round(d["bbox_max"], 3), box, "; ".join(seen)))


def assimp(args, reference):
    tool = args.tool or "assimp"
    for path, fmt, up in exports(args.work, args.reference):
        name = os.path.basename(path)
        r = run([tool, "info", path])
        check(r.returncode == 0, "%s: assimp info failed: %s" % (name, r.stdout[-1000:] + r.stderr))
        info = dict(re.findall(r"^(Vertices|Faces|Minimum point|Maximum point):?\s+(.*)$", r.stdout, re.M))
        if "Faces" not in info:
            continue
        faces, vertices = int(info["Faces"]), int(info["Vertices"])
        # assimp joins identical vertices; an OBJ's corners differ by their texture coordinate.
        want = 3 * reference.faces if fmt == "obj" else reference.vertices
        check(vertices == want and faces == reference.faces,
              "%s: assimp has %d vertices, %d faces; expected %d, %d" % (name, vertices, faces, want, reference.faces))
        points = [[float(v) for v in re.findall(r"[-0-9.e]+", info[k])] for k in ("Minimum point", "Maximum point")]
        box = to_locard(numpy.array(points), "y" if fmt == "glb" else up)
        err = check_box(name, reference, box.min(axis=0), box.max(axis=0))
        with tempfile.TemporaryDirectory() as tmp:
            ply = os.path.join(tmp, "out.ply")
            r = run([tool, "export", path, ply])
            xyz, colours, _ = read_ply(ply) if r.returncode == 0 else (None, None, 0)
        check(colours is not None, "%s: assimp export wrote no vertex colours" % name)
        worst = float("inf")
        if colours is not None:
            worst, _ = colour_error(reference, to_locard(xyz, "y" if fmt == "glb" else up), colours)
            check(worst <= 1.0, "%s: assimp's colours off by up to %.1f steps" % (name, worst))
        print("assimp %s: %d vertices, %d faces, box within %.1g m; vertex colours max error %.1f"
              % (name, vertices, faces, err, worst))


def run_cloudcompare(args, options):
    """CloudCompare's command line, headless (-SILENT, no display)."""
    return run([args.tool or "CloudCompare", "-SILENT", "-AUTO_SAVE", "OFF"] + options,
               env=dict(os.environ, QT_QPA_PLATFORM="offscreen"))


def cloudcompare(args, reference):
    for path, fmt, up in exports(args.work, args.reference):
        if fmt != "obj":
            continue  # CloudCompare 2.11 reads neither glTF nor FBX
        name = os.path.basename(path)
        with tempfile.TemporaryDirectory() as tmp:
            # Saving a textured mesh as PLY waits on a dialog even with -SILENT: re-save as OBJ.
            mesh_obj, points_ply = os.path.join(tmp, "mesh.obj"), os.path.join(tmp, "points.ply")
            r = run_cloudcompare(args, ["-O", path, "-M_EXPORT_FMT", "OBJ", "-SAVE_MESHES", "FILE",
                                        mesh_obj, "-SAMPLE_MESH", "POINTS", "20000", "-C_EXPORT_FMT",
                                        "PLY", "-PLY_EXPORT_FMT", "ASCII", "-SAVE_CLOUDS", "FILE",
                                        points_ply])
            ok = r.returncode == 0 and os.path.exists(points_ply) and os.path.exists(mesh_obj)
            check(ok, "%s: CloudCompare failed: %s" % (name, r.stdout[-2000:] + r.stderr[-1000:]))
            if not ok:
                continue
            mesh_xyz, faces = read_obj(mesh_obj)
            xyz, colours, _ = read_ply(points_ply)
        check(len(mesh_xyz) == reference.vertices and faces == reference.faces,
              "%s: CloudCompare has %d vertices, %d faces; written %d, %d"
              % (name, len(mesh_xyz), faces, reference.vertices, reference.faces))
        # CloudCompare keeps the file's axes (it shows z up: a y-up OBJ lies on its side).
        box = to_locard(mesh_xyz, up)
        err = check_box(name, reference, box.min(axis=0), box.max(axis=0))
        check(colours is not None, "%s: CloudCompare's samples have no colour" % name)
        if colours is None:
            continue
        if reference.analytic:
            # Sampling takes the nearest texel: off by up to one texel's colour step (6.4 / 2
            # per leg direction here, two directions) plus rounding.
            worst, mean = colour_error(reference, to_locard(xyz, up), colours)
            check(worst <= 5.0 and mean <= 2.0, "%s: CloudCompare's texture colours off by up "
                  "to %.1f (mean %.1f) steps" % (name, worst, mean))
        else:
            # A case's colour inside a triangle is known only at its corners: compare with the
            # nearest vertex (a wrong texture or UV mapping is off by tens of steps on average).
            near = nearest_vertex_colours(reference, to_locard(xyz, up))
            diff = numpy.abs(colours - near)
            diff = diff[~numpy.isnan(diff).any(axis=1)]
            worst, mean = float(diff.max()), float(diff.mean())
            check(mean <= 6.0, "%s: CloudCompare's texture colours differ from the nearest "
                  "vertex's by %.1f steps on average" % (name, mean))
        print("cloudcompare %s: %d vertices, %d faces, box within %.1g m (%s); %d "
              "points sampled from the texture, colour max error %.1f, mean %.1f%s"
              % (name, len(mesh_xyz), faces, err, "z up" if up == "z" else "y up: lies on its side in CloudCompare",
                 len(xyz), worst, mean, "" if reference.analytic else " (against the nearest vertex)"))


def cloudcompare_e57(args):
    """A laser scan read from E57 by Locard and written as PLY: CloudCompare opens it with every
    point, its colour and its intensity (the pump-room scan of docs/e57.md)."""
    os.makedirs(args.work, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=args.work) as tmp:
        ours, theirs = os.path.join(tmp, "scan.ply"), os.path.join(tmp, "cloudcompare.ply")
        r = run([args.locard, "convert", args.source, ours])
        check(r.returncode == 0, "locard convert %s failed: %s" % (args.source, r.stderr[-2000:]))
        if r.returncode != 0:
            return
        r = run_cloudcompare(args, ["-O", ours, "-C_EXPORT_FMT", "PLY", "-PLY_EXPORT_FMT", "ASCII",
                                    "-SAVE_CLOUDS", "FILE", theirs])
        ok = r.returncode == 0 and os.path.exists(theirs)
        check(ok, "CloudCompare failed on %s: %s" % (ours, r.stdout[-2000:] + r.stderr[-1000:]))
        if not ok:
            return
        xyz, colours, _ = read_ply(ours)
        cc_xyz, cc_colours, _ = read_ply(theirs)
        with open(theirs, "rb") as f:
            header = f.read(2000).decode("ascii", "replace")
    check(colours is not None, "locard wrote no colour for %s" % args.source)
    check(cc_colours is not None, "CloudCompare read no colour")
    check(len(cc_xyz) == len(xyz), "CloudCompare has %d points, Locard wrote %d" % (len(cc_xyz), len(xyz)))
    check("intensity" in header, "CloudCompare read no intensity")
    if colours is None or cc_colours is None or len(cc_xyz) != len(xyz):
        return
    # CloudCompare keeps the points' order; its ASCII PLY prints 6 significant digits.
    position = float(numpy.abs(cc_xyz - xyz).max())
    colour = float(numpy.abs(cc_colours - colours).max())
    check(position <= 1e-4, "CloudCompare's positions off by up to %.2g m" % position)
    check(colour == 0, "CloudCompare's colours off by up to %d steps" % colour)
    print("cloudcompare %s: %d points, positions within %.1g m, colours identical, intensity read"
          % (os.path.basename(args.source), len(xyz), position))


def meshlab(args, reference):
    tool = args.tool or "meshlabserver"
    for path, fmt, up in exports(args.work, args.reference):
        if fmt != "fbx" or up != "y":
            continue  # MeshLab 2020.09: no glTF importer, OBJ import aborts (any OBJ)
        name = os.path.basename(path)
        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "out.ply")
            r = run(["xvfb-run", "-a", tool, "-i", path, "-o", out, "-m", "vc"])
            ok = r.returncode == 0 and os.path.exists(out)
            check(ok, "%s: meshlabserver failed: %s" % (name, r.stdout[-2000:] + r.stderr[-1000:]))
            if not ok:
                continue
            xyz, colours, faces = read_ply(out)
        check(len(xyz) == reference.vertices and faces == reference.faces,
              "%s: MeshLab has %d vertices, %d faces; written %d, %d"
              % (name, len(xyz), faces, reference.vertices, reference.faces))
        # MeshLab keeps the file's axes (y-up here) and units.
        box = to_locard(xyz, up)
        err = check_box(name, reference, box.min(axis=0), box.max(axis=0))
        # MeshLab 2020.09 reads no FBX vertex colour (every vertex white): reported, not failed.
        worst = colour_error(reference, box, colours)[0] if colours is not None else float("inf")
        white = colours is not None and bool((colours == 255).all())
        print("meshlab %s: %d vertices, %d faces, box within %.1g m; %s"
              % (name, len(xyz), faces, err, "no colour (every vertex white)" if white
                 else "vertex colours max error %.1f" % worst))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("what", choices=["fixture", "blender", "assimp", "cloudcompare", "meshlab",
                                         "cloudcompare_e57"])
    parser.add_argument("--work", required=True)
    parser.add_argument("--locard")
    parser.add_argument("--tool", help="the tool's executable (default: its usual name)")
    parser.add_argument("--reference", help="a case's mesh.ply (its exports beside it)")
    parser.add_argument("--source", help="cloudcompare_e57: the E57 scan to convert")
    args = parser.parse_args()
    if args.what == "fixture":
        fixture(args)
    elif args.what == "cloudcompare_e57":
        cloudcompare_e57(args)
    else:
        reference = Reference(args.reference or os.path.join(args.work, "room.ply"))
        globals()[args.what](args, reference)
    if FAILURES:
        print("%d check(s) failed" % len(FAILURES))
        sys.exit(1)


if __name__ == "__main__":
    main()
