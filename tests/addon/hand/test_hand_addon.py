"""The hand rig through the installed add-on: objects, Table 6.4 limits, live step, Solve Contractions,
bake + glTF/FBX export, retargeting onto the WebXR generic hand, operators refusing bad input."""
from __future__ import annotations

import json
import math
import struct
from pathlib import Path

import numpy as np
import pytest

from conftest import addon_module
from export_checks import mesh_names, placement_errors, reimport, world_vertices

WEBXR_NAMES = {"wrist", "thumb-metacarpal", "thumb-phalanx-proximal", "thumb-phalanx-distal"} | {
    f"{f}-finger-{p}" for f in ("index", "middle", "ring", "pinky")
    for p in ("metacarpal", "phalanx-proximal", "phalanx-intermediate", "phalanx-distal")}


def _build(bpy, side="right"):
    assert bpy.ops.faces_hands.build_hand_rig(side=side) == {"FINISHED"}
    obj = bpy.context.active_object
    assert obj.get("fh_rig") and obj.get("fh_rig_kind") == "hand" and obj.type == "MESH"
    return obj


def _armature(obj):
    return next(c for c in obj.children if c.get("fh_part") == "armature")


def _evaluated(bpy, obj) -> np.ndarray:
    graph = bpy.context.evaluated_depsgraph_get()
    mesh = obj.evaluated_get(graph).to_mesh()
    out = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", out)
    obj.evaluated_get(graph).to_mesh_clear()
    return out.reshape(-1, 3)


def _glb_json(path: Path) -> dict:
    data = path.read_bytes()
    return json.loads(data[20:20 + struct.unpack_from("<I", data, 12)[0]])


def _glb_accessor(path: Path, doc: dict, index: int) -> np.ndarray:
    """Accessor ``index`` of the GLB ``path`` as an array (rows x components)."""
    data = path.read_bytes()
    start = 20 + struct.unpack_from("<I", data, 12)[0] + 8
    accessor = doc["accessors"][index]
    view = doc["bufferViews"][accessor["bufferView"]]
    dtype = {5126: np.float32, 5121: np.uint8, 5123: np.uint16}[accessor["componentType"]]
    width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}[accessor["type"]]
    values = np.frombuffer(data, dtype, accessor["count"] * width,
                           start + view.get("byteOffset", 0) + accessor.get("byteOffset", 0))
    if accessor.get("normalized"):
        values = values / np.iinfo(dtype).max
    return values.reshape(accessor["count"], width)


def _state(bpy):
    return {o.name: ({k: repr(o[k]) for k in o.keys() if k != "fh_rig_data"}, [list(r) for r in o.matrix_basis])
            for o in bpy.data.objects}


@pytest.mark.smoke
def test_build_hand_objects_armature_limits_and_controls(bpy_clean):
    bpy = bpy_clean
    obj = _build(bpy)
    arm = _armature(obj)
    assert WEBXR_NAMES | {"forearm"} == {b.name for b in arm.data.bones}
    assert len(obj.data.vertices) == pytest.approx(1500, rel=0.05) and len(obj.data.polygons) == pytest.approx(3000, rel=0.05)
    assert obj.modifiers["Armature"].object == arm
    bone_meshes = [o for o in bpy.data.objects if o.parent == arm and o.parent_type == "BONE"]
    assert len(bone_meshes) == 21 and {o.parent_bone for o in bone_meshes} == {b.name for b in arm.data.bones}
    limit = arm.pose.bones["index-finger-phalanx-proximal"].constraints["Table 6.4"]
    assert (math.degrees(limit.min_x), math.degrees(limit.max_x)) == pytest.approx((-25, 90))
    pip = arm.pose.bones["middle-finger-phalanx-intermediate"].constraints["Table 6.4"]
    assert math.degrees(pip.max_x) == pytest.approx(110) and pip.min_y == pip.max_y == 0.0
    fixed = arm.pose.bones["index-finger-metacarpal"].constraints["Table 6.4"]
    assert fixed.min_x == fixed.max_x == fixed.min_z == fixed.max_z == 0.0        # index CMC is fixed
    assert len([k for k in obj.keys() if k.startswith("fh.ctrl.")]) == 42
    ui = obj.id_properties_ui("fh.ctrl.opponens_pollicis").as_dict()
    assert (ui["min"], ui["max"]) == (0.0, 1.0) and "bulges" in ui["description"]


def test_limit_rotation_keeps_a_posed_bone_inside_table_6_4(bpy_clean):
    bpy = bpy_clean
    arm = _armature(_build(bpy))
    bone = arm.pose.bones["index-finger-phalanx-intermediate"]
    bone.rotation_euler = (3.0, 0.0, 0.0)
    bpy.context.view_layer.update()
    rest = np.array(arm.data.bones[bone.name].matrix_local)[:3, :3]
    posed = np.array(bone.matrix)[:3, :3]
    angle = math.degrees(math.acos(np.clip((np.trace(rest.T @ posed) - 1) / 2, -1, 1)))
    assert angle == pytest.approx(110.0, abs=0.5)


def test_live_step_curls_a_finger_towards_the_palm(bpy_clean):
    bpy = bpy_clean
    obj = _build(bpy)
    live = addon_module("operators.bases.live")
    objects = addon_module("operators.hand.objects")
    rest = _evaluated(bpy, obj)
    obj["fh.ctrl.flexor_digitorum_profundus_middle"] = 0.4
    for _ in range(20):
        live.live_step(bpy.context, obj, objects.push_hand_pose, dt=1 / 30)
    moved = _evaluated(bpy, obj)
    tip = int(np.argmin(rest[:, 2]))                       # the middle finger's tip hangs lowest
    assert moved[tip, 0] - rest[tip, 0] > 0.03             # towards the palm (+X), > 3 cm
    assert abs(_armature(obj).pose.bones["middle-finger-phalanx-proximal"].rotation_euler.x) > 0.3


def test_solve_contractions_for_a_posed_armature(bpy_clean):
    bpy = bpy_clean
    obj = _build(bpy)
    arm = _armature(obj)
    for finger in ("index", "middle", "ring"):
        arm.pose.bones[f"{finger}-finger-phalanx-proximal"].rotation_euler.x = math.radians(50)
        arm.pose.bones[f"{finger}-finger-phalanx-intermediate"].rotation_euler.x = math.radians(60)
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.faces_hands.solve_contractions() == {"FINISHED"}
    values = {k[8:]: obj[k] for k in obj.keys() if k.startswith("fh.ctrl.")}
    assert sum(v > 0.01 for v in values.values()) >= 3 and all(0 <= v <= 1 for v in values.values())
    assert max(values[f"flexor_digitorum_{m}_middle"] for m in ("profundus", "superficialis")) > 0.01
    assert arm.pose.bones["index-finger-phalanx-proximal"].rotation_euler.x == 0.0


def test_apply_hand_pose_sets_a_staged_pose_stage_by_stage(bpy_clean):
    bpy = bpy_clean
    obj = _build(bpy)
    motion = addon_module("faces_hands_addon.hand.motion")
    names = [k[8:] for k in obj.keys() if k.startswith("fh.ctrl.")]
    fist, squeezed = motion.pose_stages("fist", names)
    assert squeezed != fist
    for squeeze, stage in ((False, fist), (True, squeezed)):
        assert bpy.ops.faces_hands.apply_hand_pose(pose="fist", squeeze=squeeze) == {"FINISHED"}
        values = {n: obj[f"fh.ctrl.{n}"] for n in names}
        assert values == pytest.approx({n: stage.get(n, 0.0) for n in names})
    assert bpy.ops.faces_hands.apply_hand_pose(pose="point", squeeze=True) == {"FINISHED"}   # no squeeze: the pose
    assert {n: obj[f"fh.ctrl.{n}"] for n in names} == pytest.approx(
        {n: motion.pose_contractions("point", names).get(n, 0.0) for n in names})


def test_bake_and_export_glb_and_fbx(bpy_clean, tmp_path, capfd):
    """Every export carries the skeleton: in the GLB the armature is the skin's parent, four joint influences
    per vertex summing to 1, rotation keys on the finger bones and the bulge shape keys' weights animated with
    the contractions; the FBX re-imported has the bones, weights, keys and their animation; both play where the
    scene has the hand (skin vertices within 0.1 mm at four frames) and the exporters warn of nothing (no
    skinned mesh outside its armature, no constraints left to bake)."""
    bpy = bpy_clean
    obj = _build(bpy)
    services = addon_module("operators.hand.services")
    bpy.context.scene.render.fps = 30
    first, last = services.animate(bpy.context, obj, "wave_to_fist")
    assert (first, last) == (1, 103)          # 3.4 s: the fist is held, squeezed and let go (hand/motion.py)
    report = services.bake(bpy.context, obj)
    assert "103 frames" in report
    keys = [k.name for k in obj.data.shape_keys.key_blocks if k.name.startswith("FH.")]
    assert 20 <= len(keys) <= 40 and sum(k.startswith("FH.bulge.") for k in keys) == 9
    capfd.readouterr()
    glb = services.export(bpy.context, obj, str(tmp_path / "hand.glb"))
    log = capfd.readouterr()
    assert "Armature must be the parent" not in log.out + log.err and "Baking animation" not in log.out + log.err
    arm = _armature(obj)
    assert obj.modifiers["Armature"].object == arm and all(len(b.constraints) == 1 for b in arm.pose.bones)
    doc = _glb_json(glb)
    assert len(doc["skins"]) == 1
    joint_names = {doc["nodes"][j]["name"] for j in doc["skins"][0]["joints"]}
    assert WEBXR_NAMES <= joint_names
    skinned = next(i for i, n in enumerate(doc["nodes"]) if "skin" in n)
    parent = next(n for n in doc["nodes"] if skinned in n.get("children", ()))
    assert "skin" not in parent and "mesh" not in parent and parent["name"] == arm.name     # the armature
    mesh = next(m for m in doc["meshes"] if "targets" in m["primitives"][0])
    assert len(mesh["primitives"][0]["targets"]) == len(keys) and mesh["extras"]["targetNames"] == keys
    attributes = mesh["primitives"][0]["attributes"]
    assert "JOINTS_1" not in attributes
    weights = _glb_accessor(glb, doc, attributes["WEIGHTS_0"])
    assert np.allclose(weights.sum(axis=1), 1.0, atol=2e-3) and (weights > 0).sum(axis=1).max() <= 4
    assert (weights > 0).sum(axis=1).max() >= 3                  # blended, not one bone per vertex
    animation = doc["animations"][0]
    channels = animation["channels"]
    assert {c["target"]["path"] for c in channels} >= {"rotation", "weights"}
    rotated = {doc["nodes"][c["target"]["node"]]["name"] for c in channels if c["target"]["path"] == "rotation"}
    assert "index-finger-phalanx-proximal" in rotated
    curl = next(c for c in channels if c["target"]["path"] == "rotation"
                and doc["nodes"][c["target"]["node"]]["name"] == "middle-finger-phalanx-intermediate")
    quaternions = _glb_accessor(glb, doc, animation["samplers"][curl["sampler"]]["output"])
    assert np.degrees(2 * np.arccos(np.clip(np.abs(quaternions[:, 3]), 0, 1))).max() > 60     # the fist curls it
    morph = next(c for c in channels if c["target"]["path"] == "weights")
    played = _glb_accessor(glb, doc, animation["samplers"][morph["sampler"]]["output"]).reshape(-1, len(keys))
    bulges = played[:, [i for i, k in enumerate(keys) if k.startswith("FH.bulge.")]]
    assert bulges.max() > 0.3 and bulges[0].max() < 0.05     # the fist contracts what the open hand does not
    influences = np.array([sum(g.weight > 0 for g in v.groups) for v in obj.data.vertices])
    assert influences.max() <= 4                  # what glTF's JOINTS_0 holds and three.js plays
    obj.rotation_euler = (0.4, -0.2, 1.3)         # a hand the artist turned and moved
    obj.location = (0.3, -0.5, 1.1)
    frames = (1, 40, 70, 103)
    objects = addon_module("operators.adapters.export").export_objects(obj, addon_module("operators.hand.objects").EXPORT_ROLES)
    wanted, names = world_vertices(bpy, objects, frames), mesh_names(objects)
    fbx = services.export(bpy.context, obj, str(tmp_path / "hand.fbx"))
    glb = services.export(bpy.context, obj, str(tmp_path / "hand.glb"))
    for path in (fbx, glb):
        imported = reimport(bpy, path, 30)
        armature = next(o for o in imported if o.type == "ARMATURE")
        skin = next(o for o in imported if o.type == "MESH" and o.data.shape_keys is not None)
        assert skin.parent == armature and skin.modifiers[0].object == armature, path.suffix
        assert WEBXR_NAMES <= {b.name for b in armature.data.bones}, path.suffix
        assert WEBXR_NAMES <= {g.name for g in skin.vertex_groups}, path.suffix
        sums = np.array([sum(g.weight for g in v.groups) for v in skin.data.vertices])
        assert np.allclose(sums, 1.0, atol=2e-3) and max(len(v.groups) for v in skin.data.vertices) <= 4, path.suffix
        assert {k.name for k in skin.data.shape_keys.key_blocks} >= set(keys), path.suffix
        assert skin.data.shape_keys.animation_data.action is not None, path.suffix
        assert armature.animation_data is not None and armature.animation_data.action is not None, path.suffix
        errors = placement_errors(wanted, world_vertices(bpy, imported, [f - 1 for f in frames], names))
        assert max(errors.values()) <= 1e-4, (path.suffix, errors)


def test_retarget_onto_the_webxr_generic_hand(bpy_clean, installed):
    bpy = bpy_clean
    obj = _build(bpy)
    services = addon_module("operators.hand.services")
    services.animate(bpy.context, obj, "fist")
    services.bake(bpy.context, obj)
    before = {o.name for o in bpy.data.objects}
    bpy.ops.import_scene.gltf(filepath=str(installed.extension_dir / "assets/webxr/generic-hand/right.glb"))
    target = next(o for o in bpy.data.objects if o.name not in before and o.type == "ARMATURE")
    count = services.retarget(bpy.context, obj, target)
    assert count >= 20
    scene = bpy.context.scene
    scene.frame_set(scene.frame_end)
    source = _armature(obj).pose.bones["middle-finger-phalanx-intermediate"]
    bone = target.pose.bones["middle-finger-phalanx-intermediate"]
    def turned(pb, arm):
        rest = np.array(arm.matrix_world)[:3, :3] @ np.array(pb.bone.matrix_local)[:3, :3]
        posed = np.array(arm.matrix_world)[:3, :3] @ np.array(pb.matrix)[:3, :3]
        return posed @ rest.T
    assert np.allclose(turned(bone, target), turned(source, _armature(obj)), atol=1e-4)
    assert math.degrees(math.acos((np.trace(turned(bone, target)) - 1) / 2)) > 60     # the finger curled


def _armature_from_skeleton(bpy, skeleton):
    """A Blender armature with the engine skeleton's bones (heads, tails, rolls, parents)."""
    data = bpy.data.armatures.new(skeleton.name)
    arm = bpy.data.objects.new(skeleton.name, data)
    bpy.context.scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    for k, name in enumerate(skeleton.names):
        bone = data.edit_bones.new(name)
        bone.head, bone.tail, bone.roll = skeleton.heads[k], skeleton.tails[k], float(skeleton.rolls[k])
        if skeleton.parents[k] >= 0:
            bone.parent = data.edit_bones[skeleton.names[skeleton.parents[k]]]
    bpy.ops.object.mode_set(mode="OBJECT")
    return arm


def test_retarget_a_fist_onto_mpfb2_mixamo_and_vrm_hands(bpy_clean):
    """The fist keyed on the hand rig, retargeted onto MPFB2's game-engine and default skeletons, Mixamo's and a
    VRM-named one built as Blender armatures: every finger bone of the target turns as far relative to its
    wrist as the hand's bone does (within 2 degrees), and the fingers curl."""
    bpy = bpy_clean
    obj = _build(bpy)
    rig = addon_module("operators.adapters.rig_store").get_rig(obj, "hand")
    motion = addon_module("faces_hands_addon.hand.motion")
    rig.settled_stages(motion.pose_stages("fist", rig.muscle_names))
    services = addon_module("operators.hand.services")
    services.key_joint_angles(obj, rig, [1], [rig.joint_angles])
    body = addon_module("faces_hands_addon.character.body")
    built = addon_module("faces_hands_addon.character.skeleton")
    hands = addon_module("faces_hands_addon.character.hands")
    mesh = body.character_mesh()
    source = _armature(obj)
    bpy.context.scene.frame_set(1)

    def bends(arm, wrist):
        turn = {b.name: np.array(b.matrix)[:3, :3] @ np.array(b.bone.matrix_local)[:3, :3].T for b in arm.pose.bones}
        return {n: math.degrees(math.acos(np.clip((np.trace(turn[wrist].T @ t) - 1) / 2, -1, 1)))
                for n, t in turn.items()}

    for name in ("game_engine", "default", "mixamo", "vrm"):
        skeleton = built.build_skeleton("game_engine" if name == "vrm" else name, mesh)
        skeleton = hands.vrm_skeleton(skeleton) if name == "vrm" else skeleton
        target = _armature_from_skeleton(bpy, skeleton)
        count = services.retarget(bpy.context, obj, target, frames=[1])
        assert count == 16, name
        bpy.context.scene.frame_set(1)
        pairs = hands.hand_bone_pairs(skeleton, "R")
        mine, theirs = bends(source, "wrist"), bends(target, pairs["wrist"])
        for bone, other in pairs.items():
            assert theirs[other] == pytest.approx(mine[bone], abs=2.0), (name, bone, other)
        assert sum(mine[b] > 30 for b in pairs) >= 8, name
    stranger = built.build_skeleton("mixamo", mesh)
    keep = [k for k, n in enumerate(stranger.names) if "RightHandIndex" not in n and stranger.parents[k] < k]
    stranger = _armature_from_skeleton(bpy, type(stranger)(
        "stranger", [stranger.names[k] for k in keep], np.array([keep.index(stranger.parents[k])
                                                                 if stranger.parents[k] in keep else -1 for k in keep]),
        stranger.heads[keep], stranger.tails[keep], stranger.rolls[keep], stranger.connected[keep], stranger.rest[keep]))
    with pytest.raises(addon_module("faces_hands_addon.core.errors").UserError, match="retarget needs all 16"):
        services.retarget(bpy.context, obj, stranger, frames=[1])        # a hand without its index finger


def test_a_left_hand_is_mirrored_and_curls_the_same_way(bpy_clean):
    bpy = bpy_clean
    obj = _build(bpy, "left")
    live = addon_module("operators.bases.live")
    objects = addon_module("operators.hand.objects")
    rest = _evaluated(bpy, obj)
    assert rest[int(np.argmin(rest[:, 1])), 0] < -0.02        # the thumb tip: at +X on a right hand, -X here
    obj["fh.ctrl.flexor_digitorum_profundus_middle"] = 0.4
    for _ in range(20):
        live.live_step(bpy.context, obj, objects.push_hand_pose, dt=1 / 30)
    tip = int(np.argmin(rest[:, 2]))
    assert rest[tip, 0] - _evaluated(bpy, obj)[tip, 0] > 0.03     # its palm faces -X


def test_operators_refuse_bad_input_and_leave_the_scene(bpy_clean, tmp_path):
    bpy = bpy_clean
    obj = _build(bpy)
    bpy.context.view_layer.objects.active = obj
    before = _state(bpy)
    for call, message in ((lambda: bpy.ops.faces_hands.build_hand_from_photo(), "load a hand photo"),
                          (lambda: bpy.ops.faces_hands.solve_contractions(), "pose the hand first"),
                          (lambda: bpy.ops.faces_hands.export_hand(filepath=str(tmp_path / "hand.obj")), ".glb")):
        with pytest.raises(RuntimeError, match=message):        # the operator's ERROR report, in background mode
            call()
    assert _state(bpy) == before and not (tmp_path / "hand.obj").exists()
