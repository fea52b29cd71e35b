# SPDX-License-Identifier: MIT
# Renders an original mesh and its marked copy the same way, for judging the mark by eye
# (bench/results/2026-11-25-by-eye.md). Runs inside Blender, headless:
#
#   blender -b --factory-startup --python-exit-code 2 --python bench/render/render_pair.py -- \
#       ORIGINAL MARKED OUT_PREFIX [--size PX] [--samples N] [--view quarter|front|side|top]
#
# Both meshes are read with Blender's own PLY/OBJ/STL importer, shaded smooth (vertex normals
# from the faces, as a viewer shows them) with a glossy grey material, and rendered by Cycles on
# the CPU from the same camera: orthographic, framing the original's bounding box, a key light
# at a grazing angle of 20 degrees to the view's plane so that small normal changes show as
# ripples in the highlights, a dim fill light. Writes OUT_PREFIX-original.png,
# OUT_PREFIX-marked.png and OUT_PREFIX-pair.png (side by side, original left), and prints the
# pixel difference of the two pictures (mean, 99th percentile, max, in 8-bit levels).
# Any error exits 2 with one line on stderr.
import math
import os
import sys
import traceback

import bpy
import mathutils
import numpy


# Where the camera looks from, in the file's coordinates (Y up, as most scans): the default is a
# three-quarter view from the front right.
VIEWS = {"quarter": (1.0, 0.8, 1.0), "front": (0.0, 0.0, 1.0), "side": (1.0, 0.0, 0.0), "top": (0.0, 1.0, 0.0)}


def usage(message):
    sys.stderr.write("render_pair.py: %s\n" % message)
    sys.exit(2)


def parse(argv):
    args = argv[argv.index("--") + 1:] if "--" in argv else []
    options = {"size": 768, "samples": 24, "view": "quarter"}
    positional = []
    i = 0
    while i < len(args):
        a = args[i]
        if a in ("--size", "--samples", "--view"):
            if i + 1 >= len(args):
                usage("%s needs a value" % a)
            value = args[i + 1]
            options[a[2:]] = value if a == "--view" else int(value)
            i += 2
        else:
            positional.append(a)
            i += 1
    if len(positional) != 3:
        usage("expected ORIGINAL MARKED OUT_PREFIX, got %d arguments" % len(positional))
    if options["view"] not in VIEWS:
        usage("--view must be one of " + ", ".join(sorted(VIEWS)))
    return positional, options


def import_mesh(path):
    ext = os.path.splitext(path)[1].lower()
    before = set(bpy.data.objects)
    if ext == ".ply":
        bpy.ops.import_mesh.ply(filepath=path)
    elif ext == ".obj":
        bpy.ops.import_scene.obj(filepath=path, split_mode="OFF", axis_forward="-Z", axis_up="Y")
    elif ext == ".stl":
        bpy.ops.import_mesh.stl(filepath=path)
    else:
        usage("%s: unsupported extension %s" % (path, ext))
    added = [o for o in bpy.data.objects if o not in before and o.type == "MESH"]
    if len(added) != 1:
        usage("%s: expected one mesh object, got %d" % (path, len(added)))
    obj = added[0]
    # Every importer is told the same axes: undo what the OBJ importer's axis conversion did,
    # so both files sit in their own coordinates.
    obj.rotation_euler = (0.0, 0.0, 0.0)
    obj.location = (0.0, 0.0, 0.0)
    obj.scale = (1.0, 1.0, 1.0)
    # The same look whatever the importer brought: no material of the file's, no custom or
    # auto-smoothed split normals, every face smooth.
    obj.data.materials.clear()
    if obj.data.has_custom_normals:
        bpy.context.view_layer.objects.active = obj
        bpy.ops.mesh.customdata_custom_splitnormals_clear()
    obj.data.use_auto_smooth = False
    for polygon in obj.data.polygons:
        polygon.use_smooth = True
        polygon.material_index = 0
    return obj


def main():
    (original_path, marked_path, prefix), options = parse(sys.argv)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = options["samples"]
    scene.cycles.use_denoising = False
    scene.render.resolution_x = options["size"]
    scene.render.resolution_y = options["size"]
    scene.render.film_transparent = False
    scene.view_settings.view_transform = "Standard"
    world = bpy.data.worlds.new("world")
    world.color = (0.05, 0.05, 0.05)
    scene.world = world

    material = bpy.data.materials.new("grey")
    material.use_nodes = True
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.6, 0.6, 0.62, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.25
    bsdf.inputs["Specular"].default_value = 0.6

    objects = {}
    for label, path in (("original", original_path), ("marked", marked_path)):
        obj = import_mesh(path)
        obj.data.materials.append(material)
        objects[label] = obj

    corners = [mathutils.Vector(c) for c in objects["original"].bound_box]
    lo = mathutils.Vector([min(c[i] for c in corners) for i in range(3)])
    hi = mathutils.Vector([max(c[i] for c in corners) for i in range(3)])
    centre = (lo + hi) / 2
    diagonal = (hi - lo).length
    view = mathutils.Vector(VIEWS[options["view"]]).normalized()
    up = mathutils.Vector((0, 1, 0)) if options["view"] != "top" else mathutils.Vector((0, 0, -1))

    camera_data = bpy.data.cameras.new("camera")
    camera_data.type = "ORTHO"
    camera_data.ortho_scale = diagonal * 0.9
    camera_data.clip_start = diagonal * 0.01
    camera_data.clip_end = diagonal * 10
    camera = bpy.data.objects.new("camera", camera_data)
    scene.collection.objects.link(camera)
    camera.location = centre + view * diagonal * 2
    camera.rotation_euler = (-view).to_track_quat("-Z", "Y" if options["view"] != "top" else "Z").to_euler()
    scene.camera = camera

    # Key light grazing at 20 degrees from the view direction, from the upper left; dim fill.
    right = view.cross(up).normalized()
    key_direction = (view * math.cos(math.radians(70)) + (up - right).normalized() * math.sin(math.radians(70)))
    key_data = bpy.data.lights.new("key", "SUN")
    key_data.energy = 2.0
    key_data.angle = math.radians(1.0)
    key = bpy.data.objects.new("key", key_data)
    key.rotation_euler = (-key_direction).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(key)
    fill_data = bpy.data.lights.new("fill", "SUN")
    fill_data.energy = 0.4
    fill = bpy.data.objects.new("fill", fill_data)
    fill.rotation_euler = (-view).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(fill)

    pixels = {}
    for label in ("original", "marked"):
        for other, obj in objects.items():
            obj.hide_render = other != label
        path = "%s-%s.png" % (prefix, label)
        scene.render.filepath = path
        bpy.ops.render.render(write_still=True)
        image = bpy.data.images.load(os.path.abspath(path))
        pixels[label] = numpy.array(image.pixels[:]).reshape(image.size[1], image.size[0], 4)

    # Side by side (original left), and how far apart the two pictures are in 8-bit levels.
    pair = numpy.concatenate([pixels["original"], pixels["marked"]], axis=1)
    height, width = pair.shape[:2]
    out = bpy.data.images.new("pair", width=width, height=height)
    out.pixels = pair.ravel().tolist()
    out.filepath_raw = os.path.abspath("%s-pair.png" % prefix)
    out.file_format = "PNG"
    out.save()
    difference = numpy.abs(pixels["original"][..., :3] - pixels["marked"][..., :3]) * 255.0
    print("render_pair.py: %s: pixel difference mean %.2f, 99th percentile %.1f, max %.1f (8-bit levels)"
          % (os.path.basename(prefix), difference.mean(), numpy.percentile(difference, 99), difference.max()))


if __name__ == "__main__":
    try:
        main()
    except SystemExit:
        raise
    except Exception:  # one line on stderr, exit 2, as the other bench scripts
        sys.stderr.write("render_pair.py: %s\n" % traceback.format_exc().strip().splitlines()[-1])
        sys.exit(2)
