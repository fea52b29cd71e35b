#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Every attack of the suite at its default level on every mesh file under the given folders:
no run may crash (a signal), nor fail inside (exit 5, an internal error). Files the readers refuse
(exit 3) and attacks that refuse a mesh with one sentence (exit 2) are counted, not failures.

  bench/robustness/crash_sweep.py /tmp/sh3f --every 8 --jobs 2 --json-file sweep.json

Prints one line per crash or failure and a summary; exits 1 when any run crashed or failed, 2
on bad arguments.
Environment: MESHMARK (default build/bin/meshmark).
"""
import argparse
import concurrent.futures
import json
import os
import subprocess
import sys
import tempfile
import time

# The suite's attacks at their default levels (`meshmark attack --help`), as the awkward-geometry
# test runs them (tests/unit/attacks/awkward_geometry_test.cpp).
ATTACKS = ["similarity", "noise", "smooth", "taubin", "quantize", "simplify", "remesh", "subdivide",
           "subdivide=midpoint", "subdivide=sqrt3", "crop", "reorder", "voxel"]
MESH_EXTENSIONS = (".obj", ".ply", ".off", ".stl", ".gltf", ".glb", ".3mf")
# The command-line contract's exit codes (docs/cli.md): 0 done, 2 bad option or refused attack,
# 3 unreadable input, 4 a mesh an algorithm cannot take.
CONTRACT_CODES = {0, 2, 3, 4}


def mesh_files(folders):
    found = []
    for folder in folders:
        for root, _, names in os.walk(folder):
            found += [os.path.join(root, n) for n in names if n.lower().endswith(MESH_EXTENSIONS)]
    return sorted(found)


def attack(meshmark, path, spec, out_dir):
    out = os.path.join(out_dir, "out.ply")
    start = time.time()
    done = subprocess.run([meshmark, "attack", path, spec, "-o", out, "-q", "--threads", "1"],
                          capture_output=True, text=True)
    return {"file": path, "attack": spec, "exit": done.returncode, "seconds": round(time.time() - start, 2),
            "stderr": done.stderr.strip().splitlines()[-1] if done.stderr.strip() else ""}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("folders", nargs="+")
    parser.add_argument("--every", type=int, default=1, help="take every Nth file (sorted by path)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--attacks", nargs="+", default=ATTACKS)
    parser.add_argument("--meshmark", default=os.environ.get("MESHMARK", "build/bin/meshmark"))
    parser.add_argument("--json-file")
    args = parser.parse_args()
    if args.every < 1 or args.jobs < 1:
        parser.error("--every and --jobs must be at least 1")
    for folder in args.folders:
        if not os.path.isdir(folder):
            parser.error("%s: no such folder" % folder)
    files = mesh_files(args.folders)[::args.every]
    if not files:
        parser.error("no mesh files under %s" % " ".join(args.folders))
    runs = []
    with tempfile.TemporaryDirectory(prefix="meshmark-sweep-") as scratch:
        folders = [os.path.join(scratch, str(k)) for k in range(len(files) * len(args.attacks))]
        with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
            futures = []
            for k, (path, spec) in enumerate((p, a) for p in files for a in args.attacks):
                os.makedirs(folders[k])
                futures.append(pool.submit(attack, args.meshmark, path, spec, folders[k]))
            for n, future in enumerate(concurrent.futures.as_completed(futures), 1):
                run = future.result()
                runs.append(run)
                if run["exit"] not in CONTRACT_CODES:
                    what = "CRASH, signal %d" % -run["exit"] if run["exit"] < 0 else "FAILED, exit %d" % run["exit"]
                    print("%s: meshmark attack %s %s: %s" % (what, run["file"], run["attack"], run["stderr"]),
                          flush=True)
                if sys.stderr.isatty():
                    print("\r%d/%d" % (n, len(futures)), end="", file=sys.stderr, flush=True)
    crashes = [r for r in runs if r["exit"] not in CONTRACT_CODES]
    by_code = {}
    for r in runs:
        by_code[r["exit"]] = by_code.get(r["exit"], 0) + 1
    print("%d files x %d attacks = %d runs; exit codes %s; %d crashes; longest %.1f s" % (
        len(files), len(args.attacks), len(runs), json.dumps(dict(sorted(by_code.items()))), len(crashes),
        max(r["seconds"] for r in runs)))
    if args.json_file:
        with open(args.json_file + ".tmp", "w") as f:
            json.dump({"command": " ".join(sys.argv), "runs": runs}, f, indent=1)
        os.replace(args.json_file + ".tmp", args.json_file)
    return 1 if crashes else 0


if __name__ == "__main__":
    sys.exit(main())
