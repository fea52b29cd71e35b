# SPDX-License-Identifier: MIT
# Blender's voxel remesh of one mesh, for the interop suite (blender_interop_test.cpp):
#   blender -b --factory-startup --python blender_voxel_remesh.py -- IN.ply OUT.ply N
# The Remesh modifier in Voxel mode (adaptivity 0) with Voxel Size = bbox diagonal / N, applied,
# and the result written as PLY (quads kept). Prints "voxel_size=<h>".
import sys

import bpy
import mathutils

source, target, resolution = sys.argv[sys.argv.index("--") + 1:]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_mesh.ply(filepath=source)
obj = bpy.context.selected_objects[0]
bpy.context.view_layer.objects.active = obj
points = [v.co for v in obj.data.vertices]
lo = mathutils.Vector([min(p[i] for p in points) for i in range(3)])
hi = mathutils.Vector([max(p[i] for p in points) for i in range(3)])
remesh = obj.modifiers.new("voxel", "REMESH")
remesh.mode = "VOXEL"
remesh.voxel_size = (hi - lo).length / float(resolution)
remesh.adaptivity = 0.0
print("voxel_size=%r" % remesh.voxel_size)
bpy.ops.object.modifier_apply(modifier=remesh.name)
bpy.ops.export_mesh.ply(filepath=target, use_ascii=False, use_normals=False,
                        use_uv_coords=False, use_colors=False)
