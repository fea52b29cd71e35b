# SPDX-License-Identifier: MIT
# Open3D's mesh operations as re-work of one mesh, the companion of attacks.py (same contract) for
# the robustness bench (bench/results/2026-11-24-everyday-blender-rework.md).
# Debian's python3-open3d:
#
#   /usr/bin/python3 bench/blender/open3d_attacks.py INPUT OUT_DIR [--seed S] OP [OP ...]
#
# Each OP reads INPUT afresh (open3d.io.read_triangle_mesh), applies one operation and writes
# OUT_DIR/<label>.ply (binary, positions and faces only; <label> is the OP with '=' replaced by
# '_'), under a temporary name renamed into place; OUT_DIR/attacks.json lists what was written.
# Any error exits 2 with one line on stderr.
#
# Operations:
#   o3d-decimate=R   simplify_quadric_decimation to R x the face count
#   o3d-laplacian=N  filter_smooth_laplacian, N iterations (lambda 0.5, Open3D's default)
#   o3d-taubin=N     filter_smooth_taubin, N iterations (lambda 0.5, mu -0.53, Open3D's defaults)
# The two smoothings drop unreferenced vertices first (Open3D would make them NaN).
import math
import os
import sys
import time

import numpy
import open3d


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from attack_contract import UsageError, parse_arguments, write_report  # noqa: E402


def parse_op(text):
    name, _, value = text.partition("=")
    if name not in ("o3d-decimate", "o3d-laplacian", "o3d-taubin"):
        raise UsageError("unknown operation '%s'" % name)
    try:
        number = float(value)
    except ValueError:
        raise UsageError("operation '%s' needs a number (%s=...)" % (name, name)) from None
    if not math.isfinite(number) or number <= 0 or (name == "o3d-decimate" and number > 1):
        raise UsageError("operation '%s': value out of range" % name)
    return name, number


def apply_op(mesh, name, value):
    if name == "o3d-decimate":
        return mesh.simplify_quadric_decimation(
            target_number_of_triangles=max(1, int(round(value * len(mesh.triangles)))))
    if name == "o3d-laplacian":
        return mesh.filter_smooth_laplacian(number_of_iterations=int(value))
    return mesh.filter_smooth_taubin(number_of_iterations=int(value))


def main(args):
    # --seed is accepted for the common contract; these operations use no randomness.
    source, out_dir, specs, _ = parse_arguments(args, "open3d_attacks.py INPUT OUT_DIR [--seed S] OP [OP ...]")
    ops = [(spec, *parse_op(spec)) for spec in specs]
    report = []
    for spec, name, value in ops:
        start = time.time()
        mesh = open3d.io.read_triangle_mesh(source)
        if len(mesh.vertices) == 0 or len(mesh.triangles) == 0:
            raise UsageError("%s: Open3D read no triangles" % source)
        if name != "o3d-decimate":
            # Open3D's smoothing divides by the neighbour count: an unreferenced vertex turns NaN.
            mesh.remove_unreferenced_vertices()
        result = apply_op(mesh, name, value)
        if not numpy.isfinite(numpy.asarray(result.vertices)).all():
            raise UsageError("%s: Open3D's %s gave non-finite coordinates" % (source, spec))
        label = spec.replace("=", "_")
        target = os.path.join(out_dir, label + ".ply")
        temporary = os.path.join(out_dir, ".tmp-" + label + ".ply")
        if not open3d.io.write_triangle_mesh(temporary, result, write_ascii=False, write_vertex_normals=False,
                                             write_vertex_colors=False, write_triangle_uvs=False):
            raise UsageError("%s: Open3D could not write it" % temporary)
        os.replace(temporary, target)
        report.append({"label": label, "op": spec, "output": target, "vertices": len(result.vertices),
                       "faces": len(result.triangles), "seconds": round(time.time() - start, 3)})
    write_report(out_dir, report)

if __name__ == "__main__":
    try:
        main(sys.argv[1:])
    except UsageError as e:
        print("open3d_attacks.py: %s" % e, file=sys.stderr)
        sys.exit(2)
    except Exception as e:
        print("open3d_attacks.py: %s: %s" % (type(e).__name__, e), file=sys.stderr)
        sys.exit(2)
