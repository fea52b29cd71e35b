# SPDX-License-Identifier: MIT
"""The sidebar panel (3D view, N, tab "meshmark") and the scene settings it edits."""
import json

import bpy


class MeshmarkSettings(bpy.types.PropertyGroup):
    key_path: bpy.props.StringProperty(name="Key", subtype="FILE_PATH", default="//meshmark.key.json")
    original_path: bpy.props.StringProperty(name="Original", subtype="FILE_PATH",
                                            default="//meshmark.key.original.ply")
    message: bpy.props.StringProperty(name="Message")
    seed: bpy.props.IntProperty(name="Seed", default=-1, min=-1, description="-1: random")
    strength: bpy.props.FloatProperty(name="Strength", default=0.0, min=0.0, precision=5, step=0.01,
                                      description="0 = default (0.001 of the diagonal, RMS)")
    overwrite_key: bpy.props.BoolProperty(name="Overwrite key", default=False)


class VIEW3D_PT_meshmark(bpy.types.Panel):
    bl_label = "meshmark"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "meshmark"

    def draw(self, context):
        settings = context.scene.meshmark
        layout = self.layout
        layout.prop(settings, "key_path")
        layout.prop(settings, "original_path")
        box = layout.box()
        box.label(text="Embed")
        box.prop(settings, "message")
        box.prop(settings, "seed")
        box.prop(settings, "strength")
        box.prop(settings, "overwrite_key")
        op = box.operator("meshmark.embed", icon="MOD_NOISE")
        op.key_path = settings.key_path
        op.original_path = settings.original_path
        op.message = settings.message
        op.seed = settings.seed
        op.strength = settings.strength
        op.overwrite_key = settings.overwrite_key
        box = layout.box()
        box.label(text="Detect")
        op = box.operator("meshmark.detect", icon="VIEWZOOM")
        op.key_path = settings.key_path
        op.original_path = settings.original_path
        text = context.scene.get("meshmark_report")
        if text:
            try:
                report = json.loads(text)
            except ValueError:
                return
            if "detected" in report:
                box.label(text=("FOUND" if report["detected"] else "not found") +
                          f": z = {report['score']:.2f}, p <= {report['false_positive_probability']:.2g}")
                if not report["detected"] and report.get("far_copy"):
                    box.label(text="far from the original: too little of the mark may be left")
            elif "rms_displacement" in report:
                box.label(text=f"Last embed: RMS {100 * report['rms_displacement']:.3g}% of the diagonal")
