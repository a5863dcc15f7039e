"""Exports put every vertex where the scene has it (issue 33 item 4): a rig object with a part parented while
the rig was turned, under every transform an artist's scene gives it (turned, scaled, mirrored, under a
moving Empty, with head motion as a delta rotation, a moving part, a centimetre scene), written as GLB and
FBX and read back by Blender's own importers: every vertex within 0.1 mm at rest and at animated frames."""
from __future__ import annotations

import math

import pytest

from conftest import addon_module
from export_checks import mesh_names, placement_errors, reimport, world_vertices

TOLERANCE_M = 1e-4
FRAMES = (1, 7, 14, 21)
CASES = ("turned", "turned_scaled", "mirrored", "under_moving_empty", "head_motion_over_turn", "moving_part",
         "centimetres")


def _sphere(bpy, name, radius, location=(0.0, 0.0, 0.0)):
    bpy.ops.mesh.primitive_uv_sphere_add(radius=radius, segments=12, ring_count=6, location=location)
    obj = bpy.context.active_object
    obj.name = obj.data.name = name
    return obj


def _key(obj, path, frames_values):
    for frame, value in frames_values:
        setattr(obj, path, value)
        obj.keyframe_insert(path, frame=frame)


def _scene(bpy, case):
    """A head (the rig object, with an animated shape key) and an eye parented to it as Ctrl+P does."""
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end, scene.render.fps = 1, 21, 30
    head = _sphere(bpy, "Head", 0.1)
    head.shape_key_add(name="Basis")
    jaw = head.shape_key_add(name="jawOpen")
    for point in jaw.data:
        if point.co.z < 0:
            point.co.z -= 0.02
    _key(jaw, "value", ((1, 0.0), (21, 1.0)))
    eye = _sphere(bpy, "Eye", 0.012, (0.03, -0.09, 0.03))
    eye["fh_part"] = "eye_L"
    if case.startswith(("turned", "head_motion")):
        head.rotation_euler = (math.pi / 2, 0.0, 0.3)
        head.location = (1.0, 2.0, 3.0)
    if case == "turned_scaled":
        head.scale = (0.5, 2.0, 1.0)
    if case == "mirrored":
        head.scale = (-1.0, 1.0, 1.0)
    if case == "under_moving_empty":
        root = bpy.data.objects.new("Root", None)
        scene.collection.objects.link(root)
        root.rotation_euler, root.scale = (0.0, 0.0, 1.0), (2.0, 2.0, 2.0)
        _key(root, "location", ((1, (0.5, 0.0, 0.0)), (21, (0.0, 1.0, 0.2))))
        head.parent = root
    if case == "head_motion_over_turn":
        _key(head, "delta_rotation_euler", ((1, (0.2, 0.1, 0.3)), (21, (-0.2, 0.0, 0.5))))
    if case == "centimetres":
        scene.unit_settings.scale_length = 0.01
        head.rotation_euler = (0.0, 0.0, 1.0)
    bpy.context.view_layer.update()
    eye.parent = head
    eye.matrix_parent_inverse = head.matrix_world.inverted()
    if case == "moving_part":
        head.rotation_euler = (math.pi / 2, 0.0, 0.0)
        _key(eye, "rotation_euler", ((1, (0.0, 0.0, 0.0)), (21, (0.3, 0.2, 0.1))))
    bpy.context.view_layer.update()
    return head, eye


@pytest.mark.parametrize("case", CASES)
def test_every_vertex_of_every_part_where_the_scene_has_it(bpy_clean, tmp_path, case):
    bpy = bpy_clean
    export = addon_module("operators.adapters.export")
    head, eye = _scene(bpy, case)
    wanted = world_vertices(bpy, [head, eye], FRAMES)
    names = mesh_names([head, eye])
    paths = [export.export_rig(bpy.context, head, str(tmp_path / f"{case}.{fmt}"), ("eye_L",)) for fmt in ("glb", "fbx")]
    for path in paths:
        imported = reimport(bpy, path, 30)
        errors = placement_errors(wanted, world_vertices(bpy, imported, [f - FRAMES[0] for f in FRAMES], names))
        assert max(errors.values()) <= TOLERANCE_M, (path.suffix, {k: f"{v * 1000:.3f} mm" for k, v in errors.items()})
