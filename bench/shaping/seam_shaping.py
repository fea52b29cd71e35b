#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Experiment (issue 16): put more of the mark on a game asset's seams, where Blender's
Decimate keeps its vertices, at the same surface distance, to see what detection gains before
any product change (bench/results/2026-11-28-strength-for-a-5pct-decimation.md: tried in the
twentieth session, not kept).

    meshmark embed asset.glb -o marked.glb --key key.json --seed 1
    /usr/bin/python3 bench/shaping/seam_shaping.py asset.glb marked.glb shaped.glb W [RINGS [SCALE]]
    meshmark compare asset.glb shaped.glb --json      # its mrms; run again with SCALE = target / mrms

The displacement of each welded vertex (the records of the file's single primitive that share
a position, bit for bit) is scaled by W where several records share it (a UV seam or hard
edge: Blender's glTF importer splits the mesh there, and its Decimate holds those borders), by
1 elsewhere, the weights averaged over RINGS rings of neighbours (default 0), and the whole by
SCALE (default 1). Detection is meshmark's, unchanged. Reads and writes a GLB with one mesh of
one primitive with float32 positions and indices (the Suzanne asset of
bench/blender/make_game_asset.py). Needs numpy (Debian's /usr/bin/python3).
"""
import json
import struct
import sys

import numpy as np


def read_glb(path):
    data = bytearray(open(path, "rb").read())
    json_length = struct.unpack_from("<I", data, 12)[0]
    document = json.loads(bytes(data[20:20 + json_length]))
    return document, data, 20 + json_length + 8  # the BIN chunk's data


def primitive_arrays(document, data, bin_start):
    meshes = document["meshes"]
    if len(meshes) != 1 or len(meshes[0]["primitives"]) != 1:
        sys.exit("seam_shaping.py: the file must have one mesh of one primitive")
    primitive = meshes[0]["primitives"][0]
    accessor = document["accessors"][primitive["attributes"]["POSITION"]]
    if accessor["componentType"] != 5126 or document["bufferViews"][accessor["bufferView"]].get("byteStride", 12) != 12:
        sys.exit("seam_shaping.py: positions must be tightly packed float32")
    view = document["bufferViews"][accessor["bufferView"]]
    start = bin_start + view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
    positions = np.frombuffer(bytes(data[start:start + 12 * accessor["count"]]), dtype="<f4").reshape(-1, 3).copy()
    indices_accessor = document["accessors"][primitive["indices"]]
    indices_view = document["bufferViews"][indices_accessor["bufferView"]]
    index_type = {5121: "<u1", 5123: "<u2", 5125: "<u4"}[indices_accessor["componentType"]]
    index_start = bin_start + indices_view.get("byteOffset", 0) + indices_accessor.get("byteOffset", 0)
    indices = np.frombuffer(bytes(data[index_start:index_start + np.dtype(index_type).itemsize * indices_accessor["count"]]),
                            dtype=index_type).reshape(-1, 3).astype(np.int64)
    return positions, start, indices


def main(argv):
    if len(argv) < 5:
        sys.exit(__doc__.strip().split("\n\n")[1])
    original_path, marked_path, out_path = argv[1:4]
    seam_weight = float(argv[4])
    rings = int(argv[5]) if len(argv) > 5 else 0
    scale = float(argv[6]) if len(argv) > 6 else 1.0
    document, data, bin_start = read_glb(original_path)
    original, _, triangles = primitive_arrays(document, data, bin_start)
    marked_document, marked_data, marked_bin = read_glb(marked_path)
    marked, marked_start, _ = primitive_arrays(marked_document, marked_data, marked_bin)
    if marked.shape != original.shape:
        sys.exit("seam_shaping.py: the marked file must be the original's records, marked")
    ids = {}
    welded = np.array([ids.setdefault(bytes(p), len(ids)) for p in original], dtype=np.int64)
    records = np.bincount(welded, minlength=len(ids))
    weight = np.where(records >= 2, seam_weight, 1.0)
    edges = welded[np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])]
    for _ in range(rings):
        total, count = weight.copy(), np.ones(len(ids))
        np.add.at(total, edges[:, 0], weight[edges[:, 1]])
        np.add.at(count, edges[:, 0], 1)
        np.add.at(total, edges[:, 1], weight[edges[:, 0]])
        np.add.at(count, edges[:, 1], 1)
        weight = total / count
    displacement = marked.astype(np.float64) - original.astype(np.float64)
    shaped = (original.astype(np.float64) + displacement * (scale * weight[welded])[:, None]).astype("<f4")
    marked_data[marked_start:marked_start + shaped.nbytes] = shaped.tobytes()
    open(out_path, "wb").write(marked_data)
    print(f"{len(ids)} welded vertices, {int((records >= 2).sum())} on seams; mean weight {weight.mean():.3f}, "
          f"on seams {weight[records >= 2].mean():.3f}")


if __name__ == "__main__":
    main(sys.argv)
