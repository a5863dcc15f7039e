"""The hand on MPFB2's hand mesh through the installed add-on: built, animated, baked and exported, the FBX
re-imported in Blender carries the armature with the hand's bones, the skin's vertex groups for them and
weights summing to 1 over at most four bones per vertex (every export carries the skeleton)."""
from __future__ import annotations

import numpy as np

from conftest import addon_module
from export_checks import reimport

HAND_BONES = {"wrist", "thumb-metacarpal", "thumb-phalanx-proximal", "thumb-phalanx-distal"} | {
    f"{f}-finger-{p}" for f in ("index", "middle", "ring", "pinky")
    for p in ("metacarpal", "phalanx-proximal", "phalanx-intermediate", "phalanx-distal")}


def test_the_mpfb2_hand_exports_bones_and_weights_in_fbx(bpy_clean, tmp_path):
    bpy = bpy_clean
    assert bpy.ops.faces_hands.build_hand_rig(mesh="mpfb2") == {"FINISHED"}
    obj = bpy.context.active_object
    rig = addon_module("operators.adapters.rig_store").get_rig(obj, "hand")
    count = len(obj.data.vertices)
    assert rig.mesh == "mpfb2" and count == len(rig.template.skin.vertices)
    services = addon_module("operators.hand.services")
    bpy.context.scene.render.fps = 30
    services.animate(bpy.context, obj, "fist")
    services.bake(bpy.context, obj)
    fbx = services.export(bpy.context, obj, str(tmp_path / "hand.fbx"))
    imported = reimport(bpy, fbx, 30)
    armature = next(o for o in imported if o.type == "ARMATURE")
    skin = next(o for o in imported if o.type == "MESH" and len(o.data.vertices) == count)
    assert skin.parent == armature and skin.modifiers[0].object == armature
    assert HAND_BONES <= {b.name for b in armature.data.bones}
    assert HAND_BONES <= {g.name for g in skin.vertex_groups}
    sums = np.array([sum(g.weight for g in v.groups) for v in skin.data.vertices])
    assert np.allclose(sums, 1.0, atol=2e-3) and max(len(v.groups) for v in skin.data.vertices) <= 4
    groups = {g.index: g.name for g in skin.vertex_groups}
    heaviest = {groups[max(v.groups, key=lambda g: g.weight).group] for v in skin.data.vertices}
    assert HAND_BONES - {"forearm"} <= heaviest            # every finger bone moves skin of its own
    assert armature.animation_data is not None and armature.animation_data.action is not None
