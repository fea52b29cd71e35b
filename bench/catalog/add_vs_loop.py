#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""`meshmark catalog add` of a folder against a loop of `meshmark embed` over the same files
(issue 53's throughput target), side by side: A and B alternate, --pairs times, each timed as a
whole with getrusage of the children (wall, user + system CPU, peak RSS of the largest process).
Prints the medians, the A/B wall ratio of each pair, and the throughput ratio B/A as JSON.

  python3 bench/catalog/add_vs_loop.py SH3F --pairs 3

SRC is a folder of mesh files (every .obj, .ply, .off, .stl, .glb, .gltf, .3mf under it, as
`catalog add` finds them; hidden folders skipped). The loop writes each copy and its key file
(`embed FILE -o N.EXT --key N.json -q`), one process per file, as a shell loop would.
"""
import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

EXTENSIONS = {".obj", ".ply", ".off", ".stl", ".glb", ".gltf", ".3mf"}


def default_cli():
    return str(Path(__file__).resolve().parents[2] / "build" / "bin" / "meshmark")


def mesh_files(src):
    files = []
    for root, dirs, names in os.walk(src):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        files += [Path(root) / n for n in sorted(names) if Path(n).suffix.lower() in EXTENSIONS]
    return files


def timed(run):
    """Wall seconds, CPU seconds and peak RSS (MiB) of the children \\p run starts."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    run()
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, after.ru_maxrss / 1024.0


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("src")
    parser.add_argument("--cli", default=default_cli())
    parser.add_argument("--pairs", type=int, default=3)
    parser.add_argument("--work", help="scratch folder (default: a temporary one)")
    args = parser.parse_args()
    files = mesh_files(args.src)
    if not files:
        print(f"add_vs_loop: no mesh files under {args.src}", file=sys.stderr)
        return 2
    work = Path(args.work or tempfile.mkdtemp(prefix="meshmark-add-vs-loop-"))
    work.mkdir(parents=True, exist_ok=True)

    def add():
        shutil.rmtree(work / "add", ignore_errors=True)
        (work / "add").mkdir()
        subprocess.run([args.cli, "catalog", "add", str(work / "add" / "cat.db"), args.src,
                        "-o", str(work / "add" / "out"), "-q"], check=True)

    def loop():
        shutil.rmtree(work / "loop", ignore_errors=True)
        (work / "loop").mkdir()
        for i, f in enumerate(files):
            # A file that cannot carry a mark fails here as it is refused there.
            subprocess.run([args.cli, "embed", str(f), "-o", str(work / "loop" / f"{i}{f.suffix}"),
                            "--key", str(work / "loop" / f"{i}.json"), "-q"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    a, b = [], []
    for _ in range(args.pairs):
        a.append(timed(add))
        b.append(timed(loop))
    ratios = [x[0] / y[0] for x, y in zip(a, b)]
    median = lambda rows, k: round(statistics.median(r[k] for r in rows), 2)
    print(json.dumps({
        "files": len(files), "pairs": args.pairs,
        "add": {"wall_s": median(a, 0), "cpu_s": median(a, 1), "walls": [round(x[0], 2) for x in a]},
        "loop": {"wall_s": median(b, 0), "cpu_s": median(b, 1), "walls": [round(x[0], 2) for x in b]},
        "add_over_loop_wall": [round(r, 3) for r in ratios],
        "throughput_ratio": round(1.0 / statistics.median(ratios), 2),
    }, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
