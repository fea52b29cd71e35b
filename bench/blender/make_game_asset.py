# SPDX-License-Identifier: MIT
# A game-like asset made in Blender, for the robustness bench
# (bench/results/2026-11-26-game-like-asset-in-blender.md): no game asset is among the shared
# meshes, and this one has what
# makes them hard: separate parts (Suzanne's head and two eyes, a bevelled box, a cylinder),
# hard edges split (Edge Split at 30 degrees) and UV seams (Smart UV Project), written as .glb,
# where both split the vertices. Runs inside Blender, headless:
#
#   blender -b --factory-startup --python bench/blender/make_game_asset.py -- OUT.glb [KIND]
#
# KIND (default suzanne): Blender 3.4 (Debian) gives
#   suzanne   the asset above: 8,150 distinct positions (meshmark's reader welds the glTF's split
#             vertices back; Blender's own writers keep 10,235), 16,120 triangles, 5 parts;
#   vehicle   hard surface: 13 objects kept apart under one node turned 25 degrees and scaled
#             1.3 (node transforms in the file), bevelled boxes of few vertices (the body has 96)
#             beside dense tyres (4 x 1,280), hubs, an exhaust and two lamps that interpenetrate
#             them, sharp edges by auto smooth at 30 degrees, Smart UV seams: 7,148 positions;
#   creature  organic: a Skin modifier on a mirrored skeleton, subdivided 3 times, with two eyes
#             and a low-poly spear as separate objects, UV seams: 7,679 positions;
#   rigged-creature  the creature skinned to a two-bone armature, with an animation that
#             turns the front bone by 20 degrees over frames 1-20 (attacks.py's pose=FRAME);
#   faceted-creature  the creature flat shaded: every triangle has vertices of its own;
#   turntable-vehicle  the vehicle on a display turntable: its root turns once about z over
#             frames 1-96, an animation that moves the asset only as a whole;
#   two-action-creature  the rigged creature with a second action (the back bone bowing by 25
#             degrees over frames 1-30): two glTF animations, "bow" (written first) and "turn".
#   morph-creature  the creature with a shape key (a morph target in the file): "puff" swells
#             the head along its normals by 0.06 (1.7% of the diagonal), set to 0.6 in the file
#             (the mesh's default weights: what viewers and Blender show) and animated from 0.6
#             at frame 1 to 0 at frame 10 and 1 at frame 20 (a weights channel);
#   blended-creature  the same shape key left at 0.6, not animated (a fixed blend);
#   chopped-vehicle  the vehicle with a shape key "chop" on its cabin (its roof lowered by 0.15),
#             left at 0.8, not animated (a fixed blend on one part).
# (bench/results/2026-11-26-two-more-game-like-assets.md).
import math
import sys

import numpy

numpy.bool = bool  # Debian's Blender 3.4 glTF add-on still uses the alias NumPy removed
import bpy  # noqa: E402
import mathutils  # noqa: E402


def suzanne():
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
    return [asset]


def uv_and_smooth(obj, sharp=True):
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.uv.smart_project(angle_limit=math.radians(66))
    bpy.ops.object.mode_set(mode="OBJECT")
    bpy.ops.object.shade_smooth()
    if sharp:
        obj.data.use_auto_smooth = True
        obj.data.auto_smooth_angle = math.radians(30)


def apply(obj, kind, **settings):
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    m = obj.modifiers.new(kind.lower(), kind)
    for k, v in settings.items():
        setattr(m, k, v)
    bpy.ops.object.modifier_apply(modifier=m.name)


def vehicle():
    objs = []
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, 0.6))
    body = bpy.context.active_object
    body.scale = (2.2, 1.0, 0.5)
    apply(body, "BEVEL", width=0.04, segments=3)
    objs.append(body)
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(-0.2, 0, 1.05))
    cabin = bpy.context.active_object
    cabin.scale = (1.0, 0.85, 0.45)
    apply(cabin, "BEVEL", width=0.06, segments=4)
    objs.append(cabin)
    for i, (x, y) in enumerate([(0.75, 0.55), (0.75, -0.55), (-0.75, 0.55), (-0.75, -0.55)]):
        bpy.ops.mesh.primitive_torus_add(major_radius=0.24, minor_radius=0.1, major_segments=64,
                                         minor_segments=20, location=(x, y, 0.32),
                                         rotation=(math.radians(90), 0, 0))
        tyre = bpy.context.active_object
        objs.append(tyre)
        bpy.ops.mesh.primitive_cylinder_add(vertices=32, radius=0.16, depth=0.12, location=(x, y, 0.32),
                                            rotation=(math.radians(90), 0, 0))
        hub = bpy.context.active_object
        apply(hub, "BEVEL", width=0.01, segments=2)
        objs.append(hub)
    bpy.ops.mesh.primitive_cylinder_add(vertices=24, radius=0.05, depth=0.5, location=(-1.15, 0.3, 0.55),
                                        rotation=(0, math.radians(90), 0))
    objs.append(bpy.context.active_object)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=0.12, location=(0.95, 0.35, 0.75))
    lamp = bpy.context.active_object
    lamp.scale = (0.6, 1, 1)
    objs.append(lamp)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=0.12, location=(0.95, -0.35, 0.75))
    lamp = bpy.context.active_object
    lamp.scale = (0.6, 1, 1)
    objs.append(lamp)
    for o in objs:
        uv_and_smooth(o)
    # a whole-vehicle node transform: rotated and scaled, not applied
    bpy.ops.object.empty_add(location=(0, 0, 0))
    root = bpy.context.active_object
    for o in objs:
        o.parent = root
    root.rotation_euler = (0, 0, math.radians(25))
    root.scale = (1.3, 1.3, 1.3)
    return objs


def turntable_vehicle():
    """The vehicle on a display turntable: its root node turns once about z over frames 1-96
    (4 s), as shop and viewer models often do; no frame bends it."""
    objects = vehicle()
    root = objects[0].parent
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 96
    root.keyframe_insert("rotation_euler", frame=1)
    root.rotation_euler = (0, 0, math.radians(25 + 360))
    root.keyframe_insert("rotation_euler", frame=96)
    scene.frame_set(1)
    return objects


def add_shape_key(obj, name, offset):
    """A shape key \p name on \p obj (after a Basis) moving each vertex by offset(vertex), a
    Vector, or leaving it where offset gives None."""
    obj.shape_key_add(name="Basis")
    key = obj.shape_key_add(name=name)
    for vertex, point in zip(obj.data.vertices, key.data):
        moved = offset(vertex)
        if moved is not None:
            point.co = vertex.co + moved
    return key


def chopped_vehicle():
    """The vehicle with a shape key on its cabin: "chop" lowers the cabin's roof by 0.15 (its
    upper half: a chopped roof), left at 0.8 and not animated (a fixed blend on one part)."""
    objects = vehicle()
    cabin = objects[1]
    down = mathutils.Vector((0.0, 0.0, -0.15 / cabin.scale[2]))
    chop = add_shape_key(cabin, "chop", lambda vertex: down if vertex.co[2] > 0.0 else None)
    chop.value = 0.8
    return objects


def creature():
    verts = [(0, 0, 1.0), (0, 0.5, 1.05), (0, 1.0, 1.0), (0, 1.3, 1.35), (0, 1.55, 1.5), (0, 1.85, 1.45),
             (0, -0.5, 1.0), (0, -1.0, 1.05), (0, -1.4, 1.2), (0.35, 1.0, 0.6), (0.4, 1.05, 0.15),
             (0.35, 0.0, 0.6), (0.4, -0.05, 0.15)]
    edges = [(0, 1), (1, 2), (2, 3), (3, 4), (4, 5), (0, 6), (6, 7), (7, 8), (2, 9), (9, 10), (0, 11), (11, 12)]
    mesh = bpy.data.meshes.new("creature")
    mesh.from_pydata(verts, edges, [])
    obj = bpy.data.objects.new("creature", mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    obj.modifiers.new("mirror", "MIRROR").use_clip = True
    skin = obj.modifiers.new("skin", "SKIN")
    skin.use_smooth_shade = True
    bpy.ops.object.modifier_apply(modifier="mirror")
    # skin radii: thick body, thin legs and tail tip
    for i, v in enumerate(obj.data.vertices):
        sv = obj.data.skin_vertices[0].data[i]
        y, z = v.co[1], v.co[2]
        if z < 0.7:
            sv.radius = (0.12, 0.12)
        elif y < -0.8:
            sv.radius = (0.1, 0.1)
        elif y > 1.4:
            sv.radius = (0.2, 0.22)
        else:
            sv.radius = (0.3, 0.3)
    bpy.ops.object.modifier_apply(modifier="skin")
    apply(obj, "SUBSURF", levels=3, render_levels=3)
    objs = [obj]
    for x in (0.12, -0.12):
        bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=8, radius=0.05, location=(x, 1.98, 1.55))
        objs.append(bpy.context.active_object)
    bpy.ops.mesh.primitive_cylinder_add(vertices=8, radius=0.03, depth=2.0, location=(0.7, 0.8, 1.0),
                                        rotation=(math.radians(70), 0, 0))
    objs.append(bpy.context.active_object)
    bpy.ops.mesh.primitive_cone_add(vertices=8, radius1=0.08, depth=0.3, location=(0.7, 1.75, 1.35),
                                    rotation=(math.radians(-20), 0, 0))
    objs.append(bpy.context.active_object)
    for o in objs:
        uv_and_smooth(o, sharp=o is not obj)
    return objs


def rigged_creature():
    """The creature with a two-bone armature (automatic weights) whose front bone turns by 20
    degrees about x from frame 1 to frame 20: a skinned glTF with an animation, written at
    frame 1 (the bind pose)."""
    objects = creature()
    body = objects[0]
    bpy.ops.object.armature_add(location=(0, 0, 0))
    armature = bpy.context.active_object
    bpy.ops.object.mode_set(mode="EDIT")
    bones = armature.data.edit_bones
    back = bones[0]
    back.name = "back"
    back.head = (0, -1.4, 1.2)
    back.tail = (0, 0, 1.0)
    front = bones.new("front")
    front.head = (0, 0, 1.0)
    front.tail = (0, 1.9, 1.5)
    front.parent = back
    front.use_connect = True
    bpy.ops.object.mode_set(mode="OBJECT")
    bpy.ops.object.select_all(action="DESELECT")
    body.select_set(True)
    armature.select_set(True)
    bpy.context.view_layer.objects.active = armature
    bpy.ops.object.parent_set(type="ARMATURE_AUTO")
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 20
    bone = armature.pose.bones["front"]
    bone.rotation_mode = "XYZ"
    bone.rotation_euler = (0, 0, 0)
    bone.keyframe_insert("rotation_euler", frame=1)
    bone.rotation_euler = (math.radians(20), 0, 0)
    bone.keyframe_insert("rotation_euler", frame=20)
    scene.frame_set(1)
    return objects


def two_action_creature():
    """The rigged creature with a second action, "bow": the back bone turned by -25 degrees
    about x over frames 1-30. Both are kept in NLA tracks, so the glTF writer exports two
    animations (Blender 3.4 writes "bow" first); Blender plays the first after importing."""
    objects = rigged_creature()
    armature = next(o for o in bpy.context.scene.objects if o.type == "ARMATURE")
    turn = armature.animation_data.action
    turn.name = "turn"
    bow = bpy.data.actions.new("bow")
    armature.animation_data.action = bow
    bone = armature.pose.bones["back"]
    bone.rotation_mode = "XYZ"
    bone.rotation_euler = (0, 0, 0)
    bone.keyframe_insert("rotation_euler", frame=1)
    bone.rotation_euler = (math.radians(-25), 0, 0)
    bone.keyframe_insert("rotation_euler", frame=30)
    bone.rotation_euler = (0, 0, 0)
    armature.pose.bones["front"].rotation_euler = (0, 0, 0)
    armature.animation_data.action = None
    for action in (bow, turn):
        track = armature.animation_data.nla_tracks.new()
        track.name = action.name
        track.strips.new(action.name, 1, action)
    bpy.context.scene.frame_end = 30
    bpy.context.scene.frame_set(1)
    return objects


def morph_creature():
    """The creature with a shape key "puff" (the head swollen along its normals) at 0.6, and an
    animation of that key's value: 0.6 at frame 1, 0 at frame 10, 1 at frame 20."""
    objects = creature()
    puff = add_shape_key(objects[0], "puff", lambda vertex: 0.06 * vertex.normal if vertex.co[1] > 1.3 else None)
    puff.value = 0.6
    puff.keyframe_insert("value", frame=1)
    puff.value = 0.0
    puff.keyframe_insert("value", frame=10)
    puff.value = 1.0
    puff.keyframe_insert("value", frame=20)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 20
    scene.frame_set(1)
    return objects


def blended_creature():
    """The creature with the shape key of morph_creature left at 0.6, not animated (a fixed blend:
    the file's mesh weights)."""
    objects = morph_creature()
    body = objects[0]
    body.data.shape_keys.animation_data_clear()
    body.data.shape_keys.key_blocks["puff"].value = 0.6
    return objects


def faceted_creature():
    """The creature flat shaded: every face with vertices of its own in the file (low-poly art)."""
    objects = creature()
    for o in objects:
        o.data.use_auto_smooth = False
        for polygon in o.data.polygons:
            polygon.use_smooth = False
    return objects


KINDS = {"suzanne": suzanne, "vehicle": vehicle, "creature": creature, "rigged-creature": rigged_creature,
         "faceted-creature": faceted_creature, "turntable-vehicle": turntable_vehicle,
         "two-action-creature": two_action_creature, "morph-creature": morph_creature,
         "blended-creature": blended_creature, "chopped-vehicle": chopped_vehicle}


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(argv) not in (1, 2) or not argv[0].lower().endswith(".glb") or (len(argv) == 2 and argv[1] not in KINDS):
        sys.stderr.write("make_game_asset.py: usage: blender -b --python make_game_asset.py -- OUT.glb "
                         "[%s]\n" % "|".join(KINDS))
        sys.exit(2)
    kind = argv[1] if len(argv) == 2 else "suzanne"
    bpy.ops.wm.read_factory_settings(use_empty=True)
    objects = KINDS[kind]()
    bpy.ops.export_scene.gltf(filepath=argv[0], export_format="GLB", use_selection=False)
    print("make_game_asset.py: %s (%s): %d vertices, %d faces in Blender, %d objects" %
          (argv[0], kind, sum(len(o.data.vertices) for o in objects),
           sum(len(o.data.polygons) for o in objects), len(objects)))


main()
