# SPDX-License-Identifier: MIT
# Everyday Blender re-work of one mesh, for the robustness bench
# (bench/results/2026-11-24-everyday-blender-rework.md). Runs inside Blender, headless:
#
#   blender -b --factory-startup --python-exit-code 2 --python bench/blender/attacks.py -- \
#       INPUT OUT_DIR [--seed S] OP [OP ...]
#
# INPUT is read with Blender's own importer (.ply, .obj, .gltf/.glb, .stl). Each OP starts again
# from a fresh import of INPUT, applies one operation and writes OUT_DIR/<label>.<ext>: binary PLY
# (Blender's PLY writer, no normals, UVs or colours, so shared vertices stay shared), except for
# the round trips, which write through the writer under test with its default options. <label> is
# the OP with '=' replaced by '_'. OUT_DIR/attacks.json lists what was written (label, op,
# output, vertices, faces, seconds). Every file is written under a temporary name and renamed, so
# a failed run leaves no partial output; any error exits 2 with one line on stderr.
#
# Operations (fractions are of the bounding-box diagonal):
#   ply, obj, gltf   round trip: import, write through Blender's PLY / OBJ / glTF (.glb) writer
#   transform        move by (0.1, -0.2, 0.3), rotate by (20, 30, 40) degrees XYZ, scale by 1.5
#   mirror           mirror in x about the bbox centre, the faces reversed so they face out (what
#                    Object > Mirror > X and Apply Scale leave)
#                    transform and mirror take a rigged (or parented) mesh as shown: its modifiers
#                    applied first, off its parent, as moving or mirroring the whole rig does
#   merge[=F]        Merge by Distance, distance F (default 1e-4)
#   noise[=F]        Randomize Vertices (transform.vertex_random), offset F (default 0.002), --seed
#   subdivide[=L]    Subdivision Surface modifier (Catmull-Clark), L levels (default 1)
#   laplacian[=N]    Laplacian Smooth modifier, N repeats (default 1), other settings default
#   smooth[=N]       Smooth modifier, factor 0.5, N repeats (default 10)
#   decimate=R       Decimate modifier, collapse, ratio R
#   merged-decimate=R  Merge by Distance (1e-4) first, then decimate=R: an imported asset split
#                    at its UV seams and hard edges decimated as one surface
#   bisect           bmesh.ops.bisect_plane through the bbox centre, normal along the largest
#                    extent, the negative side cleared (about half the surface kept)
#   bisect-A+, bisect-A-  the same through the plane across axis A (x, y or z), keeping the
#                    positive (+) or negative (-) side: every half of a symmetric model
#   voxel=N          Remesh modifier, voxel mode, adaptivity 0, voxel size = diagonal / N
#   pose=F           the scene at animation frame F, every mesh as its modifiers (an armature)
#                    leave it: a rigged character re-posed by its own animation
#   second-action=F  pose=F after switching every animated object to the file's second glTF
#                    animation (Blender imports each as an action; the first plays, the others
#                    wait muted in NLA tracks a user may switch to)
import math
import os
import sys
import time
import traceback

import bmesh
import bpy
import mathutils

try:  # Debian's glTF importer uses numpy.bool, removed from numpy 1.24.
    import numpy

    if not hasattr(numpy, "bool"):
        numpy.bool = bool
except ImportError:
    pass


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from attack_contract import UsageError, parse_arguments, write_report  # noqa: E402

DEFAULTS = {"merge": 1e-4, "noise": 0.002, "subdivide": 1, "laplacian": 1, "smooth": 10}
NEEDS_VALUE = {"decimate", "merged-decimate", "voxel", "pose", "second-action"}
HALVES = {"bisect-%s%s" % (axis, side) for axis in "xyz" for side in "+-"}
NO_VALUE = {"ply", "obj", "gltf", "transform", "mirror", "bisect"} | HALVES
ROUND_TRIP_EXT = {"ply": ".ply", "obj": ".obj", "gltf": ".glb"}


def parse_op(text):
    name, _, value = text.partition("=")
    if name in NO_VALUE:
        if value:
            raise UsageError("operation '%s' takes no value" % name)
        return name, None
    if name not in DEFAULTS and name not in NEEDS_VALUE:
        raise UsageError("unknown operation '%s'" % name)
    if not value:
        if name in NEEDS_VALUE:
            raise UsageError("operation '%s' needs a value (%s=...)" % (name, name))
        return name, DEFAULTS[name]
    try:
        number = float(value)
    except ValueError:
        raise UsageError("operation '%s': '%s' is not a number" % (name, value)) from None
    if not math.isfinite(number) or number <= 0:
        raise UsageError("operation '%s': the value must be positive" % name)
    if name in ("decimate", "merged-decimate") and number > 1:
        raise UsageError("operation '%s': the ratio must be in (0, 1]" % name)
    return name, number


def import_mesh(path, frame=None, action=0):
    """Fresh scene, INPUT imported with Blender's importer; returns the single mesh object. With
    \p frame, the scene is set to that animation frame and every mesh object is converted to
    the mesh its modifiers give there (an armature's pose) before the join; \p action: which of
    the file's animations plays (0: the first, as imported)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    ext = os.path.splitext(path)[1].lower()
    if ext == ".ply":
        bpy.ops.import_mesh.ply(filepath=path)
    elif ext == ".obj":
        # No axis conversion, so the output stays in the input's coordinates.
        bpy.ops.wm.obj_import(filepath=path, forward_axis="Y", up_axis="Z")
    elif ext in (".gltf", ".glb"):
        bpy.ops.import_scene.gltf(filepath=path)
    elif ext == ".stl":
        bpy.ops.import_mesh.stl(filepath=path)
    else:
        raise UsageError("%s: Blender cannot read '%s' files (use .ply .obj .gltf .glb .stl)" % (path, ext))
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    if not meshes:
        raise UsageError("%s: no mesh was imported" % path)
    bpy.ops.object.select_all(action="DESELECT")
    for o in meshes:
        o.select_set(True)
    bpy.context.view_layer.objects.active = meshes[0]
    if action > 0:
        # The importer keeps each animation in an NLA track of every object it animates, the
        # file's first on top (created last): the file's animation K is track count - 1 - K.
        switched = 0
        for o in bpy.context.scene.objects:
            tracks = o.animation_data.nla_tracks if o.animation_data else []
            if len(tracks) > action:
                o.animation_data.action = tracks[len(tracks) - 1 - action].strips[0].action
                switched += 1
        if switched == 0:
            raise UsageError("%s: no object has an animation %d" % (path, action + 1))
    if frame is not None:
        bpy.context.scene.frame_set(frame)
        bpy.ops.object.convert(target="MESH")  # applies the modifiers as they stand at the frame
        meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
        bpy.ops.object.select_all(action="DESELECT")
        for o in meshes:
            o.select_set(True)
        bpy.context.view_layer.objects.active = meshes[0]
        bpy.ops.object.parent_clear(type="CLEAR_KEEP_TRANSFORM")  # off the armature, posed as seen
    if len(meshes) > 1:
        bpy.ops.object.join()
    obj = bpy.context.view_layer.objects.active
    # Bake the object's transform (the glTF importer's Y-up rotation) into the mesh.
    bpy.ops.object.transform_apply(location=True, rotation=True, scale=True)
    if len(obj.data.vertices) == 0:
        raise UsageError("%s: the mesh has no vertices" % path)
    return obj


def bbox(obj):
    points = [v.co for v in obj.data.vertices]
    lo = mathutils.Vector([min(p[i] for p in points) for i in range(3)])
    hi = mathutils.Vector([max(p[i] for p in points) for i in range(3)])
    return lo, hi


def apply_modifier(obj, kind, **settings):
    modifier = obj.modifiers.new(kind.lower(), kind)
    for key, value in settings.items():
        setattr(modifier, key, value)
    bpy.ops.object.modifier_apply(modifier=modifier.name)


def with_bmesh(obj, change):
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    change(bm)
    bm.to_mesh(obj.data)
    bm.free()
    obj.data.update()


def bake_shown(obj):
    """The mesh of obj as its modifiers leave it at the current frame, off its parent, with its
    transform applied; returns the converted object."""
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.convert(target="MESH")
    bpy.ops.object.parent_clear(type="CLEAR_KEEP_TRANSFORM")
    bpy.ops.object.transform_apply(location=True, rotation=True, scale=True)
    return bpy.context.view_layer.objects.active


def apply_op(obj, name, value, seed):
    lo, hi = bbox(obj)
    diagonal = (hi - lo).length
    centre = (lo + hi) / 2
    if name in ROUND_TRIP_EXT or name in ("pose", "second-action"):  # pose: done by import_mesh
        return obj
    if obj.data.shape_keys:  # morph targets: edit the shape shown (Blender applies no modifier to
        mix = obj.shape_key_add(name="mix", from_mix=True)  # a mesh with shape keys)
        shown = [point.co.copy() for point in mix.data]
        obj.shape_key_clear()
        for vertex, point in zip(obj.data.vertices, shown):
            vertex.co = point
        obj.data.update()
    if name in ("transform", "mirror") and (obj.modifiers or obj.parent is not None):
        # A rigged mesh: its armature deforms the data it is given, so data moved or mirrored
        # under bones that were not is no similarity of any pose. Move or mirror what is shown
        # instead, as a user does who moves or mirrors the object with its rig: the mesh as its
        # modifiers leave it, off the armature.
        obj = bake_shown(obj)
        lo, hi = bbox(obj)
        diagonal = (hi - lo).length
        centre = (lo + hi) / 2
    if name == "transform":
        move = mathutils.Matrix.Translation(mathutils.Vector((0.1, -0.2, 0.3)) * diagonal)
        turn = mathutils.Euler([math.radians(a) for a in (20, 30, 40)], "XYZ").to_matrix().to_4x4()
        obj.data.transform(move @ mathutils.Matrix.Scale(1.5, 4) @ turn)
        obj.data.update()
    elif name == "mirror":
        flip = mathutils.Matrix.Translation(centre) @ mathutils.Matrix.Scale(-1.0, 4, (1.0, 0.0, 0.0)) \
            @ mathutils.Matrix.Translation(-centre)

        def mirrored(bm):
            bmesh.ops.transform(bm, matrix=flip, verts=bm.verts)
            bmesh.ops.reverse_faces(bm, faces=bm.faces)

        with_bmesh(obj, mirrored)
    elif name == "merge":
        with_bmesh(obj, lambda bm: bmesh.ops.remove_doubles(bm, verts=bm.verts, dist=value * diagonal))
    elif name == "noise":
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="SELECT")
        bpy.ops.transform.vertex_random(offset=value * diagonal, uniform=0.0, normal=0.0, seed=seed)
        bpy.ops.object.mode_set(mode="OBJECT")
    elif name == "subdivide":
        apply_modifier(obj, "SUBSURF", levels=int(value), render_levels=int(value))
    elif name == "laplacian":
        apply_modifier(obj, "LAPLACIANSMOOTH", iterations=int(value))
    elif name == "smooth":
        apply_modifier(obj, "SMOOTH", factor=0.5, iterations=int(value))
    elif name == "decimate":
        apply_modifier(obj, "DECIMATE", decimate_type="COLLAPSE", ratio=value)
    elif name == "merged-decimate":
        with_bmesh(obj, lambda bm: bmesh.ops.remove_doubles(bm, verts=bm.verts, dist=DEFAULTS["merge"] * diagonal))
        apply_modifier(obj, "DECIMATE", decimate_type="COLLAPSE", ratio=value)
    elif name == "bisect" or name in HALVES:
        extent = hi - lo
        axis = max(range(3), key=lambda i: extent[i]) if name == "bisect" else "xyz".index(name[7])
        side = -1.0 if name.endswith("-") else 1.0
        normal = mathutils.Vector([side if i == axis else 0.0 for i in range(3)])

        def cut(bm):
            geom = list(bm.verts) + list(bm.edges) + list(bm.faces)
            bmesh.ops.bisect_plane(bm, geom=geom, plane_co=centre, plane_no=normal, clear_inner=True)

        with_bmesh(obj, cut)
    elif name == "voxel":
        apply_modifier(obj, "REMESH", mode="VOXEL", voxel_size=diagonal / value, adaptivity=0.0)
    else:  # parse_op admits only the names above
        raise AssertionError(name)
    return obj


def export(obj, name, path):
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    if name == "obj":
        # The writer's defaults, without its .mtl (no materials here) and the axis conversion.
        bpy.ops.wm.obj_export(filepath=path, export_selected_objects=True, export_materials=False,
                              forward_axis="Y", up_axis="Z")
    elif name == "gltf":
        bpy.ops.export_scene.gltf(filepath=path, export_format="GLB", use_selection=True)
    elif name == "ply":
        bpy.ops.export_mesh.ply(filepath=path)
    else:
        bpy.ops.export_mesh.ply(filepath=path, use_ascii=False, use_normals=False,
                                use_uv_coords=False, use_colors=False)


def main(argv):
    args = argv[argv.index("--") + 1:] if "--" in argv else []
    source, out_dir, specs, seed = parse_arguments(
        args, "blender -b --python attacks.py -- INPUT OUT_DIR [--seed S] OP [OP ...]")
    ops = [(spec, *parse_op(spec)) for spec in specs]  # all checked before any work
    report = []
    for spec, name, value in ops:
        start = time.time()
        obj = import_mesh(source, int(value) if name in ("pose", "second-action") else None,
                          1 if name == "second-action" else 0)
        obj = apply_op(obj, name, value, seed)
        label = spec.replace("=", "_")
        target = os.path.join(out_dir, label + ROUND_TRIP_EXT.get(name, ".ply"))
        temporary = os.path.join(out_dir, ".tmp-" + os.path.basename(target))
        export(obj, name, temporary)
        os.replace(temporary, target)
        report.append({"label": label, "op": spec, "output": target,
                       "vertices": len(obj.data.vertices), "faces": len(obj.data.polygons),
                       "seconds": round(time.time() - start, 3)})
        print("attacks.py: %s -> %s (%d vertices, %d faces)" %
              (spec, target, len(obj.data.vertices), len(obj.data.polygons)), flush=True)
    write_report(out_dir, report)


if __name__ == "__main__":
    try:
        main(sys.argv)
    except UsageError as e:
        print("attacks.py: %s" % e, file=sys.stderr, flush=True)
        sys.exit(2)
    except Exception as e:  # Blender's own errors: one line, then the trace for debugging
        print("attacks.py: %s: %s" % (type(e).__name__, e), file=sys.stderr, flush=True)
        traceback.print_exc()
        sys.exit(2)
