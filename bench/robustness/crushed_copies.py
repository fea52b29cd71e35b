#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Copies with part of the mesh crushed, in the original's vertex order and renumbered as
Blender's PLY writer numbers them (bench/results/2026-11-28-held-out-cad-blender-rework.md).

    PYTHONPATH=build/python /usr/bin/python3 bench/robustness/crushed_copies.py \
        --meshmark build/bin/meshmark --work /tmp/crushed fandisk.obj bunny.off rocker-arm.obj

For each mesh (a path, or a name in MESHMARK_MESH_DIR, default ../shared/data/meshes): `meshmark
embed --seed 1`, then for each fraction f the marked and the unmarked mesh with the f nearest
vertices to vertex 0 moved onto their centroid (what Blender's Smooth modifier does to a CAD
part's small pieces), written twice: with the original's triangles and vertex order, and with
the vertices numbered in the order the triangles first use them (Blender's PLY writer). Each
copy is read with `meshmark detect --json`; printed per copy: the score, whether it is claimed,
how it was put in correspondence and the rows left out. Exits 1 if a marked copy is not claimed
or an unmarked one is.
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

import meshmark


def first_use_numbering(F):
    number = -np.ones(int(F.max()) + 1, dtype=np.int64)
    next_number = 0
    G = np.empty_like(F)
    for f in range(len(F)):
        for k in range(3):
            v = F[f, k]
            if number[v] < 0:
                number[v] = next_number
                next_number += 1
            G[f, k] = number[v]
    return number, G.astype(np.int32)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("meshes", nargs="+")
    parser.add_argument("--meshmark", default=os.environ.get("MESHMARK", "build/bin/meshmark"))
    parser.add_argument("--work", required=True)
    parser.add_argument("--fractions", type=float, nargs="+", default=[0.1, 0.2, 0.25, 0.33])
    args = parser.parse_args()
    mesh_dir = os.environ.get("MESHMARK_MESH_DIR", "../shared/data/meshes")
    os.makedirs(args.work, exist_ok=True)
    failures = 0
    for name in args.meshes:
        original = name if os.path.exists(name) else os.path.join(mesh_dir, name)
        stem = os.path.basename(original)
        marked = os.path.join(args.work, f"{stem}.marked.ply")
        key = os.path.join(args.work, f"{stem}.key.json")
        subprocess.run([args.meshmark, "embed", original, "-o", marked, "--key", key, "--seed", "1", "-q"],
                       check=True)
        V, F = meshmark.read_mesh(original)
        distance = np.linalg.norm(V - V[0], axis=1)
        number, renumbered_faces = first_use_numbering(F)
        for kind, path in (("marked", marked), ("unmarked", original)):
            P, _ = meshmark.read_mesh(path)
            for fraction in args.fractions:
                crushed = P.copy()
                chosen = distance <= np.sort(distance)[int(len(distance) * fraction)]
                crushed[chosen] = crushed[chosen].mean(axis=0)
                renumbered = np.empty_like(crushed)
                renumbered[number] = crushed
                for numbering, (positions, faces) in (("in order", (crushed, F)),
                                                      ("renumbered", (renumbered, renumbered_faces))):
                    copy = os.path.join(args.work, f"{stem}.{kind}.{fraction}.{numbering.replace(' ', '_')}.ply")
                    meshmark.write_mesh(copy, positions, faces)
                    report = json.loads(subprocess.run(
                        [args.meshmark, "detect", copy, "--original", original, "--key", key, "--json"],
                        capture_output=True, text=True).stdout)
                    wrong = report["detected"] != (kind == "marked")
                    failures += wrong
                    print(f"{stem:16s} {kind:8s} crushed {fraction:4.2f} {numbering:10s} z {report['score']:6.2f} "
                          f"{'claimed' if report['detected'] else 'not claimed':11s} "
                          f"{report['registration']['method']}, rows left out {report['outlier_fraction']:.2f}"
                          f"{'  <-- wrong' if wrong else ''}")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
