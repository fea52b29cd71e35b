#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""What a decimated game asset's seams keep of the mark
(bench/results/2026-11-28-strength-for-a-5pct-decimation.md).

Blender's importer keeps a glTF file's vertex records, so every UV seam and hard edge is a border
of the imported mesh, and its Decimate holds borders in place. For each border vertex of a
Blender copy (within --gate mark amplitudes of a seam), its offset from the closest point on the
original's seams is split into the part across the seam (in the tangent plane) and the part
along the normal, and each is compared with the mark's own displacement there. Prints, per
part, the mark's RMS, the error's RMS and median and their correlation, in mark amplitudes (the
mark's RMS normal displacement over the original's vertices).

    PYTHONPATH=build/python python3 bench/robustness/seam_offsets.py ORIGINAL.glb MARKED.glb \\
        SPLIT.ply COPY.ply [--key KEY.json]

ORIGINAL.glb: the unmarked asset; MARKED.glb: `meshmark embed` of it (the same vertices);
SPLIT.ply: Blender's PLY round trip of ORIGINAL (bench/blender/attacks.py `ply`), whose borders
are the seams; COPY.ply: Blender's copy of MARKED (e.g. attacks.py `decimate=0.05`). Blender's
files are in its Z-up frame and are turned back to glTF's Y-up one; with --key the copy is
instead taken through the transform `meshmark detect --json` registers (as detection sees it),
and a similarity fitted to the across errors is removed. Needs numpy.
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

import meshmark as mm


def border_edges(F):
    """Edges (sorted pairs) that one triangle uses."""
    edges = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    return unique[counts == 1]


def z_up_to_y_up(P):
    return np.stack([P[:, 0], P[:, 2], -P[:, 1]], axis=1)


def nearest_vertex(P, Q):
    """Index of the nearest row of Q for each row of P (brute force, in blocks)."""
    out = np.empty(len(P), dtype=int)
    for s in range(0, len(P), 256):
        out[s:s + 256] = ((P[s:s + 256, None, :] - Q[None, :, :]) ** 2).sum(-1).argmin(1)
    return out


def closest_on_segments(P, A, B):
    """For each row of P: the index of the closest segment A-B, its parameter and the distance."""
    AB = B - A
    L2 = (AB ** 2).sum(1)
    index = np.empty(len(P), dtype=int)
    t_best = np.empty(len(P))
    distance = np.empty(len(P))
    for s in range(0, len(P), 128):
        p = P[s:s + 128, None, :]
        t = np.clip(((p - A[None]) * AB[None]).sum(-1) / L2[None], 0.0, 1.0)
        d = ((p - (A[None] + t[..., None] * AB[None])) ** 2).sum(-1)
        j = d.argmin(1)
        rows = np.arange(len(j))
        index[s:s + 128], t_best[s:s + 128], distance[s:s + 128] = j, t[rows, j], np.sqrt(d[rows, j])
    return index, t_best, distance


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("original")
    parser.add_argument("marked")
    parser.add_argument("split")
    parser.add_argument("copy")
    parser.add_argument("--key", help="take the copy through detection's registration with this key")
    parser.add_argument("--gate", type=float, default=20.0, help="mark amplitudes (default 20)")
    parser.add_argument("--meshmark", default=os.environ.get("MESHMARK", "build/bin/meshmark"))
    args = parser.parse_args()

    V0, F0 = mm.read_mesh(args.original)
    M, FM = mm.read_mesh(args.marked)
    if V0.shape != M.shape or F0.shape != FM.shape or not (F0 == FM).all():
        sys.exit("%s: not a marked copy of %s (other vertices or triangles)" % (args.marked, args.original))
    D = M - V0
    face_normals = np.cross(V0[F0[:, 1]] - V0[F0[:, 0]], V0[F0[:, 2]] - V0[F0[:, 0]])
    normals = np.zeros_like(V0)
    for k in range(3):
        np.add.at(normals, F0[:, k], face_normals)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True) + 1e-300
    amplitude = np.sqrt(np.mean((D * normals).sum(1) ** 2))

    SV, SF = mm.read_mesh(args.split)
    seams = nearest_vertex(z_up_to_y_up(SV), V0)[border_edges(SF)]
    seams = np.unique(np.sort(seams, axis=1), axis=0)
    seams = seams[seams[:, 0] != seams[:, 1]]

    C, CF = mm.read_mesh(args.copy)
    if args.key:
        report = subprocess.run([args.meshmark, "detect", args.copy, "--original", args.original, "--key", args.key,
                                 "--json", "-q"], capture_output=True, text=True)
        T = np.array(json.loads(report.stdout)["registration"]["transform"])
        C = C @ T[:3, :3].T + T[:3, 3]
    else:
        C = z_up_to_y_up(C)
    corners = np.unique(border_edges(CF))
    P = C[corners]
    A, B = V0[seams[:, 0]], V0[seams[:, 1]]
    j, t, distance = closest_on_segments(P, A, B)
    near = distance < args.gate * amplitude
    i0, i1 = seams[j, 0], seams[j, 1]
    q = A[j] + t[:, None] * (B[j] - A[j])
    along = (B[j] - A[j]) / np.linalg.norm(B[j] - A[j], axis=1, keepdims=True)
    n = normals[i0] + normals[i1]
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    across = np.cross(along, n)
    across /= np.linalg.norm(across, axis=1, keepdims=True)
    n = np.cross(across, along)
    mark = (1.0 - t)[:, None] * D[i0] + t[:, None] * D[i1]
    offset = P - q
    print("%s: %d vertices, %d on a border, %d within %g amplitudes of one of the %d seam edges; amplitude %.4g "
          "(%.4f%% of the diagonal)" % (args.copy, len(C), len(P), near.sum(), args.gate, len(seams), amplitude,
                                        100 * amplitude / np.linalg.norm(V0.max(0) - V0.min(0))))
    for name, axis in (("across the seam", across), ("along the normal", n)):
        observed = (offset * axis).sum(1)[near]
        expected = (mark * axis).sum(1)[near]
        error = observed - expected
        if args.key and name == "across the seam":
            # Registration leaves a similarity, which detection's nuisance fit removes: fit it here too.
            x = q[near] - V0.mean(0)
            a = axis[near]
            G = np.stack([a[:, 0], a[:, 1], a[:, 2]] + [(np.cross(np.eye(3)[k], x) * a).sum(1) for k in range(3)] +
                         [(x * a).sum(1)], axis=1)
            error = error - G @ np.linalg.lstsq(G, error, rcond=None)[0]
        print("  %-16s mark RMS %.2f, error RMS %.2f (median |error| %.2f), correlation %.3f" % (
            name, np.sqrt(np.mean(expected ** 2)) / amplitude, np.sqrt(np.mean(error ** 2)) / amplitude,
            np.median(np.abs(error)) / amplitude, np.corrcoef(observed, expected)[0, 1]))


if __name__ == "__main__":
    main()
