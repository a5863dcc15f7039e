"""Fit Face Rig to Character on an artist's own character (issue 35, bad input): a body of several meshes, an
armature without known neck and head bones, a mesh without the head's vertex group or without an armature are
refused with a message naming what is missing, before anything changes."""
from __future__ import annotations

import pytest


def _character(bpy, bones=("neck_01", "head"), meshes=1, group="head"):
    arm_data = bpy.data.armatures.new("Armature")
    arm = bpy.data.objects.new("Armature", arm_data)
    bpy.context.scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    for k, name in enumerate(bones):
        bone = arm_data.edit_bones.new(name)
        bone.head, bone.tail = (0.0, 0.0, 1.4 + 0.1 * k), (0.0, 0.0, 1.5 + 0.1 * k)
    bpy.ops.object.mode_set(mode="OBJECT")
    made = []
    for k in range(meshes):
        mesh = bpy.data.meshes.new(f"Body {k}")
        mesh.from_pydata([(0, 0, 1.5), (0.1, 0, 1.5), (0, 0.1, 1.6)], [], [(0, 1, 2)])
        obj = bpy.data.objects.new(f"Body {k}", mesh)
        bpy.context.scene.collection.objects.link(obj)
        obj.modifiers.new("Armature", "ARMATURE").object = arm
        if group:
            obj.vertex_groups.new(name=group).add([0, 1, 2], 1.0, "REPLACE")
        made.append(obj)
    return arm, made


def _state(bpy):
    return {o.name: sorted(o.keys()) for o in bpy.data.objects}


@pytest.mark.parametrize("setup, message", [
    (dict(meshes=2), "the body is 2 meshes skinned to 'Armature'"),
    (dict(bones=("spine", "skull")), "no neck and head bones"),
    (dict(group="Head"), "no vertex group 'head'"),
    (dict(), "only 3 vertices"),
])
def test_fit_character_refuses_what_it_cannot_rig(bpy_clean, setup, message):
    bpy = bpy_clean
    arm, meshes = _character(bpy, **setup)
    bpy.context.view_layer.objects.active = meshes[0]
    before = _state(bpy)
    with pytest.raises(RuntimeError, match=message):
        bpy.ops.faces_hands.fit_character()
    assert _state(bpy) == before and arm.animation_data is None


def test_fit_character_needs_an_armature(bpy_clean):
    bpy = bpy_clean
    _, meshes = _character(bpy)
    meshes[0].modifiers.clear()
    bpy.context.view_layer.objects.active = meshes[0]
    with pytest.raises(RuntimeError, match="not deformed by an armature"):
        bpy.ops.faces_hands.fit_character()
