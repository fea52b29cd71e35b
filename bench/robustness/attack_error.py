#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""What an attack leaves of the mark
(bench/results/2026-11-26-what-an-attack-leaves.md).

Reads the trials of `meshmark bench robustness --json-file` runs and, for every (mesh, attack)
they hold, measures the attack's own error: the attack (seed 1) applied to the UNMARKED
original, then `meshmark compare` of the original with the result (MRMS, a fraction of the
diagonal). Dividing by the mark's strength (the RMS surface distance between the marked and the
original surface, 0.059% of the diagonal at the defaults) says how many times larger than the
mark the attack's own change is: the noise the reading has to see the mark through. Prints a
markdown table of the marked copies claimed per band of that ratio (all attacks, then per
attack family: the first step's name), the same per band of each
copy's registration RMS (what `meshmark detect` reports) over the strength, then one row per
(mesh, attack) sorted by the first ratio; --json-file keeps every measurement.

  PYTHONPATH=build/python python3 bench/robustness/attack_error.py --trials grid.json \\
      [--trials more.json] [--mesh-dir ../shared/data/meshes] [--json-file errors.json]

Only attacks that change the surface (simplify, remesh, voxel, crop, noise, smooth, ...) make
sense here; rows of attacks that keep it exactly (reorder, similarity) read about 0.
"""
import argparse
import json
import os
import tempfile

import meshmark as mm

DEFAULT_STRENGTH = 0.00059  # the additive rule's default surface strength, fraction of the diagonal
BANDS = [0.0, 1.0, 2.0, 3.0, 4.0, 6.0, 10.0, float("inf")]


def attack_error(path, spec):
    """MRMS between the original at \\p path and its attacked copy (seed 1), fraction of the diagonal."""
    V, F = mm.read_mesh(path)
    A, G = mm.attack_mesh(V, F, spec, seed=1)[:2]
    with tempfile.TemporaryDirectory() as folder:
        attacked = os.path.join(folder, "attacked.ply")
        mm.write_mesh(attacked, A, G)
        return mm.compare(path, attacked)["mrms"], len(A)


def band_label(low, high):
    return f">= {low:g}" if high == float("inf") else f"{low:g}-{high:g}"


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--trials", action="append", required=True, help="a bench robustness --json-file")
    parser.add_argument("--mesh-dir", default=os.environ.get("MESHMARK_MESH_DIR", "../shared/data/meshes"))
    parser.add_argument("--json-file", help="write every (mesh, attack) measurement here")
    args = parser.parse_args()

    trials, strength = [], None
    for path in args.trials:
        with open(path) as f:
            run = json.load(f)
        given = run["settings"].get("strength", -1.0)
        run_strength = given if given > 0 else DEFAULT_STRENGTH
        if strength is not None and abs(run_strength - strength) > 1e-12:
            parser.error(f"{path}: strength {run_strength} differs from the other runs' {strength}")
        strength = run_strength
        trials += [t for t in run["trials"] if t["kind"] == "marked" and t["attack"] != "none" and not t["error"]]
    cells = {}
    for t in trials:
        cells.setdefault((t["mesh"], t["attack"]), []).append(t)

    rows = []
    for (mesh, spec), ts in sorted(cells.items()):
        path = os.path.join(args.mesh_dir, mesh)
        mrms, vertices = attack_error(path, spec)
        rows.append({"mesh": mesh, "attack": spec, "attack_mrms": mrms, "ratio": mrms / strength,
                     "vertices_after": vertices, "copies": len(ts), "claimed": sum(t["detected"] for t in ts),
                     "mean_z": sum(t["score"] for t in ts) / len(ts), "min_z": min(t["score"] for t in ts)})
        print(f"{mesh} {spec}: attack MRMS {100 * mrms:.3f}% = {mrms / strength:.2f} x the mark, "
              f"{rows[-1]['claimed']}/{len(ts)} claimed", flush=True)

    print(f"\nMark strength {100 * strength:.3f}% of the diagonal; ratio = attack MRMS / strength.\n")
    # Per band, every attack and each attack family (the step's name: simplify, remesh, ...).
    families = sorted({r["attack"].split(",")[0].split("=")[0].split(":")[0] for r in rows})

    def cell(band):
        if not band:
            return "-"
        copies = sum(r["copies"] for r in band)
        claimed = sum(r["claimed"] for r in band)
        mean_z = sum(r["mean_z"] * r["copies"] for r in band) / copies
        return f"{claimed}/{copies}, {mean_z:.2f}"

    print("| attack MRMS / mark | all: claimed, mean z | " + " | ".join(f"`{f}`" for f in families) + " |")
    print("|---" * (2 + len(families)) + "|")
    for low, high in zip(BANDS, BANDS[1:]):
        band = [r for r in rows if low <= r["ratio"] < high]
        if band:
            by_family = [cell([r for r in band if r["attack"].split(",")[0].split("=")[0].split(":")[0] == f])
                         for f in families]
            print(f"| {band_label(low, high)} | {cell(band)} | " + " | ".join(by_family) + " |")
    # The same bands over each copy's own registration RMS (the suspect's distance to the
    # original, what `meshmark detect` reports as registration rms_error), marked copies only.
    print("\n| registration RMS / mark | copies | claimed | mean z |")
    print("|---|---|---|---|")
    for low, high in zip(BANDS, BANDS[1:]):
        band = [t for t in trials if low <= t["registration_rms"] / strength < high]
        if band:
            claimed = sum(t["detected"] for t in band)
            print(f"| {band_label(low, high)} | {len(band)} | {claimed} ({100 * claimed / len(band):.0f}%) "
                  f"| {sum(t['score'] for t in band) / len(band):.2f} |")
    print("\n| mesh | attack | vertices left | attack MRMS | / mark | claimed | mean z | min z |")
    print("|---|---|---|---|---|---|---|---|")
    for r in sorted(rows, key=lambda r: r["ratio"]):
        print(f"| {r['mesh']} | {r['attack']} | {r['vertices_after']} | {100 * r['attack_mrms']:.3f}% "
              f"| {r['ratio']:.2f} | {r['claimed']}/{r['copies']} | {r['mean_z']:.2f} | {r['min_z']:.2f} |")
    if args.json_file:
        with open(args.json_file, "w") as f:
            json.dump({"strength": strength, "cells": rows}, f, indent=1)


if __name__ == "__main__":
    main()
