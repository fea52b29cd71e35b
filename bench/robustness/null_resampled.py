#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Null study on resampled suspects (docs/robustness.md, "Rows weighted by their distance").

Unmarked copies of each mesh, put through attacks that make detection register and resample
them, are read with many keys (seeds FIRST .. FIRST+KEYS-1, each embedded in memory on the
original): every reading is a trial of the false-positive bound on the path where the far rows
are left out and the others weighted by their distance. Prints, per mesh, the readings so far,
the largest z and the claims (there should be none); then the share of readings at or above
z = 2.5, 3 and 3.5 against the bound of docs/statistics.md.

Usage: null_resampled.py --mesh M [--mesh ...] [--keys 417] [--first-seed 1000]
       [--attacks "remesh=0.25;remesh=0.05;voxel=150;simplify=0.02"] [--json-file out.json]
Needs the Python package (PYTHONPATH=build/python after a build).
"""
import argparse
import json
import math
import time

import meshmark as mm


def bound(t, statistics=10):
    """The verdict's bound on the score alone for a resampled suspect: 10 statistics (two
    readings of 3 weightings and 2 damped readings each), Hoeffding / Pinelis."""
    tail = min(math.exp(-t * t / 2), 2 * math.exp(3) / 9 * 0.5 * math.erfc(t / math.sqrt(2)))
    return min(1.0, statistics * tail)


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
                                 "detected": bool(r.detected)})
        print(f"{path}: {len(readings)} readings, {time.time() - start:.0f} s, largest z "
              f"{max(x['score'] for x in readings):.2f}, claimed {sum(x['detected'] for x in readings)}", flush=True)
    for t in (2.5, 3.0, 3.5):
        share = sum(x["score"] >= t for x in readings) / len(readings)
        print(f"z >= {t}: {share:.5f} of the readings, bound {bound(t):.5f}")
    if args.json_file:
        with open(args.json_file, "w") as f:
            json.dump(readings, f)


if __name__ == "__main__":
    main()
