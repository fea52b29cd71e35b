# SPDX-License-Identifier: MIT
"""meshmark for Blender: watermark the active mesh and look for a mark, from the 3D view's sidebar.

Operators bpy.ops.meshmark.embed and bpy.ops.meshmark.detect, a panel in the sidebar (N, tab
"meshmark"). They call the Python package meshmark (docs/blender.md), found by
package.import_meshmark.
"""

bl_info = {
    "name": "meshmark",
    "author": "meshmark contributors",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > meshmark",
    "description": "Robust invisible watermarks for meshes: embed a mark, detect it in a copy",
    "category": "Mesh",
}

if "bpy" in locals():
    import importlib

    importlib.reload(package)  # noqa: F821 (re-enabling the add-on reloads its modules)
    importlib.reload(operators)  # noqa: F821
    importlib.reload(panel)  # noqa: F821

import bpy

from . import operators, package, panel


class MeshmarkPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    package_path: bpy.props.StringProperty(
        name="Python package folder",
        description="Folder that holds the meshmark package (e.g. <prefix>/lib/python3/dist-packages); "
        "empty: the installed one, or $MESHMARK_PYTHONPATH",
        subtype="DIR_PATH",
    )

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "package_path")
        layout.label(text=package.status())


classes = (MeshmarkPreferences, operators.MESHMARK_OT_embed, operators.MESHMARK_OT_detect,
           panel.MeshmarkSettings, panel.VIEW3D_PT_meshmark)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.meshmark = bpy.props.PointerProperty(type=panel.MeshmarkSettings)


def unregister():
    del bpy.types.Scene.meshmark
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
