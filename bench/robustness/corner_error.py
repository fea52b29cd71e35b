#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Where a quadric decimation put its vertices, against the original's surface and against a
prediction of its own placement (bench/results/2026-11-28-five-readings-of-a-5pct-decimation.md).

    meshmark detect COPY --original ORIGINAL --key KEY --json > copy.json
    PYTHONPATH=build/python /usr/bin/python3 bench/robustness/corner_error.py \
        ORIGINAL RECORDS COPY copy.json [--area]

ORIGINAL is the original file (its positions, welded, give the surface and its normals);
RECORDS is the original as the decimating tool held it, in the copy's frame (for Blender: its
PLY round trip of the original, whose vertex records are split at UV seams and hard edges, so
that each seam is a border); COPY is the decimated copy; copy.json gives the registration that
maps the copy (and RECORDS) onto the original. Offsets are measured along the original's
area-weighted vertex normal at the closest point, in mark amplitudes (0.059% of the original's
bounding-box diagonal, the default strength).

Printed: the copy's corners and how many lie on a border; their offsets from the original's
surface (RMS, percentiles of the magnitude); how much of them a curvature model explains (R^2 of
a least-squares fit on the original's curvature times the copy's squared edge length there, on
each alone); and their offsets from a prediction of the collapse's placement: each corner's
quadric summed over the RECORDS vertices nearest to it (face planes, and border planes weighted
100 times, as Blender's bmesh_decimate_collapse builds them; --area weights face planes by area),
minimized from the corner along the quadric's well-determined directions.
Needs numpy, open3d (/usr/bin/python3) and meshmark's Python module.
"""
import argparse
import json

import numpy as np
import open3d as o3d

import meshmark

STRENGTH = 0.00059  # the default strength, a fraction of the diagonal
BORDER_WEIGHT = 100.0  # BOUNDARY_PRESERVE_WEIGHT of Blender's collapse decimator


def nearest(points, queries):
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))  # the tree reads it: keep it alive
    tree = o3d.geometry.KDTreeFlann(cloud)
    return np.array([tree.search_knn_vector_3d(q, 1)[1][0] for q in queries])


def undirected_edges(F):
    E = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    S = np.sort(E, 1)
    _, inverse, counts = np.unique(S[:, 0].astype(np.int64) * (F.max() + 1) + S[:, 1], return_inverse=True,
                                   return_counts=True)
    return E, counts[inverse.ravel()] == 1  # every directed edge, and whether it is a border


def plane_quadrics(normals, offsets, weights):
    A = weights[:, None, None] * normals[:, :, None] * normals[:, None, :]
    b = (weights * offsets)[:, None] * normals
    return A, b


def vertex_quadrics(V, F, area_weighted):
    cross = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    double_area = np.linalg.norm(cross, axis=1)
    normal = cross / (double_area[:, None] + 1e-300)
    Af, bf = plane_quadrics(normal, -np.sum(normal * V[F[:, 0]], 1),
                            0.5 * double_area if area_weighted else np.ones(len(F)))
    QA = np.zeros((len(V), 3, 3))
    Qb = np.zeros((len(V), 3))
    for k in range(3):
        np.add.at(QA, F[:, k], Af)
        np.add.at(Qb, F[:, k], bf)
    E, is_border = undirected_edges(F)
    face = np.tile(np.arange(len(F)), 3)[is_border]
    E = E[is_border]
    side = np.cross(V[E[:, 1]] - V[E[:, 0]], normal[face])
    length = np.linalg.norm(side, axis=1)
    keep = length > 1e-12
    side, E = side[keep] / length[keep][:, None], E[keep]
    Ab, bb = plane_quadrics(side, -np.sum(side * V[E[:, 0]], 1), np.full(len(E), BORDER_WEIGHT))
    for k in range(2):
        np.add.at(QA, E[:, k], Ab)
        np.add.at(Qb, E[:, k], bb)
    return QA, Qb, len(E)


def minimized_from(x0, A, b):
    """The quadric x^T A x + 2 b.x + c minimized from x0 along A's well-determined directions."""
    w, U = np.linalg.eigh(A)
    g = A @ x0 + b
    step = np.zeros(3)
    for j in range(3):
        if w[j] > 1e-6 * max(w[-1], 1e-300):
            step -= U[:, j] * (U[:, j] @ g) / w[j]
    return x0 + step


def r_squared(feature, target):
    A = np.c_[feature, np.ones_like(feature)]
    coefficients, *_ = np.linalg.lstsq(A, target, rcond=None)
    residual = target - A @ coefficients
    return 1.0 - residual @ residual / np.sum((target - target.mean()) ** 2)


def describe(name, offsets):
    magnitude = np.abs(offsets)
    p50, p90, p99 = np.percentile(magnitude, [50, 90, 99])
    print(f"  {name}: RMS {np.sqrt(np.mean(offsets ** 2)):.2f}, |offset| median {p50:.2f}, 90th {p90:.2f}, 99th {p99:.2f}")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("original")
    parser.add_argument("records")
    parser.add_argument("copy")
    parser.add_argument("detection", help="meshmark detect --json of COPY against ORIGINAL")
    parser.add_argument("--area", action="store_true", help="weight the face planes by area")
    args = parser.parse_args()

    with open(args.detection, encoding="utf-8") as file:
        T = np.array(json.load(file)["registration"]["transform"])
    to_original = lambda P: P @ T[:3, :3].T + T[:3, 3]
    V, F = meshmark.read_mesh(args.original)
    R, RF = meshmark.read_mesh(args.records)
    C, CF = meshmark.read_mesh(args.copy)
    R, C = to_original(R), to_original(C)
    amplitude = STRENGTH * np.linalg.norm(V.max(0) - V.min(0))

    # The original's surface, welded, with area-weighted vertex normals.
    W, inverse = np.unique(np.round(V, 9), axis=0, return_inverse=True)
    WF = inverse.ravel()[F]
    cross = np.cross(W[WF[:, 1]] - W[WF[:, 0]], W[WF[:, 2]] - W[WF[:, 0]])
    normals = np.zeros_like(W)
    for k in range(3):
        np.add.at(normals, WF[:, k], cross)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True) + 1e-300
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(W.astype(np.float32)), o3d.core.Tensor(WF.astype(np.uint32)))

    corners = np.unique(CF)
    X = C[corners]
    closest = scene.compute_closest_points(o3d.core.Tensor(X.astype(np.float32)))["points"].numpy().astype(np.float64)
    at = nearest(W, closest)
    n = normals[at]
    from_surface = np.sum((X - closest) * n, 1) / amplitude

    E, is_border = undirected_edges(CF)
    on_border = np.zeros(len(C), bool)
    on_border[E[is_border].ravel()] = True
    print(f"{args.copy}: {len(corners)} corners, {on_border[corners].sum()} on a border")
    describe("offset from the original's surface", from_surface)

    # Curvature (uniform Laplacian along the normal over the mean squared edge) against the
    # copy's squared edge length at each corner.
    edges = np.unique(np.sort(np.concatenate([WF[:, [0, 1]], WF[:, [1, 2]], WF[:, [2, 0]]]), 1), axis=0)
    around, count, squared = np.zeros_like(W), np.zeros(len(W)), np.zeros(len(W))
    for a, b in ((0, 1), (1, 0)):
        np.add.at(around, edges[:, a], W[edges[:, b]])
        np.add.at(count, edges[:, a], 1)
        np.add.at(squared, edges[:, a], np.sum((W[edges[:, b]] - W[edges[:, a]]) ** 2, 1))
    count[count == 0] = 1
    curvature = 2 * np.sum((around / count[:, None] - W) * normals, 1) / (squared / count + 1e-300)
    copy_squared, copy_count = np.zeros(len(C)), np.zeros(len(C))
    for a, b in ((0, 1), (1, 0)):
        np.add.at(copy_squared, E[:, a], np.sum((C[E[:, b]] - C[E[:, a]]) ** 2, 1))
        np.add.at(copy_count, E[:, a], 1)
    length2 = (copy_squared / np.maximum(copy_count, 1))[corners]
    print(f"  R^2 of the offsets on curvature x the copy's squared edge {r_squared(curvature[at] * length2, from_surface):.3f}, "
          f"on curvature {r_squared(curvature[at], from_surface):.3f}, on the squared edge {r_squared(length2, from_surface):.3f}")

    # The collapse's own placement, predicted from the records' quadrics.
    QA, Qb, borders = vertex_quadrics(R, RF, args.area)
    owner = nearest(X, R)
    SA = np.zeros((len(corners), 3, 3))
    Sb = np.zeros((len(corners), 3))
    np.add.at(SA, owner, QA)
    np.add.at(Sb, owner, Qb)
    predicted = np.array([minimized_from(X[i], SA[i], Sb[i]) for i in range(len(corners))])
    print(f"  the records: {len(R)} vertices, {borders} border edges")
    describe("offset from the predicted placement", np.sum((X - predicted) * n, 1) / amplitude)


if __name__ == "__main__":
    main()
