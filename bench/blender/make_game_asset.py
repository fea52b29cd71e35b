# SPDX-License-Identifier: MIT
# A game-like asset made in Blender, for the robustness bench (docs/robustness.md, "A game-like
# asset made in Blender"): no game asset is among the shared meshes, and this one has what
# makes them hard: separate parts (Suzanne's head and two eyes, a bevelled box, a cylinder),
# hard edges split (Edge Split at 30 degrees) and UV seams (Smart UV Project), written as .glb,
# where both split the vertices. Runs inside Blender, headless:
#
#   blender -b --factory-startup --python bench/blender/make_game_asset.py -- OUT.glb
#
# Blender 3.4 (Debian): 8,150 distinct positions (meshmark's reader welds the glTF's split
# vertices back; Blender's own writers keep 10,235), 16,120 triangles, 5 parts.
import math
import sys

import numpy

numpy.bool = bool  # Debian's Blender 3.4 glTF add-on still uses the alias NumPy removed
import bpy  # noqa: E402


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(argv) != 1 or not argv[0].lower().endswith(".glb"):
        sys.stderr.write("make_game_asset.py: usage: blender -b --python make_game_asset.py -- OUT.glb\n")
        sys.exit(2)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_monkey_add(size=2.0)
    head = bpy.context.active_object
    subdivision = head.modifiers.new("subdivision", "SUBSURF")
    subdivision.levels = 2
    subdivision.render_levels = 2
    bpy.ops.object.modifier_apply(modifier="subdivision")
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0.1, 1.25))
    hat = bpy.context.active_object
    hat.scale = (1.2, 1.0, 0.35)
    bevel = hat.modifiers.new("bevel", "BEVEL")
    bevel.width = 0.05
    bevel.segments = 3
    bpy.ops.object.modifier_apply(modifier="bevel")
    bpy.ops.mesh.primitive_cylinder_add(vertices=48, radius=0.35, depth=1.2, location=(0, 0.2, -1.4))
    bpy.ops.object.select_all(action="SELECT")
    bpy.context.view_layer.objects.active = head
    bpy.ops.object.join()
    asset = bpy.context.active_object
    bpy.ops.object.transform_apply(location=True, rotation=True, scale=True)
    split = asset.modifiers.new("split", "EDGE_SPLIT")
    split.split_angle = math.radians(30)
    bpy.ops.object.modifier_apply(modifier="split")
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.uv.smart_project(angle_limit=math.radians(66))
    bpy.ops.object.mode_set(mode="OBJECT")
    bpy.ops.object.shade_smooth()
    bpy.ops.export_scene.gltf(filepath=argv[0], export_format="GLB", use_selection=False)
    print("make_game_asset.py: %s: %d vertices, %d faces in Blender" %
          (argv[0], len(asset.data.vertices), len(asset.data.polygons)))


main()
