#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""How far a resampled copy's surface is from the mark, read at the original's vertices
(bench/results/2026-11-28-dragon-res4-10pct-by-real-tools.md).

    /usr/bin/python3 bench/robustness/copy_error.py ORIGINAL MARKED COPY

MARKED is the marked mesh with the original's vertex order (meshmark embed's output); COPY is
an attacked copy in the original's frame (no similarity). For each original vertex: the mark,
its marked vertex's offset along the original's area-weighted normal; the copy's offset, from
the original vertex to its closest point on the copy along the same normal; their difference is
the reading's error there. Printed: the copy's vertices, faces and vertices on a border (an
edge of one face), and the error's RMS and median in mark amplitudes (the mark's RMS normal
offset) with the correlation of the offsets with the mark, over all rows and split by whether
the closest point lies on a border of the copy.

Needs numpy and open3d (Debian's python3-numpy and python3-open3d: /usr/bin/python3).
"""
import collections
import sys

import numpy as np
import open3d as o3d


def load(path):
    mesh = o3d.io.read_triangle_mesh(path)
    return np.asarray(mesh.vertices), np.asarray(mesh.triangles)


def main(original_path, marked_path, copy_path):
    V, F = load(original_path)
    marked, _ = load(marked_path)
    C, CF = load(copy_path)
    if marked.shape != V.shape:
        sys.exit(f"{marked_path}: {len(marked)} vertices, the original has {len(V)}: not the marked mesh in its order")
    face_normals = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    N = np.zeros_like(V)
    for corner in range(3):
        np.add.at(N, F[:, corner], face_normals)
    N /= np.linalg.norm(N, axis=1)[:, None] + 1e-300
    mark = np.einsum("ij,ij->i", marked - V, N)
    amplitude = np.sqrt(np.mean(mark ** 2))

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(C.astype(np.float32)), o3d.core.Tensor(CF.astype(np.uint32)))
    closest = scene.compute_closest_points(o3d.core.Tensor(V.astype(np.float32)))
    points = closest["points"].numpy().astype(float)
    triangle = CF[closest["primitive_ids"].numpy()]
    uv = closest["primitive_uvs"].numpy()
    offset = np.einsum("ij,ij->i", points - V, N)

    edges = np.sort(np.concatenate([CF[:, [0, 1]], CF[:, [1, 2]], CF[:, [2, 0]]]), axis=1)
    uses = collections.Counter(map(tuple, edges))
    border_vertices = {v for edge, count in uses.items() if count == 1 for v in edge}
    # The closest point is on a border when it lies on a border edge or at a border vertex.
    weights = np.stack([1 - uv[:, 0] - uv[:, 1], uv[:, 0], uv[:, 1]], axis=1)
    on_border = np.zeros(len(V), bool)
    for i in range(len(V)):
        zero = [c for c in range(3) if weights[i, c] < 1e-4]
        corners = triangle[i]
        if len(zero) >= 2:
            on_border[i] = int(corners[[c for c in range(3) if c not in zero][0]]) in border_vertices
        elif len(zero) == 1:
            c = zero[0]
            edge = tuple(sorted((int(corners[(c + 1) % 3]), int(corners[(c + 2) % 3]))))
            on_border[i] = uses[edge] == 1

    error = (offset - mark) / amplitude
    diagonal = np.linalg.norm(V.max(0) - V.min(0))
    print(f"{copy_path}: {len(C)} vertices, {len(CF)} faces, {len(border_vertices)} vertices on a border; "
          f"mark amplitude {100 * amplitude / diagonal:.4f}% of the diagonal")
    for name, rows in (("all rows", np.ones(len(V), bool)), ("closest point on a border", on_border),
                       ("closest point inside", ~on_border)):
        if rows.sum() < 2:
            continue
        e = error[rows]
        print(f"  {name}: {rows.sum()} rows, error RMS {np.sqrt(np.mean(e ** 2)):.2f}, median |error| "
              f"{np.median(np.abs(e)):.2f} amplitudes, correlation with the mark "
              f"{np.corrcoef(offset[rows], mark[rows])[0, 1]:.3f}")


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__.strip().split("\n\n")[1].strip())
    main(*sys.argv[1:])
