#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""How far triangles read from an OBJ list's polygons are from the polygons themselves: per file,
the polygons' own area (Newell's normal: exact for planar polygons), the area of their fans from
the first corner (what meshmark's OBJ reader did before it triangulated concave polygons inside),
and the area of the triangles meshmark reads now (its Python module). Reports the files off by
more than 5% either way.

  PYTHONPATH=build/python /usr/bin/python3 bench/robustness/fan_area.py LIST

LIST holds one OBJ path per line (whitespace-separated); meshmark's column is left out when the
module is not importable.
"""
import sys

import numpy as np

try:
    import meshmark
except ImportError:
    meshmark = None


def polygons(path):
    V, faces = [], []
    for line in open(path, errors="replace"):
        if line.startswith("v "):
            V.append([float(x) for x in line.split()[1:4]])
        elif line.startswith("f "):
            idx = [int(t.split("/")[0]) for t in line.split()[1:]]
            if len(idx) >= 3:
                faces.append(idx)
    V = np.array(V)
    n = len(V)
    return V, [[i - 1 if i > 0 else n + i for i in f] for f in faces]


def main():
    paths = open(sys.argv[1] if len(sys.argv) > 1 else "/tmp/f820.txt").read().split()
    with_polygons = 0
    fan_off, read_off = [], []
    for path in paths:
        V, faces = polygons(path)
        if not any(len(f) > 3 for f in faces):
            continue
        with_polygons += 1
        true = fan = 0.0
        for f in faces:
            P = V[f]
            newell = np.zeros(3)
            for k in range(len(P)):
                newell += np.cross(P[k], P[(k + 1) % len(P)])
            true += np.linalg.norm(newell) / 2
            fan += sum(np.linalg.norm(np.cross(P[k] - P[0], P[k + 1] - P[0])) / 2
                       for k in range(1, len(P) - 1))
        name = path.split("/")[-1]
        if true > 0 and abs(fan / true - 1) > 0.05:
            fan_off.append((round(fan / true, 3), name))
        if meshmark is not None and true > 0:
            MV, MF = meshmark.read_mesh(path)[:2]
            MV, MF = np.asarray(MV), np.asarray(MF)
            read = np.linalg.norm(np.cross(MV[MF[:, 1]] - MV[MF[:, 0]], MV[MF[:, 2]] - MV[MF[:, 0]]),
                                  axis=1).sum() / 2
            if abs(read / true - 1) > 0.05:
                read_off.append((round(read / true, 3), name))
    print("files with polygons:", with_polygons)
    print("fans from the first corner off the polygons' area by > 5%:", len(fan_off),
          sorted(fan_off)[-8:])
    if meshmark is not None:
        print("meshmark's triangles off the polygons' area by > 5%:", len(read_off), sorted(read_off))


if __name__ == "__main__":
    main()
