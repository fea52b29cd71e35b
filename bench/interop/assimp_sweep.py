#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Mark every model of Debian's assimp-testmodels as glTF and check the marked copies with the
ecosystem's own tools (docs/interop.md, "Other people's files in bulk").

Each model under /usr/share/assimp/models (its `invalid` folder left out) in a format assimp
imports is converted by `assimp export MODEL in.glb -tri -jiv`; `meshmark embed` marks it
(seed 7); `meshmark detect` reads the marked copy against it; the Khronos validator must report
the same issues for both files, and glTF-Transform (tests/interop/read_positions.mjs, an
independent reader) must find as many positions in both, moved by the mark only.

    python3 bench/interop/assimp_sweep.py --meshmark build/bin/meshmark --work /tmp/sweep

With --draco each converted model is compressed by `gltf-transform draco` first and the
compressed file is the original (the skinned characters among them carry their joints and
weights inside the Draco data). meshmark re-encodes a moved Draco primitive, and edgebreaker
may renumber its points, so the positions are then matched to their nearest (Open3D's k-d tree:
run it with a Python that has open3d and numpy, Debian's /usr/bin/python3): the largest such
distance is a lower bound of the largest move, and a wrong or scrambled position still shows.

Needs assimp-utils, assimp-testmodels, node and the interop suite's npm packages
(scripts/setup.sh installs them). Prints one line per model and a summary; --json-file keeps
every row. Exit status 1 when a marked copy is not claimed, the validator's report changes, or
the independent reader sees other positions than the mark explains.
"""
import argparse
import json
import math
import os
import pathlib
import shutil
import struct
import subprocess
import sys

MODELS = pathlib.Path("/usr/share/assimp/models")
# What assimp imports (its own test models use these extensions).
EXTENSIONS = {".fbx", ".3ds", ".dae", ".x", ".ase", ".ms3d", ".md2", ".md5mesh", ".lwo", ".blend", ".b3d",
              ".ac", ".irrmesh", ".smd", ".mdl", ".x3d", ".amf", ".cob", ".q3o", ".ogex", ".3d", ".nff",
              ".raw", ".xgl", ".zgl", ".m3d", ".csm", ".hmp", ".ifc", ".sib", ".iqm", ".xml", ".wrl", ".dxf",
              ".ter", ".mdc", ".lws", ".bvh"}
INTEROP = pathlib.Path(__file__).resolve().parents[2] / "tests" / "interop"


def run(words, timeout=300):
    return subprocess.run(words, capture_output=True, text=True, timeout=timeout)


def last_json(text):
    """The last line of a helper's output that is a JSON object (glTF-Transform may warn first)."""
    for line in reversed(text.strip().splitlines()):
        if line.startswith("{"):
            return json.loads(line)
    raise ValueError("no JSON in: " + text[-300:])


def positions(path, scratch):
    """World positions as glTF-Transform reads them, or None when it cannot read the file."""
    out = scratch / (path.stem + ".positions")
    run(["node", str(INTEROP / "read_positions.mjs"), str(path), str(out)])
    if not out.exists():
        return None
    data = out.read_bytes()
    return [struct.unpack_from("<3d", data, 24 * i) for i in range(len(data) // 24)]


def nearest_distances(before, after, diagonal):
    """Each position of \p after to its nearest of \p before, over \p diagonal."""
    import numpy
    import open3d

    cloud = open3d.geometry.PointCloud(open3d.utility.Vector3dVector(numpy.asarray(before, dtype=float)))
    tree = open3d.geometry.KDTreeFlann(cloud)
    return [math.sqrt(tree.search_knn_vector_3d(numpy.asarray(q, dtype=float), 1)[2][0]) / diagonal for q in after]


def validation(path):
    report = last_json(run(["node", str(INTEROP / "validate.mjs"), str(path)]).stdout)
    return {key: report[key] for key in ("errors", "warnings", "codes")}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--meshmark", default="build/bin/meshmark", help="the meshmark binary")
    parser.add_argument("--work", required=True, help="scratch folder (emptied first)")
    parser.add_argument("--json-file", help="write every row as JSON here")
    parser.add_argument("--draco", action="store_true", help="compress each converted model with gltf-transform draco first")
    args = parser.parse_args()
    meshmark = str(pathlib.Path(args.meshmark).resolve())
    work = pathlib.Path(args.work)
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    models = sorted(p for p in MODELS.rglob("*")
                    if p.is_file() and "invalid" not in p.parts and p.suffix.lower() in EXTENSIONS)
    rows = []
    for n, model in enumerate(models):
        row = {"model": str(model.relative_to(MODELS))}
        scratch = work / str(n)
        scratch.mkdir()
        source = scratch / "in.glb"
        marked = scratch / "marked.glb"
        key = scratch / "key.json"
        run(["assimp", "export", str(model), str(source), "-tri", "-jiv"], timeout=120)
        if args.draco and source.exists() and source.stat().st_size > 0:
            compressed = scratch / "in_draco.glb"
            run([str(INTEROP / "node_modules" / ".bin" / "gltf-transform"), "draco", str(source), str(compressed)])
            source = compressed
        if not source.exists() or source.stat().st_size == 0:
            row["result"] = "assimp cannot convert it" if not args.draco else "assimp or gltf-transform draco cannot convert it"
        else:
            embed = run([meshmark, "embed", str(source), "-o", str(marked), "--key", str(key), "--seed", "7", "-q"])
            if embed.returncode != 0:
                row["result"] = "refused (exit %d)" % embed.returncode
                row["message"] = embed.stderr.strip()
            else:
                detect = run([meshmark, "detect", str(marked), "--original", str(source), "--key", str(key), "--json"])
                report = json.loads(detect.stdout)
                row["claimed"] = detect.returncode == 0
                row["z"] = report.get("score")
                row["same_validation"] = validation(source) == validation(marked)
                before, after = positions(source, scratch), positions(marked, scratch)
                if before is None:
                    # (assimp names images by paths relative to the model's own folder, which
                    # glTF-Transform must load and cannot find: the source is unreadable to it.)
                    row["positions"] = "glTF-Transform cannot read the source"
                    before = after = [] if after is None else None
                else:
                    row["positions"] = [len(before), len(after) if after is not None else None]
                if before and after and len(before) == len(after):
                    lo = [min(p[d] for p in before) for d in range(3)]
                    hi = [max(p[d] for p in before) for d in range(3)]
                    diagonal = math.dist(lo, hi)
                    moves = ([math.dist(p, q) / diagonal for p, q in zip(before, after)] if not args.draco
                             else nearest_distances(before, after, diagonal))
                    row["max_move"] = max(moves)
                    row["rms_move"] = math.sqrt(sum(m * m for m in moves) / len(moves))
                same_positions = (before == [] and after == []) or (
                    bool(before) and after is not None and len(before) == len(after)
                    and 0 < row.get("max_move", 0) < 0.01)
                row["result"] = "marked" if row["claimed"] and row["same_validation"] and same_positions else "FAULT"
        rows.append(row)
        print(json.dumps(row), flush=True)
    counts = {}
    for row in rows:
        kind = row["result"].split(" (")[0]
        counts[kind] = counts.get(kind, 0) + 1
    marked_rows = [r for r in rows if "z" in r]
    summary = {"models": len(rows), "by_result": counts}
    if marked_rows:
        summary["z_min"] = min(r["z"] for r in marked_rows)
        summary["max_move_max"] = max(r.get("max_move", 0) for r in marked_rows)
        summary["rms_move_range"] = [min(r.get("rms_move", 0) for r in marked_rows),
                                     max(r.get("rms_move", 0) for r in marked_rows)]
    print(json.dumps(summary))
    if args.json_file:
        pathlib.Path(args.json_file).write_text(json.dumps({"summary": summary, "rows": rows}, indent=1))
    return 1 if counts.get("FAULT") else 0


if __name__ == "__main__":
    sys.exit(main())
