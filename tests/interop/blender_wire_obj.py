# SPDX-License-Identifier: MIT
# Blender writes an OBJ with loose edges and a loose point (the interop suite's wire case):
# a UV sphere (64 x 32) with a 20-vertex cable of loose edges and one loose vertex, exported by
# Blender's OBJ writer (`l` lines for the loose edges).
#   blender -b --factory-startup --python blender_wire_obj.py -- OUT.obj
import sys

import bmesh
import bpy

out = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32)
obj = bpy.context.active_object
bm = bmesh.new()
bm.from_mesh(obj.data)
previous = None
for k in range(20):
    vertex = bm.verts.new((1.2 + 0.05 * k, 0.0, -0.1 * k))
    if previous is not None:
        bm.edges.new((previous, vertex))
    previous = vertex
bm.verts.new((0.0, 0.0, 2.0))
bm.to_mesh(obj.data)
bm.free()
if hasattr(bpy.ops.wm, "obj_export"):
    bpy.ops.wm.obj_export(filepath=out, export_materials=False)
else:
    bpy.ops.export_scene.obj(filepath=out, use_edges=True, use_materials=False)
