"""The default character through the installed add-on (issue 35): one armature with the skinned body, the
face's shape keys on the body mesh (one mesh), the head's turn on the neck and head bones arriving in the
exported glTF as those joints' rotation, the FBX re-imported with bones, weights and keys, and bad input
refused with the scene unchanged."""
from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest

from conftest import addon_module

FLOATS = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}


@pytest.fixture(scope="module")
def character(installed):
    """One character for the module (the face fit is the costly part): built without hand rigs."""
    import bpy
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    assert bpy.ops.faces_hands.add_character(skeleton="game_engine", hands=False) == {"FINISHED"}
    body = bpy.data.objects["FH Character"]
    yield bpy, body
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)


def _glb(path: Path):
    blob = path.read_bytes()
    length = struct.unpack_from("<I", blob, 12)[0]
    doc = json.loads(blob[20:20 + length])
    binary = blob[20 + length + 8:]

    def accessor(index: int) -> np.ndarray:
        a = doc["accessors"][index]
        view = doc["bufferViews"][a["bufferView"]]
        assert a["componentType"] == 5126
        width = FLOATS[a["type"]]
        start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
        return np.frombuffer(binary, "<f4", a["count"] * width, start).reshape(a["count"], width)
    return doc, accessor


def _quat_matrix(q):
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def test_one_armature_one_body_mesh(character):
    bpy, body = character
    arm = body.parent
    assert arm.type == "ARMATURE" and arm.parent is None and body.modifiers["Armature"].object == arm
    assert {"neck_01", "head", "hand_l", "index_03_r"} <= {b.name for b in arm.data.bones}
    assert body.get("fh_rig_kind") == "character" and len(body.data.uv_layers) == 1
    meshes = [o for o in bpy.data.objects if o.type == "MESH"]
    assert meshes == [body]                              # eyes, teeth, tongue are the body's own
    assert [m.name for m in body.data.materials] == ["FH Character Skin", "FH Character Eye", "FH Character Teeth",
                                                    "FH Character Tongue"]
    assert {"head", "neck_01", "spine_03"} <= set(body.vertex_groups.keys())


def _baked(bpy, body):
    """Two of the face's expressions baked into shape keys of the body (once per module)."""
    if body.data.shape_keys is None or "jawOpen" not in body.data.shape_keys.key_blocks:
        bake = addon_module("operators.bases.bake")
        jobs = addon_module("operators.bases.jobs")
        expressions = {"jawOpen": {"jaw_open": 1.0}, "eyeBlinkLeft": {"eyelid_close_L": 1.0}}
        inputs = bake.bake_inputs(bpy.context, body, animated=False)
        jobs.run_job(bake.BakeJob(inputs, "EXPRESSIONS", expressions), bpy.context)
    return body.data.shape_keys.key_blocks


def test_head_shape_keys_live_on_the_body_mesh(character):
    bpy, body = character
    keys = _baked(bpy, body)
    assert {"jawOpen", "eyeBlinkLeft"} <= set(keys.keys())
    n = len(body.data.vertices)
    rest, jaw = np.empty(3 * n, np.float32), np.empty(3 * n, np.float32)
    keys[0].points.foreach_get("co", rest)
    keys["jawOpen"].points.foreach_get("co", jaw)
    moved = np.linalg.norm((jaw - rest).reshape(-1, 3), axis=1)
    z = rest.reshape(-1, 3)[:, 2]
    assert moved.max() > 0.02 and moved[z < 1.3].max() == 0.0       # the face moves, the body below not


def test_head_rotation_arrives_on_the_neck_bones_in_the_export(character, tmp_path):
    """head_yaw keyed on the behaviour layer: the exported clip turns the head joint about the up axis by
    the whole turn (neck and head bones together), and nothing else of the body."""
    bpy, body = character
    export = addon_module("operators.adapters.export")
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 0, 10
    body["fh.behavior.head_yaw"] = 0.0
    body.keyframe_insert('["fh.behavior.head_yaw"]', frame=0)
    body["fh.behavior.head_yaw"] = 0.3
    body.keyframe_insert('["fh.behavior.head_yaw"]', frame=10)
    out = export.export_rig(bpy.context, body, str(tmp_path / "turn.glb"), ())
    doc, accessor = _glb(out)
    names = [n.get("name") for n in doc["nodes"]]
    channels = {(names[c["target"]["node"]], c["target"]["path"]): doc["animations"][0]["samplers"][c["sampler"]]
                for c in doc["animations"][0]["channels"]}
    parent = {child: k for k, node in enumerate(doc["nodes"]) for child in node.get("children", [])}

    def world(node: int, last: bool) -> np.ndarray:
        rotation = np.eye(3)
        while node is not None:
            sampler = channels.get((names[node], "rotation"))
            q = accessor(sampler["output"])[-1 if last else 0] if sampler else doc["nodes"][node].get(
                "rotation", [0, 0, 0, 1])
            rotation = _quat_matrix(q) @ rotation
            node = parent.get(node)
        return rotation
    head = names.index("head")
    turn = world(head, True) @ world(head, False).T                   # glTF: Y up, the face along +Z
    angle = np.degrees(np.arctan2(turn[0, 2], turn[0, 0]))
    assert abs(abs(angle) - np.degrees(0.3)) < 1.0, angle
    assert abs(turn[1, 1] - 1.0) < 1e-3                              # about the vertical axis only
    neck = names.index("neck_01")
    assert np.degrees(np.arccos(np.clip((np.trace(world(neck, True) @ world(neck, False).T) - 1) / 2, -1, 1))) > 5
    pelvis = names.index("pelvis")
    np.testing.assert_allclose(world(pelvis, True), world(pelvis, False), atol=1e-5)


def test_fbx_reimports_with_bones_weights_and_keys(character, tmp_path):
    bpy, body = character
    _baked(bpy, body)
    export = addon_module("operators.adapters.export")
    out = export.export_rig(bpy.context, body, str(tmp_path / "character.fbx"), ())
    before = set(bpy.data.objects)
    bpy.ops.import_scene.fbx(filepath=str(out))
    new = [o for o in bpy.data.objects if o not in before]
    armature = next(o for o in new if o.type == "ARMATURE")
    mesh = next(o for o in new if o.type == "MESH")
    assert {"neck_01", "head"} <= {b.name for b in armature.data.bones}
    assert "head" in mesh.vertex_groups and mesh.data.shape_keys is not None
    assert {"jawOpen", "eyeBlinkLeft"} <= set(mesh.data.shape_keys.key_blocks.keys())
    for obj in new:
        bpy.data.objects.remove(obj)


def test_head_turn_retargets_onto_a_mixamo_skeleton(character):
    """The bone map carries the head's turn onto an armature named like Mixamo's, as the same world turn."""
    bpy, body = character
    from faces_hands_addon.character.body import character_mesh
    from faces_hands_addon.character.skeleton import build_skeleton
    retarget = addon_module("operators.character.retarget")
    objects = addon_module("operators.character.objects")
    target = objects.create_armature(bpy.context, build_skeleton("mixamo", character_mesh()), "Mixamo",
                                     bpy.context.scene.collection)
    scene = bpy.context.scene
    body["fh.behavior.head_yaw"] = 0.3
    body.keyframe_insert('["fh.behavior.head_yaw"]', frame=5)
    keyed = retarget.retarget_animation(bpy.context, body.parent, target, [5])
    assert keyed >= 20                                              # spine, neck, head, arms, fingers
    scene.frame_set(5)
    turned = np.array(target.pose.bones["mixamorig:Head"].matrix)[:3, :3] @ \
        np.array(target.data.bones["mixamorig:Head"].matrix_local)[:3, :3].T
    source = np.array(body.parent.pose.bones["head"].matrix)[:3, :3] @ \
        np.array(body.parent.data.bones["head"].matrix_local)[:3, :3].T
    np.testing.assert_allclose(turned, source, atol=1e-4)
    assert np.degrees(np.arccos((np.trace(turned) - 1) / 2)) > 10


def test_a_takes_glb_from_the_still_export_and_the_engines_clip_is_blenders_export(character, tmp_path):
    """A take on the character written as its still GLB plus the bake's clip (``adapters.take_export``, no
    per-frame sampling) against Blender's own exporter sampling the same scene: the same nodes at the same
    rest, the same morph targets, the same key times, the skin's weights bit for bit, the neck and head
    bones' rotations to 0.005 degrees, and no other joint moving in Blender's file. A head turn the
    clip left out, or a weight put on the wrong target, fails here. A shape key of the artist's, neither
    keyed nor driven, keeps its weight (0.25) as Blender writes it; once keyed, Blender's exporter writes
    the take."""
    bpy, body = character
    performance = addon_module("faces_hands_addon.performance")
    perform, take_of = performance.perform, performance.take_of
    take_from_text = addon_module("faces_hands_addon.speech.takes").take_from_text
    services = addon_module("operators.speech.services")
    apply = addon_module("operators.speech.apply")
    bake = addon_module("operators.bases.bake")
    jobs = addon_module("operators.bases.jobs")
    export = addon_module("operators.adapters.export")
    roles = addon_module("operators.face.objects").EXPORT_ROLES
    if body.animation_data is not None:
        body.animation_data.action = None                       # an earlier test's keys
    if body.data.shape_keys is None or "Artist Key" not in body.data.shape_keys.key_blocks:
        body.shape_key_add(name="Basis" if body.data.shape_keys is None else "Artist Key", from_mix=False)
        if "Artist Key" not in body.data.shape_keys.key_blocks:
            body.shape_key_add(name="Artist Key", from_mix=False)
    body.data.shape_keys.key_blocks["Artist Key"].value = 0.25
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 30, 1.0
    scene.frame_start = 0
    take = perform(take_from_text("Well, maybe not.", fps=30.0), style="expressive", seed=4)
    apply.apply_take(scene, body, take, start_frame=0)
    scene.frame_end = int(np.ceil(take.duration * 30))
    engine_take = take_of(take)
    assert len(engine_take.head) and max(np.ptp(t.values) for t in engine_take.head) > 0.01
    targets = {"jawOpen": {"jaw_open": 1.0}, "mouthClose": {"orbicularis_oris_upper": 1.0}}
    job = bake.WeightsBakeJob.of_object(bpy.context, body, targets, roles, correctives=False,
                                        take=(engine_take, 0))
    jobs.run_job(job, bpy.context)
    ours = services._save_take(body, tmp_path / "take.glb", (job, engine_take))
    theirs = export.save_or_export(bpy.context, body, tmp_path / "blender.glb", roles,
                                   export.ExportOptions(clip="take"))
    (doc, ours_at), (ref, ref_at) = _glb(ours), _glb(theirs)
    assert len(doc["animations"][0]["channels"]) == 3          # the skin's weights, neck_01 and head
    artist = doc["meshes"][0]["extras"]["targetNames"].index("Artist Key")

    def clip(document, accessor):
        names = [n.get("name") for n in document["nodes"]]
        animation = document["animations"][0]
        return animation["name"], {(names[c["target"]["node"]], c["target"]["path"]): (
            accessor(animation["samplers"][c["sampler"]]["input"]).ravel(),
            accessor(animation["samplers"][c["sampler"]]["output"])) for c in animation["channels"]}
    name, channels = clip(doc, ours_at)
    ref_name, ref_channels = clip(ref, ref_at)
    assert name == ref_name == "take"
    assert [n.get("name") for n in doc["nodes"]] == [n.get("name") for n in ref["nodes"]]
    for node, ref_node in zip(doc["nodes"], ref["nodes"]):
        assert {k: node.get(k) for k in ("translation", "rotation", "scale")} == \
               {k: ref_node.get(k) for k in ("translation", "rotation", "scale")}
    assert doc["meshes"][0]["extras"]["targetNames"] == ref["meshes"][0]["extras"]["targetNames"]
    for key, (times, values) in channels.items():
        ref_times, ref_values = ref_channels[key]
        assert np.array_equal(times, ref_times), key
        if key[1] == "weights":
            assert np.array_equal(values, ref_values)
        else:
            # Blender keeps the head's keys as float32 (frame, value) pairs and interpolates those; the clip
            # samples the take's float64 track: 2e-5 of a unit quaternion is 0.002 degrees
            np.testing.assert_allclose(values, ref_values, atol=5e-5, err_msg=str(key))
    assert np.ptp(channels[("head", "rotation")][1], axis=0).max() > 1e-3   # the head does turn
    count = len(doc["meshes"][0]["extras"]["targetNames"])
    assert np.all(channels[("FH Character", "weights")][1].reshape(-1, count)[:, artist] == np.float32(0.25))
    names = [n.get("name") for n in ref["nodes"]]
    for key, (_, values) in ref_channels.items():
        if key not in channels:
            rest = ref["nodes"][names.index(key[0])].get(
                key[1], {"rotation": [0, 0, 0, 1], "translation": [0, 0, 0], "scale": [1, 1, 1]}[key[1]])
            np.testing.assert_allclose(values, np.broadcast_to(rest, values.shape), atol=1e-6, err_msg=str(key))
    blink = body.data.shape_keys.key_blocks["Artist Key"]          # keyed now: the clip cannot know it
    blink.value = 0.0
    blink.keyframe_insert("value", frame=0)
    blink.value = 1.0
    blink.keyframe_insert("value", frame=5)
    keyed, _ = _glb(services._save_take(body, tmp_path / "keyed.glb", (job, engine_take)))
    assert len(keyed["animations"][0]["channels"]) > 3               # Blender's exporter took it


def test_render_draws_a_sheet_of_the_characters_head(character, installed, tmp_path):
    """``faces_hands render --blend`` on a saved character draws its head (it refused: "no Faces & Hands face
    rig in this file"); the open jaw differs from the neutral cell."""
    from conftest import run_fh
    bpy, _ = character
    blend, png = tmp_path / "character.blend", tmp_path / "sheet.png"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend), copy=True)
    result = run_fh(installed, "render", "--blend", blend, "--cells", "neutral,jawOpen", "--columns", "2",
                    "--out", png)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    image = addon_module("operators.adapters.render").read_png(png)[:, :, :3]
    neutral, open_jaw = image[:, :image.shape[1] // 2], image[:, image.shape[1] // 2:]
    assert (neutral < 0.9).mean() > 0.05 and np.abs(neutral - open_jaw).mean() > 0.003
