# SPDX-License-Identifier: MIT
"""Inside headless Blender: the meshmark add-on, installed from its zip, marks an imported mesh
(moved and scaled: world-space positions), refuses to replace its key, detects the mark, and the
meshmark program detects the mark in Blender's PLY export. Run by run_blender_test.py."""
import json
import os
import subprocess
import sys

import bpy
import numpy as np

addon_zip, work = sys.argv[sys.argv.index("--") + 1:][:2]


def check(condition, message):
    if not condition:
        raise AssertionError(message)


def import_ply(path, name):
    bpy.ops.object.select_all(action="DESELECT")
    bpy.ops.import_mesh.ply(filepath=path)
    obj = bpy.context.selected_objects[0]
    obj.name = name
    bpy.context.view_layer.objects.active = obj
    return obj


# Install and enable the add-on as a user would (Preferences > Add-ons > Install...).
bpy.ops.preferences.addon_install(filepath=addon_zip)
bpy.ops.preferences.addon_enable(module="meshmark_blender")
check(hasattr(bpy.ops.meshmark, "embed") and hasattr(bpy.ops.meshmark, "detect"), "operators missing")
from meshmark_blender.package import import_meshmark  # noqa: E402

meshmark = import_meshmark()

# A test mesh written by the package, imported through Blender's own PLY importer.
u = np.linspace(0, 2 * np.pi, 40, endpoint=False)
v = np.linspace(0, 2 * np.pi, 20, endpoint=False)
uu, vv = np.meshgrid(u, v, indexing="ij")
r = 0.35 + 0.05 * np.sin(3 * uu) * np.cos(2 * vv)
V = np.stack([(1.3 * (1 + r * np.cos(vv)) * np.cos(uu)).ravel(), (0.8 * (1 + r * np.cos(vv)) * np.sin(uu)).ravel(),
              (r * np.sin(vv) + 0.15 * np.sin(2 * uu + 0.5)).ravel()], axis=1)
i, j = np.meshgrid(np.arange(40), np.arange(20), indexing="ij")
a, b = (i * 20 + j).ravel(), (((i + 1) % 40) * 20 + j).ravel()
c, d = (((i + 1) % 40) * 20 + (j + 1) % 20).ravel(), (i * 20 + (j + 1) % 20).ravel()
F = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
source = os.path.join(work, "torus.ply")
meshmark.write_mesh(source, V, F, binary=False)

obj = import_ply(source, "torus")
obj.location = (0.5, -2.0, 1.0)
obj.rotation_euler = (0.3, 0.1, 0.7)
obj.scale = (2.0, 2.0, 2.0)
bpy.context.view_layer.update()
before = np.array([obj.matrix_world @ vert.co for vert in obj.data.vertices])

key_path = os.path.join(work, "blender.key.json")
original_path = os.path.join(work, "blender.original.ply")
result = bpy.ops.meshmark.embed(key_path=key_path, original_path=original_path, message="blender", seed=42)
check(result == {"FINISHED"}, f"embed: {result}")
check(os.path.exists(key_path) and os.path.exists(original_path), "key or original not written")
after = np.array([obj.matrix_world @ vert.co for vert in obj.data.vertices])
moved = np.linalg.norm(after - before, axis=1)
diagonal = np.linalg.norm(before.max(0) - before.min(0))
check(0 < moved.max() < 0.02 * diagonal, f"displacement {moved.max()} of a diagonal {diagonal}")
check(tuple(obj.scale) == (2.0, 2.0, 2.0), "the object's transform changed")
report = json.loads(bpy.context.scene["meshmark_report"])
check(report["rms_displacement"] > 0, "no distortion reported")
check(abs(report["surface_rms_displacement"] - 5.9e-4) < 1e-9, "the default strength is not the surface distance")
key = meshmark.Key.load(key_path)
check(key.seed == 42 and key.message == "blender", "key content")

# The key is not replaced unless asked.
stamp = os.path.getmtime(key_path)
try:
    bpy.ops.meshmark.embed(key_path=key_path, original_path=original_path, seed=43)
    check(False, "an existing key was replaced")
except RuntimeError as error:  # an operator's ERROR report, raised when called from a script
    check("already exists" in str(error), f"wrong refusal: {error}")
check(os.path.getmtime(key_path) == stamp and meshmark.Key.load(key_path).seed == 42, "key changed")

# Detect inside Blender.
result = bpy.ops.meshmark.detect(original_path=original_path, key_path=key_path)
check(result == {"FINISHED"}, f"detect: {result}")
found = json.loads(bpy.context.scene["meshmark_report"])
check(found["detected"] is True, f"not detected in Blender: {found}")
check(found["far_copy"] is False, f"the marked object itself reported as a far copy: {found}")

# Export with Blender's PLY exporter (float32, its own vertex order); the program detects it.
export = os.path.join(work, "export.ply")
bpy.ops.object.select_all(action="DESELECT")
obj.select_set(True)
bpy.ops.export_mesh.ply(filepath=export, use_selection=True, use_normals=False, use_uv_coords=False,
                        use_colors=False)
cli = os.environ.get("MESHMARK_CLI")
if cli:
    done = subprocess.run([cli, "detect", export, "--original", original_path, "--key", key_path, "--json"],
                          capture_output=True, text=True)
    check(done.returncode == 0, f"meshmark detect on Blender's export: exit {done.returncode} {done.stdout} {done.stderr}")
    check(json.loads(done.stdout)["detected"] is True, "the program did not detect the export")
# And what the package reads back from the export is detected in Python as well.
V_e, F_e = meshmark.read_mesh(export)
V_o, F_o = meshmark.read_mesh(original_path)
check(meshmark.detect(V_e, F_e, V_o, F_o, key).detected, "the export is not detected in Python")

# An unmarked copy of the same mesh, placed the same way, is not claimed.
clean = import_ply(source, "clean")
clean.location, clean.rotation_euler, clean.scale = obj.location, obj.rotation_euler, obj.scale
bpy.context.view_layer.update()
result = bpy.ops.meshmark.detect(original_path=original_path, key_path=key_path)
check(result == {"FINISHED"}, f"detect on the clean copy: {result}")
check(json.loads(bpy.context.scene["meshmark_report"])["detected"] is False, "an unmarked copy was claimed")
print("blender_addon_test: OK")
