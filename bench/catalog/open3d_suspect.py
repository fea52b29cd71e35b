#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""A suspect made by Open3D (Debian's python3-open3d): SRC decimated by quadric error to half its
triangles ("decimate") or Taubin-smoothed 10 times ("smooth"), then rotated, moved and scaled,
written as OUT. For scanning suspects no meshmark code has touched (issue 53).

  /usr/bin/python3 bench/catalog/open3d_suspect.py SRC.ply OUT.ply decimate|smooth
"""
import sys, numpy as np, open3d as o3d
src, out, mode = sys.argv[1], sys.argv[2], sys.argv[3]
m = o3d.io.read_triangle_mesh(src)
n = len(m.triangles)
if mode == "decimate":
    m = m.simplify_quadric_decimation(max(100, n // 2))
elif mode == "smooth":
    m = m.filter_smooth_taubin(number_of_iterations=10)
R = m.get_rotation_matrix_from_xyz((0.3, -0.5, 0.9))
m.rotate(R, center=(0, 0, 0)); m.translate((0.7, -0.2, 1.5)); m.scale(1.3, center=(0, 0, 0))
m.compute_vertex_normals()
o3d.io.write_triangle_mesh(out, m)
