#!/usr/bin/env python3
"""Experiment (issue 16, perceptual shaping): reshape a marked copy's displacement by vertex
density at the same surface distance, to see what detection gains before any detector change.

    meshmark embed M.obj -o orig.ply --key /tmp/zero.json --strength 0 --seed 1   # M as PLY, same order
    meshmark embed orig.ply -o marked.ply --key key.json --seed 3
    bench/shaping/density_shaping.py orig.ply marked.ply shaped.ply [--cap 4]
    meshmark attack shaped.ply remesh=0.05 -o a.ply --seed 1; meshmark detect a.ply --original orig.ply --key key.json

The displacement d_i = marked_i - orig_i becomes w_i d_i with w_i = mean(A) / A_i (A_i the
vertex's area, a third of its triangles'), clamped to [1/cap, cap], then scaled so that its
first-order RMS surface distance (meshmark's surface_rms_displacement, the same face formula)
is unchanged. Detection is meshmark's, unchanged: it reads U^T (W U b s), so an intact copy
scores below sqrt(96) (the weights mix the modes), but resampling attacks read more of the
mark where the vertices are dense. Reads and writes binary little-endian PLY with double
x, y, z and a uchar/int face list, as `meshmark embed` writes it. Needs numpy.
"""
import argparse
import sys

import numpy as np


def read_ply(path):
    with open(path, "rb") as f:
        header = b""
        while not header.endswith(b"end_header\n"):
            line = f.readline()
            if not line:
                sys.exit(f"{path}: no end_header")
            header += line
        text = header.decode("ascii", "replace")
        if "binary_little_endian" not in text or "property double x" not in text:
            sys.exit(f"{path}: expected binary little-endian PLY with double positions (meshmark's output)")
        vertices = int(text.split("element vertex ")[1].split()[0])
        faces = int(text.split("element face ")[1].split()[0])
        V = np.frombuffer(f.read(24 * vertices), dtype="<f8").reshape(vertices, 3).copy()
        rest = f.read()
    record = np.dtype([("n", "u1"), ("i", "<i4", 3)])
    F = np.frombuffer(rest[: faces * record.itemsize], dtype=record)
    if np.any(F["n"] != 3):
        sys.exit(f"{path}: only triangles are supported")
    return header, V, F["i"].copy(), rest


def surface_rms(V, F, d):
    cross = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    twice = np.linalg.norm(cross, axis=1)
    ok = twice > 0
    n = cross[ok] / twice[ok, None]
    a = np.stack([(n * d[F[ok, k]]).sum(1) for k in range(3)], 1)
    mean_square = (a**2).sum(1) + a[:, 0] * a[:, 1] + a[:, 1] * a[:, 2] + a[:, 2] * a[:, 0]
    return np.sqrt((twice[ok] * mean_square / 6).sum() / twice[ok].sum())


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("original")
    parser.add_argument("marked")
    parser.add_argument("output")
    parser.add_argument("--cap", type=float, default=4.0, help="weights clamped to [1/cap, cap] (default 4)")
    args = parser.parse_args()
    header, V0, F, rest = read_ply(args.original)
    _, V1, F1, _ = read_ply(args.marked)
    if V1.shape != V0.shape or not np.array_equal(F, F1):
        sys.exit("the marked copy does not share the original's vertices and faces")
    d = V1 - V0
    third = np.linalg.norm(np.cross(V0[F[:, 1]] - V0[F[:, 0]], V0[F[:, 2]] - V0[F[:, 0]]), axis=1) / 6
    area = np.zeros(len(V0))
    for k in range(3):
        np.add.at(area, F[:, k], third)
    used = area > 0
    weight = np.ones(len(V0))
    weight[used] = np.clip(area[used].mean() / area[used], 1 / args.cap, args.cap)
    shaped = d * weight[:, None]
    shaped *= surface_rms(V0, F, d) / surface_rms(V0, F, shaped)
    rms = lambda x: np.sqrt((x**2).sum(1).mean())
    print(f"surface RMS {surface_rms(V0, F, shaped):.4g} (unchanged), vertex RMS {rms(d):.4g} -> {rms(shaped):.4g}")
    with open(args.output, "wb") as f:
        f.write(header)
        f.write((V0 + shaped).astype("<f8").tobytes())
        f.write(rest)


if __name__ == "__main__":
    main()
