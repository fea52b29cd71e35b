#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Everyday Blender re-work against the watermark
(bench/results/2026-11-24-everyday-blender-rework.md).

For each mesh and each of K keys (seeds 1..K): `meshmark embed` with the defaults (or --strength),
every Blender operation of bench/blender/attacks.py on the marked copy, and `meshmark detect --json`
of each result against the original; the unmarked original goes through the same operations once per mesh
and each result is detected with every key (unmarked copies must not be claimed). Writes a
markdown table (operation x mesh: marked copies detected / total, smallest score z, mean R;
unmarked copies claimed) and a JSON file of every trial. Exits 1 on any error (a tool failing,
an unreadable mesh; with --keep-going a Blender, gltf-transform or MeshLab failure is recorded, the run
goes on and exits 1 at the end), 2 on bad arguments. --ops (or --with-others) adds other tools' operations:
gltf-transform simplify / weld, Open3D (open3d_attacks.py) and MeshLab (meshlabserver).

  bench/blender/rework.py --keys 2 --meshes fandisk.obj rocker-arm.obj \\
      --json-file /tmp/rework.json --markdown /tmp/rework.md
  bench/blender/rework.py --from-json a.json b.json --markdown all.md   # merge runs
  bench/blender/rework.py --strength 0.001 --ops decimate=0.05 --meshes asset.glb   # a stronger mark

Environment: MESHMARK_MESH_DIR (default ../shared/data/meshes), MESHMARK (default
build/bin/meshmark), BLENDER (default blender), OPEN3D_PYTHON (default /usr/bin/python3),
GLTF_TRANSFORM (default tests/interop/node_modules/.bin/gltf-transform), MESHLABSERVER.
"""
import argparse
import datetime
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ATTACKS = os.path.join(HERE, "attacks.py")
OPEN3D_ATTACKS = os.path.join(HERE, "open3d_attacks.py")
HALVES = ["bisect-%s%s" % (axis, side) for axis in "xyz" for side in "+-"]
BLENDER_NAMES = {"ply", "obj", "gltf", "transform", "mirror", "merge", "noise", "subdivide", "laplacian", "smooth",
                 "decimate", "merged-decimate", "bisect", "voxel", "pose", "second-action"} | set(HALVES)
# Other tools' operations (--ops ... or --with-others): gltf-transform, Open3D, MeshLab.
OTHER_OPERATIONS = ["gt-simplify=0.5", "gt-simplify=0.2", "gt-decimate=0.05", "gt-weld", "o3d-decimate=0.2",
                    "o3d-laplacian=10", "o3d-taubin=10", "meshlab-decimate=0.2", "meshlab-taubin=10"]
OPERATIONS = ["ply", "obj", "gltf", "transform", "mirror", "merge", "noise", "subdivide", "laplacian",
              "smooth", "decimate=0.5", "decimate=0.2", "decimate=0.05", "bisect", "voxel=300",
              "voxel=150"]
DESCRIPTION = {
    "ply": "round trip, PLY writer", "obj": "round trip, OBJ writer", "gltf": "round trip, glTF writer (.glb)",
    "transform": "move, rotate 20/30/40 deg, scale 1.5", "mirror": "mirror in x (faces reversed)",
    "merge": "merge by distance (1e-4)",
    "noise": "Randomize Vertices 0.2%", "subdivide": "Subdivision Surface, 1 level",
    "laplacian": "Laplacian Smooth (defaults)", "smooth": "Smooth, factor 0.5 x 10",
    "decimate=0.5": "Decimate collapse 50%", "decimate=0.2": "Decimate collapse 20%",
    "decimate=0.05": "Decimate collapse 5%", "merged-decimate=0.05": "Merge by Distance, then Decimate 5%",
    "bisect": "bisect in half, keep one side",
    **{h: "bisect across %s, keep the %s side" % (h[7], "positive" if h[8] == "+" else "negative") for h in HALVES},
    "pose=10": "posed by its animation, frame 10", "pose=20": "posed by its animation, frame 20",
    "second-action=10": "posed by its second animation, frame 10",
    "second-action=20": "posed by its second animation, frame 20",
    "voxel=300": "voxel remesh, diagonal/300", "voxel=150": "voxel remesh, diagonal/150",
    "gt-simplify=0.5": "gltf-transform simplify 50% (error 0.1%)",
    "gt-simplify=0.2": "gltf-transform simplify 20% (error 0.1%)", "gt-weld": "gltf-transform weld",
    "gt-decimate=0.05": "gltf-transform simplify to 5% (no error bound)",
    "o3d-decimate=0.2": "Open3D quadric decimation 20%", "o3d-laplacian=10": "Open3D Laplacian x 10",
    "o3d-taubin=10": "Open3D Taubin x 10", "meshlab-decimate=0.2": "MeshLab quadric edge collapse 20%",
    "meshlab-taubin=10": "MeshLab Taubin x 10",
}
BLENDER_READS = (".ply", ".obj", ".gltf", ".glb", ".stl")


class Failure(Exception):
    pass


def vertex_count(path):
    """Vertices of a PLY/OBJ/OFF file from its text, for choosing meshes by size (None if unknown)."""
    ext = os.path.splitext(path)[1].lower()
    with open(path, "rb") as f:
        if ext == ".ply":
            for line in f:
                m = re.match(rb"element\s+vertex\s+(\d+)", line)
                if m:
                    return int(m.group(1))
                if line.startswith(b"end_header"):
                    return None
        elif ext == ".obj":
            return sum(1 for line in f if line.startswith(b"v "))
        elif ext == ".off":
            words = [w for line in f for w in line.split(b"#")[0].split()][:2]
            return int(words[1]) if len(words) == 2 and words[0].endswith(b"OFF") else None
    return None


def blender_environment():
    """The environment minus this interpreter's folder on PATH: Blender's embedded Python finds its
    standard library from the first python3 on PATH, so under another Python (a pyenv or venv one)
    it would lose the system's site-packages (numpy, which its glTF add-on needs)."""
    env = dict(os.environ)
    mine = os.path.dirname(os.path.realpath(sys.executable))
    env["PATH"] = os.pathsep.join(d for d in env.get("PATH", "").split(os.pathsep)
                                  if d and os.path.realpath(d) != mine)
    return env


def run(command, what, ok_codes=(0,), env=None):
    result = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    if result.returncode not in ok_codes:
        tail = (result.stderr.strip() or result.stdout.strip())[-800:]
        raise Failure("%s failed (exit %d): %s\n  command: %s" % (what, result.returncode, tail,
                                                                   " ".join(command)))
    return result


def blender_ops(args, source, out_dir, seed, ops):
    os.makedirs(out_dir, exist_ok=True)
    run([args.blender, "-b", "--factory-startup", "--python-exit-code", "2", "--python", ATTACKS,
         "--", source, out_dir, "--seed", str(seed)] + ops, "blender on %s" % source,
        env=blender_environment())
    with open(os.path.join(out_dir, "attacks.json")) as f:
        return {entry["op"]: entry for entry in json.load(f)}


def mlx(op, value):
    """A MeshLab filter script for one operation (MeshLab 2020.09's names; meshlabserver
    wants every parameter, so these are its defaults but for the target)."""
    if op == "meshlab-decimate":
        body = ('<filter name="Simplification: Quadric Edge Collapse Decimation">'
                '<Param type="RichInt" name="TargetFaceNum" value="0"/>'
                '<Param type="RichFloat" name="TargetPerc" value="%r"/>'
                '<Param type="RichFloat" name="QualityThr" value="0.3"/>'
                '<Param type="RichBool" name="PreserveBoundary" value="false"/>'
                '<Param type="RichFloat" name="BoundaryWeight" value="1"/>'
                '<Param type="RichBool" name="PreserveNormal" value="false"/>'
                '<Param type="RichBool" name="PreserveTopology" value="false"/>'
                '<Param type="RichBool" name="OptimalPlacement" value="true"/>'
                '<Param type="RichBool" name="PlanarQuadric" value="false"/>'
                '<Param type="RichFloat" name="PlanarWeight" value="0.001"/>'
                '<Param type="RichBool" name="QualityWeight" value="false"/>'
                '<Param type="RichBool" name="AutoClean" value="true"/>'
                '<Param type="RichBool" name="Selected" value="false"/></filter>' % value)
    else:  # meshlab-taubin
        body = ('<filter name="Taubin Smooth"><Param type="RichFloat" name="lambda" value="0.5"/>'
                '<Param type="RichFloat" name="mu" value="-0.53"/>'
                '<Param type="RichInt" name="stepSmoothNum" value="%d"/>'
                '<Param type="RichBool" name="Selected" value="false"/></filter>' % int(value))
    return "<!DOCTYPE FilterScript>\n<FilterScript>\n%s\n</FilterScript>\n" % body


def as_ply(args, source, out_dir):
    """source itself when it is a PLY, else OUT_DIR/input.ply written by meshmark (positions
    as meshmark reads them, glTF node transforms applied; 2^24 levels: below single precision)."""
    if source.lower().endswith(".ply"):
        return source
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, "input.ply")
    if not os.path.exists(path):
        run([args.meshmark, "attack", source, "quantize=24", "-o", path, "-q"], "meshmark attack quantize=24")
    return path


def other_ops(args, source, out_dir, ops):
    """The operations of gltf-transform (gt-*, on a .glb of the copy written by meshmark) and
    MeshLab (meshlab-*, meshlabserver under xvfb-run), one process per operation."""
    os.makedirs(out_dir, exist_ok=True)
    done = {}
    for op in ops:
        name, _, value = op.partition("=")
        label = op.replace("=", "_")
        if name in ("gt-simplify", "gt-decimate", "gt-weld"):
            gltf_copy = os.path.join(out_dir, "input.glb")
            if not os.path.exists(gltf_copy):
                # Shared vertices (Blender's glTF writer splits every vertex of a flat-shaded mesh,
                # which leaves simplify nothing to collapse); 2^24 levels: below single precision.
                run([args.meshmark, "attack", source, "quantize=24", "-o", gltf_copy, "-q"],
                    "meshmark attack quantize=24")
            target = os.path.join(out_dir, label + ".glb")
            temporary = os.path.join(out_dir, ".tmp-" + label + ".glb")
            command = [args.gltf_transform, "weld" if name == "gt-weld" else "simplify", gltf_copy, temporary]
            if name == "gt-simplify":
                command += ["--ratio", value or "0.5", "--error", "0.001"]
            elif name == "gt-decimate":
                # The error bound lifted (1 = the whole model): the ratio alone stops it, like
                # Blender's Decimate ratio (meshoptimizer keeps the vertices it does not remove).
                command += ["--ratio", value or "0.05", "--error", "1"]
        elif name in ("meshlab-decimate", "meshlab-taubin"):
            target = os.path.join(out_dir, label + ".ply")
            temporary = os.path.join(out_dir, ".tmp-" + label + ".ply")
            script = os.path.join(out_dir, label + ".mlx")
            with open(script, "w") as f:
                f.write(mlx(name, float(value or (0.5 if name == "meshlab-decimate" else 10))))
            # MeshLab 2020.09's OBJ reader aborts on some valid files (fandisk.obj): give it PLY.
            meshlab_input = as_ply(args, source, out_dir)
            command = ["xvfb-run", "-a", args.meshlabserver, "-i", meshlab_input, "-o", temporary, "-s",
                       script]
        else:
            raise Failure("unknown operation '%s'" % op)
        try:
            run(command, "%s on %s" % (op, source))
        except Failure as e:
            if not args.keep_going:
                raise
            # MeshLab 2022.02 asserts (vcg's VFDetach) on some real assets: note it, go on.
            print("rework.py: %s (--keep-going: recorded, going on)" % e, file=sys.stderr, flush=True)
            done[op] = {"op": op, "failed": str(e).splitlines()[0][:300]}
            continue
        os.replace(temporary, target)
        done[op] = {"op": op, "output": target, "vertices": vertex_count(target), "faces": None}
    return done


def rework(args, source, out_dir, seed, ops):
    """Every operation of ops on source: Blender's in one Blender run, Open3D's in one Python run,
    the others one by one; {op: {output, vertices, faces}}."""
    blender = [op for op in ops if op.split("=")[0] in BLENDER_NAMES]
    open3d = [op for op in ops if op.startswith("o3d-")]
    others = [op for op in ops if op not in blender and op not in open3d]
    done = {}
    if blender:
        try:
            done.update(blender_ops(args, source, os.path.join(out_dir, "blender"), seed, blender))
        except Failure as e:
            if not args.keep_going:
                raise
            # Blender 3.4's glTF writer raises on some real assets (an IndexError in its colour
            # attribute export): every Blender operation of this run is recorded as failed.
            print("rework.py: %s (--keep-going: recorded, going on)" % str(e).splitlines()[0], file=sys.stderr,
                  flush=True)
            done.update({op: {"op": op, "failed": str(e).splitlines()[0][:300]} for op in blender})
    if open3d:
        where = os.path.join(out_dir, "open3d")
        os.makedirs(where, exist_ok=True)
        # Open3D 0.16 reads a glTF's meshes without their node transforms (every part of a
        # multi-node asset lands at the origin): give it what the other tools see, as PLY.
        open3d_input = as_ply(args, source, where) if source.lower().endswith((".gltf", ".glb")) else source
        run([args.open3d_python, OPEN3D_ATTACKS, open3d_input, where, "--seed", str(seed)] + open3d,
            "open3d on %s" % source)
        with open(os.path.join(where, "attacks.json")) as f:
            done.update({entry["op"]: entry for entry in json.load(f)})
    if others:
        done.update(other_ops(args, source, os.path.join(out_dir, "others"), others))
    return done


def detect(args, suspect, original, key):
    result = run([args.meshmark, "detect", suspect, "--original", original, "--key", key, "--json",
                  "-q"], "meshmark detect %s" % suspect, ok_codes=(0, 1))
    try:
        report = json.loads(result.stdout)
    except json.JSONDecodeError:
        raise Failure("meshmark detect %s printed no JSON: %s" % (suspect, result.stdout[-300:])) from None
    if bool(report.get("detected")) != (result.returncode == 0):
        raise Failure("meshmark detect %s: exit code %d disagrees with detected=%s" %
                      (suspect, result.returncode, report.get("detected")))
    fields = ("detected", "verdict", "score", "correlation", "bits_expected", "bits_found",
              "false_positive_probability", "cropped_fraction")
    return {k: report.get(k) for k in fields}


def trial(args, mesh, key_seed, marked, op, blender_entry, original, key):
    if "failed" in blender_entry:
        return {"mesh": os.path.basename(mesh), "key": key_seed, "marked": marked, "op": op,
                "tool_failed": blender_entry["failed"]}
    start = time.time()
    result = detect(args, blender_entry["output"], original, key)
    result.update({"mesh": os.path.basename(mesh), "key": key_seed, "marked": marked, "op": op,
                   "vertices": blender_entry["vertices"], "faces": blender_entry["faces"],
                   "detect_seconds": round(time.time() - start, 2)})
    if args.damage and marked:
        # The copy's own damage: how far the original's surface is from the copy's (fractions
        # of the original's diagonal), which tells a copy that is no longer the asset.
        found = json.loads(run([args.meshmark, "compare", original, blender_entry["output"], "--json", "-q"],
                               "meshmark compare %s" % blender_entry["output"]).stdout)
        result["damage"] = {k: found[k] for k in ("mean_ab", "rms_ab", "hausdorff_ab", "mean_ba")}
    if not args.quiet:
        print("%-22s key %d %-8s %-14s detected=%-5s z=%6.2f R=%.3f fpp=%.2g" % (
            result["mesh"], key_seed, "marked" if marked else "unmarked", op, result["detected"],
            result["score"], result["correlation"], result["false_positive_probability"]),
            file=sys.stderr, flush=True)
    return result


def run_mesh(args, mesh, work):
    name = os.path.basename(mesh)
    stem, ext = os.path.splitext(name)
    mesh_work = os.path.join(work, stem)
    os.makedirs(mesh_work, exist_ok=True)
    # Blender reads the unmarked copy; a format it cannot read is converted by meshmark first.
    blender_input = mesh
    marked_ext = ext.lower()
    if marked_ext not in BLENDER_READS:
        marked_ext = ".ply"
        blender_input = os.path.join(mesh_work, "original.ply")
        # 2^24 levels over the bounding box: below single precision, which Blender keeps anyway.
        run([args.meshmark, "attack", mesh, "quantize=24", "-o", blender_input, "-q"],
            "meshmark attack quantize=24")
    trials = []
    unmarked = rework(args, blender_input, os.path.join(mesh_work, "unmarked"), 0, args.ops)
    for key_seed in range(1, args.keys + 1):
        key = os.path.join(mesh_work, "key%d.json" % key_seed)
        marked = os.path.join(mesh_work, "marked%d%s" % (key_seed, marked_ext))
        run([args.meshmark, "embed", mesh, "-o", marked, "--key", key, "--seed", str(key_seed),
             "--force", "-q"] + (["--strength", repr(args.strength)] if args.strength else []),
            "meshmark embed %s" % mesh)
        # The embedding's own distortion (MRMS over the diagonal), kept with every trial in the JSON.
        mark_mrms = json.loads(run([args.meshmark, "compare", mesh, marked, "--json"],
                                   "meshmark compare %s" % mesh).stdout)["mrms"]
        done = rework(args, marked, os.path.join(mesh_work, "marked%d" % key_seed), key_seed, args.ops)
        for op in args.ops:
            for is_marked, entry in ((True, done[op]), (False, unmarked[op])):
                result = trial(args, mesh, key_seed, is_marked, op, entry, mesh, key)
                result["mark_mrms"] = mark_mrms
                trials.append(result)
    return trials


def table(trials):
    failed = [t for t in trials if "tool_failed" in t]
    meshes = list(dict.fromkeys(t["mesh"] for t in trials))  # a mesh every tool failed on included
    ops = list(dict.fromkeys(t["op"] for t in trials))
    trials = [t for t in trials if "tool_failed" not in t]
    lines = ["| operation | " + " | ".join(meshes) + " | unmarked copies claimed |",
             "|---|" + "---|" * len(meshes) + "---|"]
    for op in ops:
        cells = []
        for mesh in meshes:
            marked = [t for t in trials if t["op"] == op and t["mesh"] == mesh and t["marked"]]
            if not marked:
                cells.append("tool failed" if any(t["op"] == op and t["mesh"] == mesh for t in failed) else "")
                continue
            hits = sum(1 for t in marked if t["detected"])
            cells.append("%d/%d, z %.2f, R %.3f" % (hits, len(marked), min(t["score"] for t in marked),
                                                    sum(t["correlation"] for t in marked) / len(marked)))
        clean = [t for t in trials if t["op"] == op and not t["marked"]]
        claimed = sum(1 for t in clean if t["detected"])
        lines.append("| `%s` %s | %s | %d/%d |" % (op, DESCRIPTION.get(op, ""), " | ".join(cells),
                                                  claimed, len(clean)))
    marked = [t for t in trials if t["marked"]]
    clean = [t for t in trials if not t["marked"]]
    lines.append("")
    lines.append("Marked copies claimed: %d/%d. Unmarked copies claimed: %d/%d (largest z %.2f)." % (
        sum(t["detected"] for t in marked), len(marked), sum(t["detected"] for t in clean), len(clean),
        max((t["score"] for t in clean), default=float("nan"))))
    lost = [t for t in marked if not t["detected"] and "damage" in t]
    if lost:
        lines.append("")
        lines.append("Marked copies not claimed, with their own damage (the original's surface to the copy's, "
                     "in % of the diagonal: mean, RMS, largest):")
        lines.append("")
        for t in lost:
            d = t["damage"]
            lines.append("- %s `%s` key %d: z %.2f; mean %.3f%%, RMS %.3f%%, largest %.2f%%" % (
                t["mesh"], t["op"], t["key"], t["score"], 100 * d["mean_ab"], 100 * d["rms_ab"],
                100 * d["hausdorff_ab"]))
    if failed:
        lines.append("")
        lines.append("The tool failed on %d copies (not counted above): %s." % (len(failed), "; ".join(
            sorted({"%s on %s" % (t["op"], t["mesh"]) for t in failed}))))
    return "\n".join(lines) + "\n"


def write_atomically(path, text):
    directory = os.path.dirname(os.path.abspath(path))
    fd, temporary = tempfile.mkstemp(dir=directory, prefix=".tmp-")
    with os.fdopen(fd, "w") as f:
        f.write(text)
    os.replace(temporary, path)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--meshes", nargs="+", help="mesh files or names in MESHMARK_MESH_DIR "
                        "(default: every mesh there with --min-vertices or more)")
    parser.add_argument("--min-vertices", type=int, default=5000)
    parser.add_argument("--keys", type=int, default=2, help="keys (seeds 1..K) per mesh")
    parser.add_argument("--strength", type=float, help="meshmark embed --strength (default: embed's own)")
    parser.add_argument("--ops", nargs="+", default=OPERATIONS,
                        help="operations (default: the Blender ones): attacks.py's, open3d_attacks.py's "
                        "(o3d-*), gltf-transform's gt-simplify=R (error 0.1%%), gt-decimate=R (no error "
                        "bound) and gt-weld (on a .glb of the copy written by meshmark), MeshLab's "
                        "meshlab-decimate=R and meshlab-taubin=N")
    parser.add_argument("--with-others", action="store_true",
                        help="add " + " ".join(OTHER_OPERATIONS))
    parser.add_argument("--open3d-python", default=os.environ.get("OPEN3D_PYTHON", "/usr/bin/python3"),
                        help="the Python with Debian's python3-open3d")
    parser.add_argument("--gltf-transform", default=os.environ.get(
        "GLTF_TRANSFORM", os.path.join(HERE, "..", "..", "tests", "interop", "node_modules", ".bin",
                                       "gltf-transform")))
    parser.add_argument("--meshlabserver", default=os.environ.get("MESHLABSERVER", "meshlabserver"))
    parser.add_argument("--mesh-dir", default=os.environ.get("MESHMARK_MESH_DIR", "../shared/data/meshes"))
    parser.add_argument("--meshmark", default=os.environ.get("MESHMARK", "build/bin/meshmark"))
    parser.add_argument("--blender", default=os.environ.get("BLENDER", "blender"))
    parser.add_argument("--work-dir", help="keep the intermediate files here (default: a temporary folder)")
    parser.add_argument("--json-file", help="write every trial here")
    parser.add_argument("--markdown", help="write the table here (default: stdout)")
    parser.add_argument("--from-json", nargs="+", help="no runs: the table of these JSON files' trials")
    parser.add_argument("--keep-going", action="store_true",
                        help="when Blender, gltf-transform or MeshLab fails, record it (the table's "
                        "cell says 'tool failed'; a Blender failure fails all its operations on that "
                        "copy) and go on; the exit code is still 1")
    parser.add_argument("--damage", action="store_true",
                        help="also measure each marked copy's own damage (meshmark compare against the "
                        "original; in the JSON, and listed under the table for the copies not claimed)")
    parser.add_argument("-q", "--quiet", action="store_true")
    args = parser.parse_args()
    if args.keys < 1:
        parser.error("--keys must be at least 1")
    if args.with_others:
        args.ops = args.ops + [op for op in OTHER_OPERATIONS if op not in args.ops]

    if args.from_json:
        trials = []
        for path in args.from_json:
            with open(path) as f:
                trials += json.load(f)["trials"]
    else:
        needed = [args.meshmark, args.blender]
        needed += [args.open3d_python] if any(op.startswith("o3d-") for op in args.ops) else []
        needed += [args.gltf_transform] if any(op.startswith("gt-") for op in args.ops) else []
        needed += [args.meshlabserver, "xvfb-run"] if any(op.startswith("meshlab-") for op in args.ops) else []
        for tool in needed:
            if shutil.which(tool) is None:
                raise Failure("%s: not found (see --help for the options and variables naming the tools)" % tool)
        # Blender runs with this interpreter's folder taken off PATH (blender_env): name it by
        # its full path first, or a Blender beside that interpreter (/usr/bin) is lost with it.
        args.blender = shutil.which(args.blender)
        if args.meshes:
            meshes = [m if os.path.exists(m) else os.path.join(args.mesh_dir, m) for m in args.meshes]
        else:
            if not os.path.isdir(args.mesh_dir):
                raise Failure("%s: no such folder (set MESHMARK_MESH_DIR or --mesh-dir)" % args.mesh_dir)
            meshes = sorted(os.path.join(args.mesh_dir, m) for m in os.listdir(args.mesh_dir))
            meshes = [m for m in meshes if (vertex_count(m) or 0) >= args.min_vertices]
        for m in meshes:
            if not os.path.isfile(m):
                raise Failure("%s: no such mesh" % m)
        work = args.work_dir or tempfile.mkdtemp(prefix="meshmark-rework-")
        trials = []
        try:
            for mesh in meshes:
                trials += run_mesh(args, os.path.abspath(mesh), os.path.abspath(work))
        finally:
            if not args.work_dir:
                shutil.rmtree(work, ignore_errors=True)
        if args.json_file:
            write_atomically(args.json_file, json.dumps({
                "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
                "command": " ".join(sys.argv), "keys": args.keys, "strength": args.strength,
                "trials": trials}, indent=1) + "\n")
    text = table(trials)
    if args.markdown:
        write_atomically(args.markdown, text)
    else:
        sys.stdout.write(text)
    if any("tool_failed" in t for t in trials):
        raise Failure("a tool failed on some operations (listed at the end of the table)")


if __name__ == "__main__":
    try:
        main()
    except Failure as e:
        print("rework.py: %s" % e, file=sys.stderr)
        sys.exit(1)
