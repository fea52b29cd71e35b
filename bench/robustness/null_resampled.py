#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Null study on resampled suspects (bench/results/2026-11-25-rows-weighted-by-distance.md;
the latest run in bench/results/2026-11-26-voxel-remeshes-not-vertices.md).

Unmarked copies of each mesh, put through attacks that make detection register and resample
them, are read with many keys (seeds FIRST .. FIRST+KEYS-1, each embedded in memory on the
original): every reading is a trial of the false-positive bound on the path where the far rows
are left out and the others weighted by their distance (and, for attacks that keep the
original's vertices, such as a reorder or a midpoint subdivision, on the vertex-matching path).
Prints, per mesh, the readings so far, the largest z and the claims (there should be none);
then, for p = 0.1, 0.01 and 0.001, the share of readings whose score alone has a
false-positive bound of at most p: the bound of docs/statistics.md says that share cannot
exceed p in expectation, whatever the number of statistics the verdict paid for.

Usage: null_resampled.py --mesh M [--mesh ...] [--keys 417] [--first-seed 1000]
       [--attacks "remesh=0.25;remesh=0.05;voxel=150;simplify=0.02"] [--json-file out.json]
Needs the Python package (PYTHONPATH=build/python after a build).
"""
import argparse
import json
import time

import meshmark as mm


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--mesh", action="append", required=True)
    parser.add_argument("--keys", type=int, default=417)
    parser.add_argument("--first-seed", type=int, default=1000)
    parser.add_argument("--attacks", default="remesh=0.25;remesh=0.05;voxel=150;simplify=0.02")
    parser.add_argument("--json-file")
    args = parser.parse_args()
    readings = []
    start = time.time()
    for path in args.mesh:
        V, F = mm.read_mesh(path)
        suspects = [(a,) + tuple(mm.attack_mesh(V, F, a, seed=1)[:2]) for a in args.attacks.split(";")]
        for seed in range(args.first_seed, args.first_seed + args.keys):
            key, _ = mm.embed(V, F, seed=seed, threads=1)
            for attack, Va, Fa in suspects:
                r = mm.detect(Va, Fa, V, F, key, threads=1)
                readings.append({"mesh": path, "attack": attack, "seed": seed, "score": r.score,
                                 "score_fpp": r.score_false_positive_probability,
                                 "method": r.alignment, "detected": bool(r.detected)})
        print(f"{path}: {len(readings)} readings, {time.time() - start:.0f} s, largest z "
              f"{max(x['score'] for x in readings):.2f}, claimed {sum(x['detected'] for x in readings)}", flush=True)
    for p in (0.1, 0.01, 0.001):
        share = sum(x["score_fpp"] <= p for x in readings) / len(readings)
        print(f"score's bound <= {p}: {share:.5f} of the readings (the bound says at most {p})")
    methods = sorted({x["method"] for x in readings})
    for method in methods:
        scores = [x["score"] for x in readings if x["method"] == method]
        print(f"{method}: {len(scores)} readings, largest z {max(scores):.2f}")
    if args.json_file:
        with open(args.json_file, "w") as f:
            json.dump(readings, f)


if __name__ == "__main__":
    main()
