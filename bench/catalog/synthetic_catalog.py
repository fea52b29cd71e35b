#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""A synthetic catalogue of near-duplicates for the scan benchmark (issue 53).

From a folder of real meshes (e.g. the 820 Sweet Home 3D furniture models of Debian's
sweethome3d-furniture, unzipped), writes --count originals under OUT: every source mesh once,
then variants of them until the count is reached -- the same object stretched along an axis,
bent, twisted, tapered, or "scanned twice" (small smooth noise), each a distinct original that
looks like its source: the near-duplicates a marketplace holds. Files are binary PLY named
<source>-v<k>.ply. Uses the meshmark Python package (PYTHONPATH=build/python) and numpy.

  PYTHONPATH=build/python python3 bench/catalog/synthetic_catalog.py SRC OUT --count 10000
"""
import argparse
import sys
from pathlib import Path

import numpy as np

import meshmark


def variant(V, k, rng):
    """One deformation of V (n, 3), chosen by k."""
    c = V.mean(axis=0)
    X = V - c
    extent = np.ptp(X, axis=0).max() or 1.0
    kind = k % 5
    axis = rng.integers(3)
    if kind == 0:  # stretched
        s = np.ones(3)
        s[axis] = rng.uniform(0.75, 1.35)
        X = X * s
    elif kind == 1:  # bent
        other = (axis + 1) % 3
        X[:, other] += rng.uniform(0.1, 0.3) * (X[:, axis] / extent) ** 2 * extent
    elif kind == 2:  # twisted
        a, b = [i for i in range(3) if i != axis]
        t = rng.uniform(0.2, 0.6) * X[:, axis] / extent
        x, y = X[:, a].copy(), X[:, b].copy()
        X[:, a] = np.cos(t) * x - np.sin(t) * y
        X[:, b] = np.sin(t) * x + np.cos(t) * y
    elif kind == 3:  # tapered
        s = 1.0 + rng.uniform(-0.3, 0.3) * X[:, axis] / extent
        for i in range(3):
            if i != axis:
                X[:, i] *= s
    else:  # scanned twice: smooth low-frequency noise of about 1% of the extent
        f = rng.normal(size=(3, 3))
        X = X + 0.01 * extent * np.sin(X @ f / extent * 3.0)
    return X + c


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("src")
    parser.add_argument("out")
    parser.add_argument("--count", type=int, default=10000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--min-vertices", type=int, default=200)
    parser.add_argument("--max-vertices", type=int, default=15000,
                        help="sources larger than this are left out (the bench times scans, not embeds)")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    sources = []
    for path in sorted(Path(args.src).rglob("*")):
        if path.suffix.lower() in (".obj", ".ply", ".off", ".stl") and path.is_file():
            try:
                V, F = meshmark.read_mesh(path)
            except meshmark.Error:
                continue
            if args.min_vertices <= len(V) <= args.max_vertices:
                sources.append((path.stem, np.asarray(V), np.asarray(F)))
    if not sources:
        print("synthetic_catalog: no usable meshes under " + args.src, file=sys.stderr)
        return 1
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    written = 0
    k = 0
    while written < args.count:
        for i, (stem, V, F) in enumerate(sources):
            if written >= args.count:
                break
            W = V if k == 0 else variant(V.copy(), k + i, rng)
            meshmark.write_mesh(out / f"{i:04d}-{stem}-v{k}.ply", W, F)
            written += 1
        k += 1
    print(f"synthetic_catalog: {written} originals from {len(sources)} sources in {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
