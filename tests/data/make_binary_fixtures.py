#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Regenerates the binary fixtures of tests/data (and cube_ascii.stl, which shares their data).

Run from this folder: python3 make_binary_fixtures.py. Standard library only.
"""
import struct

# The unit cube of cube_ascii.ply: vertex 6 sits at z = 1.1 (a value float32 cannot hold
# exactly), faces are quads wound counter-clockwise seen from outside.
V = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1.1), (0, 1, 1)]
QUADS = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (2, 3, 7, 6), (0, 4, 7, 3), (1, 2, 6, 5)]
TRIANGLES = [t for q in QUADS for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]


def ply_header(fmt, extra=""):
    return ("ply\nformat %s 1.0\ncomment cube with quad faces\nelement vertex 8\n"
            "property float x\nproperty float y\nproperty float z\nelement face 6\n"
            "property list uchar int vertex_indices\nend_header\n" % fmt).encode()


def cube_ply(endian):
    body = b"".join(struct.pack(endian + "3f", *v) for v in V)
    body += b"".join(struct.pack(endian + "B4i", 4, *q) for q in QUADS)
    return body


def write(name, data):
    with open(name, "wb") as f:
        f.write(data)


write("cube_binary_le.ply", ply_header("binary_little_endian") + cube_ply("<"))
write("cube_binary_be.ply", ply_header("binary_big_endian") + cube_ply(">"))
# Cut inside the vertex data: 8 vertices need 96 bytes, 50 are left.
write("truncated_binary.ply", (ply_header("binary_little_endian") + cube_ply("<"))[:-(6 * 17 + 46)])

# Extra properties of every kind, skipped by their declared types: double positions split by
# other properties, a list inside the vertex element (records of varying size), an extra
# element with a list, and face properties before and after the index list.
header = b"""ply
format binary_little_endian 1.0
comment normals and extra properties, skipped by their declared types
element vertex 8
property double x
property uchar flags
property double y
property float nx
property float ny
property float nz
property double z
property list uchar short tags
element material 2
property list int char name
property ushort id
element face 6
property uchar flags
property list uchar uint vertex_indices
property list uchar float texcoord
property int extra
end_header
"""
body = b""
for i, (x, y, z) in enumerate(V):
    tags = list(range(i % 3))
    body += struct.pack("<dBd3fd", x, i, y, 0.0, 0.0, 1.0, z)
    body += struct.pack("<B%dh" % len(tags), len(tags), *tags)
for name, ident in ((b"stone", 7), (b"wood", 9)):
    body += struct.pack("<i", len(name)) + name + struct.pack("<H", ident)
for f, q in enumerate(QUADS):
    body += struct.pack("<BB4I", f, 4, *q)
    body += struct.pack("<B2f", 2, 0.25, 0.75) + struct.pack("<i", -f)
write("cube_normals_extra_props.ply", header + body)

# A binary header claiming 2147483647 vertices over a few bytes of data.
write("huge_count_binary.ply",
      b"ply\nformat binary_little_endian 1.0\nelement vertex 2147483647\nproperty float x\n"
      b"property float y\nproperty float z\nelement face 0\n"
      b"property list uchar int vertex_indices\nend_header\n" + struct.pack("<6f", *range(6)))


def normal(t):
    a, b, c = (V[i] for i in t)
    u = [b[k] - a[k] for k in range(3)]
    w = [c[k] - a[k] for k in range(3)]
    n = (u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0])
    length = sum(x * x for x in n) ** 0.5
    return tuple(x / length for x in n)


def stl_binary(header):
    data = header.ljust(80, b" ") + struct.pack("<I", len(TRIANGLES))
    for t in TRIANGLES:
        data += struct.pack("<3f", *normal(t))
        for i in t:
            data += struct.pack("<3f", *V[i])
        data += struct.pack("<H", 0)
    return data


write("cube_binary.stl", stl_binary(b"cube, binary STL"))
# A binary STL whose 80-byte header begins with "solid", as many exporters write.
write("cube_binary_solid_header.stl", stl_binary(b"solid cube, but this file is binary"))
# The header promises 12 facets; only 3 follow.
write("truncated_binary.stl", stl_binary(b"cube, binary STL, cut short")[:84 + 3 * 50])


def fmt(x):
    return ("%.9g" % x)


lines = ["solid cube"]
for t in TRIANGLES:
    lines.append("facet normal %s" % " ".join(fmt(x) for x in normal(t)))
    lines.append(" outer loop")
    for i in t:
        lines.append("  vertex %s" % " ".join(fmt(x) for x in V[i]))
    lines.append(" endloop")
    lines.append("endfacet")
lines.append("endsolid cube")
write("cube_ascii.stl", ("\n".join(lines) + "\n").encode())
