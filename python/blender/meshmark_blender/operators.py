# SPDX-License-Identifier: MIT
"""bpy.ops.meshmark.embed and bpy.ops.meshmark.detect on the active mesh object."""
import json
import os

import bpy
import numpy as np

from .package import import_meshmark


def world_mesh(obj):
    """(V, F) of the object's mesh: world-space float64 positions and its triangles (int32)."""
    mesh = obj.data
    V = np.empty(3 * len(mesh.vertices), dtype=np.float64)
    mesh.vertices.foreach_get("co", V)
    V = V.reshape(-1, 3)
    matrix = np.array(obj.matrix_world, dtype=np.float64)
    V = V @ matrix[:3, :3].T + matrix[:3, 3]
    mesh.calc_loop_triangles()
    F = np.empty(3 * len(mesh.loop_triangles), dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", F)
    F = F.reshape(-1, 3)
    return V, (F if len(F) else None)


def set_world_positions(obj, V):
    """Moves the object's vertices to world-space positions V (its transform is kept)."""
    matrix = np.array(obj.matrix_world, dtype=np.float64)
    local = (V - matrix[:3, 3]) @ np.linalg.inv(matrix[:3, :3]).T
    obj.data.vertices.foreach_set("co", local.astype(np.float32).ravel())
    obj.data.update()


def active_mesh(operator, context):
    obj = context.active_object
    if obj is None or obj.type != "MESH":
        operator.report({"ERROR"}, "meshmark: select a mesh object first.")
        return None
    if obj.data.shape_keys is not None:
        operator.report({"ERROR"}, f"meshmark: {obj.name} has shape keys; apply or remove them first.")
        return None
    if obj.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    return obj


def load_meshmark(operator):
    try:
        return import_meshmark()
    except ImportError as error:
        operator.report({"ERROR"}, f"meshmark: {error}")
        return None


class MESHMARK_OT_embed(bpy.types.Operator):
    """Watermark the active mesh in place (world-space positions); write its key and unmarked original"""

    bl_idname = "meshmark.embed"
    bl_label = "Embed watermark"
    bl_options = {"REGISTER", "UNDO"}

    key_path: bpy.props.StringProperty(name="Key file", subtype="FILE_PATH",
                                       description="Key file to write (JSON); keep it secret")
    original_path: bpy.props.StringProperty(
        name="Original file", subtype="FILE_PATH",
        description="Where to write the unmarked mesh (PLY), which detection needs; empty: "
        "<key file without .json>.original.ply")
    message: bpy.props.StringProperty(name="Message", description="Payload text (empty: random bits)")
    seed: bpy.props.IntProperty(name="Seed", default=-1, min=-1,
                                description="Secret seed; -1 draws one at random")
    strength: bpy.props.FloatProperty(name="Strength", default=0.0, min=0.0, precision=5, step=0.01,
                                       description="RMS displacement / bounding-box diagonal; 0 = default (0.001)")
    overwrite_key: bpy.props.BoolProperty(name="Overwrite key", default=False,
                                          description="Replace an existing key (and original) file")

    def execute(self, context):
        meshmark = load_meshmark(self)
        obj = active_mesh(self, context)
        if meshmark is None or obj is None:
            return {"CANCELLED"}
        if not self.key_path:
            self.report({"ERROR"}, "meshmark: choose a key file to write.")
            return {"CANCELLED"}
        key_path = bpy.path.abspath(self.key_path)
        original_path = bpy.path.abspath(self.original_path) if self.original_path else \
            (key_path[:-5] if key_path.endswith(".json") else key_path) + ".original.ply"
        for path in (key_path, original_path):
            if os.path.exists(path) and not self.overwrite_key:
                self.report({"ERROR"}, f"meshmark: {path} already exists; it may be the only proof for copies "
                            "marked earlier. Choose another file or tick 'Overwrite key'.")
                return {"CANCELLED"}
        V, F = world_mesh(obj)
        try:
            key, marked, report = meshmark.embed(
                V, F, message=self.message or None, seed=None if self.seed < 0 else self.seed,
                strength=self.strength or None, report=True)
            # The original first, then the key: both files exist before the mesh changes.
            meshmark.write_mesh(original_path, V, F)
            key.save(key_path, force=self.overwrite_key)
        except meshmark.Error as error:
            self.report({"ERROR"}, f"meshmark: {error}")
            return {"CANCELLED"}
        set_world_positions(obj, marked)
        context.scene["meshmark_report"] = json.dumps(report)
        self.report({"INFO"}, f"meshmark: embedded {len(key.payload)} bits into {obj.name}; surface distance RMS "
                    f"{100 * report['surface_rms_displacement']:.3g}% (vertex displacement RMS "
                    f"{100 * report['rms_displacement']:.3g}%, max {100 * report['max_displacement']:.3g}%) of the "
                    f"bounding-box diagonal; key {key_path}, original {original_path}")
        return {"FINISHED"}


class MESHMARK_OT_detect(bpy.types.Operator):
    """Look for a key's watermark in the active mesh (world-space), against the original file"""

    bl_idname = "meshmark.detect"
    bl_label = "Detect watermark"
    bl_options = {"REGISTER"}

    original_path: bpy.props.StringProperty(name="Original file", subtype="FILE_PATH",
                                            description="The unmarked original the key was made for")
    key_path: bpy.props.StringProperty(name="Key file", subtype="FILE_PATH")

    def execute(self, context):
        meshmark = load_meshmark(self)
        obj = active_mesh(self, context)
        if meshmark is None or obj is None:
            return {"CANCELLED"}
        if not self.original_path or not self.key_path:
            self.report({"ERROR"}, "meshmark: choose the original file and the key file.")
            return {"CANCELLED"}
        V, F = world_mesh(obj)
        try:
            # The original as a file, as `meshmark detect` reads it: its other instances and its
            # animation (a character posed at one of its frames) are used too.
            result = meshmark.detect_against_file(V, F, bpy.path.abspath(self.original_path),
                                                  bpy.path.abspath(self.key_path))
        except meshmark.Error as error:
            self.report({"ERROR"}, f"meshmark: {error}")
            return {"CANCELLED"}
        report = result.to_dict()
        report["far_copy"] = bool(result.is_far_copy)
        context.scene["meshmark_report"] = json.dumps(report)
        verdict = "FOUND" if result.detected else "not found"
        why = ""
        if not result.detected and result.is_far_copy:
            # As `meshmark detect` notes it (DetectReport::is_far_copy, docs/robustness.md).
            why = (f"; the mesh lies {result.registration_rms / result.mark_strength:.1f} times the mark's "
                   "strength from the original, and copies that far often keep too little of the mark")
        self.report({"INFO"}, f"meshmark: watermark {verdict} in {obj.name}: z = {result.score:.2f}, "
                    f"false-positive probability {result.false_positive_probability:.3g}{why}")
        return {"FINISHED"}
