#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Everyday Blender re-work against the watermark (docs/robustness.md, "Everyday re-work in Blender").

For each mesh and each of K keys (seeds 1..K): `meshmark embed` with the defaults, every Blender
operation of bench/blender/attacks.py on the marked copy, and `meshmark detect --json` of each
result against the original; the unmarked original goes through the same operations once per mesh
and each result is detected with every key (unmarked copies must not be claimed). Writes a
markdown table (operation x mesh: marked copies detected / total, smallest score z, mean R;
unmarked copies claimed) and a JSON file of every trial. Exits 1 on any error (a tool failing,
an unreadable mesh), 2 on bad arguments.

  bench/blender/rework.py --keys 2 --meshes fandisk.obj rocker-arm.obj \\
      --json-file /tmp/rework.json --markdown /tmp/rework.md
  bench/blender/rework.py --from-json a.json b.json --markdown all.md   # merge runs

Environment: MESHMARK_MESH_DIR (default ../shared/data/meshes), MESHMARK (default
build/bin/meshmark), BLENDER (default blender).
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
OPERATIONS = ["ply", "obj", "gltf", "transform", "merge", "noise", "subdivide", "laplacian",
              "smooth", "decimate=0.5", "decimate=0.2", "decimate=0.05", "bisect", "voxel=300",
              "voxel=150"]
DESCRIPTION = {
    "ply": "round trip, PLY writer", "obj": "round trip, OBJ writer", "gltf": "round trip, glTF writer (.glb)",
    "transform": "move, rotate 20/30/40 deg, scale 1.5", "merge": "merge by distance (1e-4)",
    "noise": "Randomize Vertices 0.2%", "subdivide": "Subdivision Surface, 1 level",
    "laplacian": "Laplacian Smooth (defaults)", "smooth": "Smooth, factor 0.5 x 10",
    "decimate=0.5": "Decimate collapse 50%", "decimate=0.2": "Decimate collapse 20%",
    "decimate=0.05": "Decimate collapse 5%", "bisect": "bisect in half, keep one side",
    "voxel=300": "voxel remesh, diagonal/300", "voxel=150": "voxel remesh, diagonal/150",
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
    start = time.time()
    result = detect(args, blender_entry["output"], original, key)
    result.update({"mesh": os.path.basename(mesh), "key": key_seed, "marked": marked, "op": op,
                   "vertices": blender_entry["vertices"], "faces": blender_entry["faces"],
                   "detect_seconds": round(time.time() - start, 2)})
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
        run([args.meshmark, "attack", mesh, "none", "-o", blender_input, "-q"], "meshmark attack none")
    trials = []
    unmarked = blender_ops(args, blender_input, os.path.join(mesh_work, "unmarked"), 0, args.ops)
    for key_seed in range(1, args.keys + 1):
        key = os.path.join(mesh_work, "key%d.json" % key_seed)
        marked = os.path.join(mesh_work, "marked%d%s" % (key_seed, marked_ext))
        run([args.meshmark, "embed", mesh, "-o", marked, "--key", key, "--seed", str(key_seed),
             "--force", "-q"], "meshmark embed %s" % mesh)
        done = blender_ops(args, marked, os.path.join(mesh_work, "marked%d" % key_seed), key_seed,
                           args.ops)
        for op in args.ops:
            trials.append(trial(args, mesh, key_seed, True, op, done[op], mesh, key))
            trials.append(trial(args, mesh, key_seed, False, op, unmarked[op], mesh, key))
    return trials


def table(trials):
    meshes = list(dict.fromkeys(t["mesh"] for t in trials))
    ops = list(dict.fromkeys(t["op"] for t in trials))
    lines = ["| Blender operation | " + " | ".join(meshes) + " | unmarked copies claimed |",
             "|---|" + "---|" * len(meshes) + "---|"]
    for op in ops:
        cells = []
        for mesh in meshes:
            marked = [t for t in trials if t["op"] == op and t["mesh"] == mesh and t["marked"]]
            if not marked:
                cells.append("")
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
    parser.add_argument("--ops", nargs="+", default=OPERATIONS, help="attacks.py operations")
    parser.add_argument("--mesh-dir", default=os.environ.get("MESHMARK_MESH_DIR", "../shared/data/meshes"))
    parser.add_argument("--meshmark", default=os.environ.get("MESHMARK", "build/bin/meshmark"))
    parser.add_argument("--blender", default=os.environ.get("BLENDER", "blender"))
    parser.add_argument("--work-dir", help="keep the intermediate files here (default: a temporary folder)")
    parser.add_argument("--json-file", help="write every trial here")
    parser.add_argument("--markdown", help="write the table here (default: stdout)")
    parser.add_argument("--from-json", nargs="+", help="no runs: the table of these JSON files' trials")
    parser.add_argument("-q", "--quiet", action="store_true")
    args = parser.parse_args()
    if args.keys < 1:
        parser.error("--keys must be at least 1")

    if args.from_json:
        trials = []
        for path in args.from_json:
            with open(path) as f:
                trials += json.load(f)["trials"]
    else:
        for tool in (args.meshmark, args.blender):
            if shutil.which(tool) is None:
                raise Failure("%s: not found (set MESHMARK / BLENDER or --meshmark / --blender)" % tool)
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
                "command": " ".join(sys.argv), "keys": args.keys, "trials": trials}, indent=1) + "\n")
    text = table(trials)
    if args.markdown:
        write_atomically(args.markdown, text)
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    try:
        main()
    except Failure as e:
        print("rework.py: %s" % e, file=sys.stderr)
        sys.exit(1)
