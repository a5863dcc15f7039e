"""The face rig through the installed add-on: build, live step, bakes, export and re-import."""
from __future__ import annotations

import json
import struct

import numpy as np
import pytest

from conftest import addon_module, run_fh


def _build(bpy):
    assert bpy.ops.faces_hands.build_face_rig() == {"FINISHED"}
    rig = bpy.context.active_object
    assert rig.get("fh_rig") and rig.type == "MESH"
    return rig


def _glb_json(path):
    data = path.read_bytes()
    length = struct.unpack_from("<I", data, 12)[0]
    return json.loads(data[20:20 + length])


def _scene_state(bpy):
    """Everything a cancelled or refused operator must leave as it was: objects, their custom properties,
    shape keys (names and values), actions, drivers, the current frame."""
    state = {"frame": bpy.context.scene.frame_current, "actions": sorted(a.name for a in bpy.data.actions),
             "objects": {}}
    for obj in bpy.data.objects:
        keys = obj.data.shape_keys if obj.type == "MESH" else None
        state["objects"][obj.name] = {
            "props": {k: (repr(obj[k]) if k != "fh_rig_data" else len(obj[k])) for k in obj.keys()},
            "shape_keys": [(b.name, b.value, b.mute) for b in keys.key_blocks] if keys else None,
            "drivers": len(keys.animation_data.drivers) if keys and keys.animation_data else 0,
            "matrix": [list(row) for row in obj.matrix_basis]}
    return state


@pytest.mark.smoke
def test_build_default_rig_objects_and_controls(bpy_clean):
    bpy = bpy_clean
    rig = _build(bpy)
    roles = sorted(child.get("fh_part") for child in rig.children)
    assert roles == ["eye_L", "eye_R", "jaw", "muscles", "skull", "teeth_lower", "teeth_upper", "tongue"]
    controls = [k for k in rig.keys() if k.startswith("fh.ctrl.")]
    assert len(controls) >= 24 + 12
    for name in ("zygomaticus_major_L", "orbicularis_oris_upper", "jaw_open", "eyelid_close_R"):
        assert f"fh.ctrl.{name}" in rig.keys()
    assert rig.data.shape_keys is None, "building must not add shape keys to the skin"
    # brows and lips painted on the generated skin, shown by its material and by Workbench renders
    paint = rig.data.color_attributes["FH Skin Paint"]
    colours = np.zeros(len(rig.data.vertices) * 4, np.float32)
    paint.data.foreach_get("color", colours)
    assert colours.reshape(-1, 4)[:, :3].sum(axis=1).min() < 0.1 < np.median(colours.reshape(-1, 4)[:, 0])
    shader = rig.data.materials[0].node_tree.nodes["Principled BSDF"]
    assert shader.inputs["Base Color"].links[0].from_node.attribute_name == "FH Skin Paint"


def test_live_step_moves_only_the_simulation_key(bpy_clean):
    bpy = bpy_clean
    rig = _build(bpy)
    live = addon_module("operators.bases.live")
    base = np.array([v.co[:] for v in rig.data.vertices])
    rig["fh.ctrl.jaw_open"] = 1.0
    for _ in range(20):
        live.live_step(bpy.context, rig)
    sim = rig.data.shape_keys.key_blocks["FH Simulation"]
    moved = np.array([p.co[:] for p in sim.points])
    assert np.abs(moved - base).max() > 0.005, "jaw open did not move the skin"
    assert np.allclose(np.array([v.co[:] for v in rig.data.vertices]), base), "base mesh changed"
    teeth = next(c for c in rig.children if c.get("fh_part") == "teeth_lower")
    matrix = np.array([list(row) for row in teeth.matrix_basis])
    rig_engine = addon_module("operators.adapters.rig_store").get_rig(rig)
    assert np.allclose(matrix, rig_engine.rigid_transforms()["teeth_lower"], atol=1e-6), "teeth transform mangled"
    assert matrix[2, 3] < -0.005, "lower teeth did not drop with the jaw"


def test_live_simulation_operator_without_window_is_refused_and_changes_nothing(bpy_clean):
    bpy = bpy_clean
    rig = _build(bpy)
    before = _scene_state(bpy)
    with pytest.raises(RuntimeError, match="live simulation needs a Blender window"):
        bpy.ops.faces_hands.live_simulation("INVOKE_DEFAULT")
    assert bpy.context.window_manager.faces_hands_runtime.live_object == ""
    assert rig.data.shape_keys is None, "a refused live simulation created the simulation key"
    assert _scene_state(bpy) == before


def test_bake_basis_keys_are_driven(bpy_clean):
    bpy = bpy_clean
    rig = _build(bpy)
    assert bpy.ops.faces_hands.bake_face(mode="BASIS") == {"FINISHED"}
    blocks = rig.data.shape_keys.key_blocks
    assert "FH.zygomaticus_major_L" in blocks and "FH.jaw_open" in blocks
    rig["fh.ctrl.jaw_open"] = 0.5
    rig["fh.speech.jaw_open"] = 0.25  # layers add up
    rig.update_tag()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    depsgraph.update()
    evaluated = rig.data.shape_keys.evaluated_get(depsgraph).key_blocks
    assert evaluated["FH.jaw_open"].value == pytest.approx(0.75)
    rig["fh.speech.jaw_open"] = 1.0  # the sum is clamped by the key's slider range
    rig.update_tag()
    depsgraph.update()
    assert rig.data.shape_keys.evaluated_get(depsgraph).key_blocks["FH.jaw_open"].value == pytest.approx(1.0)
    teeth = next(c for c in rig.children if c.get("fh_part") == "teeth_lower")
    assert "FH.jaw_open" in teeth.data.shape_keys.key_blocks


def test_bake_expressions_export_glb_and_reimport(bpy_clean, tmp_path):
    bpy = bpy_clean
    rig = _build(bpy)
    assert bpy.ops.faces_hands.bake_face(mode="EXPRESSIONS", expression_set="visemes") == {"FINISHED"}
    names = [b.name for b in rig.data.shape_keys.key_blocks][1:]
    assert "viseme_PP" in names and "viseme_aa" in names and len(names) == 15
    out = tmp_path / "face.glb"
    assert bpy.ops.faces_hands.export_face(filepath=str(out)) == {"FINISHED"}
    doc = _glb_json(out)
    target_names = [m.get("extras", {}).get("targetNames") for m in doc["meshes"]]
    assert names in target_names
    skin = doc["meshes"][target_names.index(names)]
    assert all("COLOR_0" in p["attributes"] for p in skin["primitives"]), "the painted brows and lips are lost"
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=str(out))
    imported = [o for o in bpy.data.objects if o.type == "MESH" and o.data.shape_keys
                and len(o.data.shape_keys.key_blocks) == 16]
    assert imported and [b.name for b in imported[0].data.shape_keys.key_blocks][1:] == names


def _key_jaw(bpy, rig):
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 8
    rig["fh.ctrl.jaw_open"] = 0.0
    rig.keyframe_insert('["fh.ctrl.jaw_open"]', frame=1)
    rig["fh.ctrl.jaw_open"] = 1.0
    rig.keyframe_insert('["fh.ctrl.jaw_open"]', frame=8)


def _weight_curves(key) -> dict:
    bag = addon_module("operators.adapters.fcurves").existing_channelbag(key)
    assert bag is not None, "the shape keys carry no animation"
    curves = {}
    for curve in bag.fcurves:
        name = curve.data_path.split('"')[1]
        curves[name] = np.array([curve.evaluate(f) for f in range(1, 9)])
    return curves


def test_bake_animation_as_weights_round_trips_through_glb_and_fbx(bpy_clean, tmp_path):
    bpy = bpy_clean
    rig = _build(bpy)
    _key_jaw(bpy, rig)
    assert bpy.ops.faces_hands.bake_face(mode="ANIMATION") == {"FINISHED"}
    key = rig.data.shape_keys
    names = [b.name for b in key.key_blocks][1:]
    assert not [n for n in names if n.startswith("FH.frame_")]       # no per-frame targets
    assert "jawOpen" in names and "viseme_aa" in names
    baked = _weight_curves(key)
    moving = {n: c for n, c in baked.items() if np.ptp(c) > 0.05}
    assert moving, "no weight moves although the jaw opens"
    out = tmp_path / "anim.glb"
    assert bpy.ops.faces_hands.export_face(filepath=str(out)) == {"FINISHED"}
    doc = _glb_json(out)
    assert len(doc["animations"]) == 1                                # one clip for the take
    paths = {c["target"]["path"] for c in doc["animations"][0]["channels"]}
    assert paths == {"weights"}
    for mesh in doc["meshes"]:
        assert not [n for n in mesh.get("extras", {}).get("targetNames", []) if n.startswith("FH Simulation")]
    fbx = tmp_path / "anim.fbx"
    assert bpy.ops.faces_hands.export_face(filepath=str(fbx)) == {"FINISHED"}
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.import_scene.fbx(filepath=str(fbx))
    skin = max((o for o in bpy.data.objects if o.type == "MESH" and o.data.shape_keys),
               key=lambda o: len(o.data.vertices))
    imported = [b.name for b in skin.data.shape_keys.key_blocks][1:]
    assert set(names) <= set(imported)
    back = _weight_curves(skin.data.shape_keys)
    for name, curve in moving.items():                                # the weights animation round-trips
        assert np.abs(back[name] - curve).max() < 0.02, name


def test_bake_animation_as_frames_keeps_the_exact_cache(bpy_clean, tmp_path):
    bpy = bpy_clean
    rig = _build(bpy)
    _key_jaw(bpy, rig)
    assert bpy.ops.faces_hands.bake_face(mode="FRAMES") == {"FINISHED"}
    blocks = rig.data.shape_keys.key_blocks
    frames = [b.name for b in blocks if b.name.startswith("FH.frame_")]
    assert len(frames) == 8
    sim = np.array([p.co[:] for p in blocks[frames[-1]].points])
    rest = np.array([p.co[:] for p in blocks[frames[0]].points])
    assert np.abs(sim - rest).max() > 0.005
    out = tmp_path / "cache.glb"
    assert bpy.ops.faces_hands.export_face(filepath=str(out)) == {"FINISHED"}
    doc = _glb_json(out)
    assert any(len(m.get("extras", {}).get("targetNames", [])) == 8 for m in doc["meshes"])


def test_bake_animation_with_nothing_animated_is_refused(bpy_clean):
    bpy = bpy_clean
    rig = _build(bpy)
    def keys():
        return [b.name for b in rig.data.shape_keys.key_blocks] if rig.data.shape_keys else []
    before = keys()
    with pytest.raises(RuntimeError, match="nothing is animated"):
        bpy.ops.faces_hands.bake_face(mode="ANIMATION")
    assert keys() == before


def test_bake_cancelled_half_way_leaves_the_scene_as_it_was(bpy_clean):
    bpy = bpy_clean
    rig = _build(bpy)
    rig["fh.ctrl.jaw_open"] = 0.3                                   # the artist's work before the bake
    rig.keyframe_insert('["fh.ctrl.jaw_open"]', frame=1)
    bpy.context.scene.frame_set(3)
    before = _scene_state(bpy)
    services = addon_module("operators.face.services")
    job = services.bake_job(bpy.context, rig, "EXPRESSIONS", "visemes")
    progress = [job.step() for _ in range(5)]
    assert len(job.shapes) == 5 and 0 < progress[-1] < 1, "the job did no work before the cancel"
    job.cleanup()                                                   # what ESC does
    assert _scene_state(bpy) == before
    # the same job run to its end does change the scene: the comparison above can fail
    job = services.bake_job(bpy.context, rig, "EXPRESSIONS", "visemes")
    addon_module("operators.bases.jobs").run_job(job, bpy.context)
    assert _scene_state(bpy) != before and "viseme_PP" in rig.data.shape_keys.key_blocks


def test_cli_bake_and_render(installed, tmp_path):
    blend = tmp_path / "head.blend"
    result = run_fh(installed, "build-face", "--out", blend)
    assert result.returncode == 0, result.stderr[-2000:]
    glb = tmp_path / "visemes.glb"
    result = run_fh(installed, "bake", "--blend", blend, "--mode", "expressions", "--preset", "visemes",
                    "--out", glb)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "viseme_PP" in json.dumps(_glb_json(glb))
    bad = run_fh(installed, "bake", "--blend", tmp_path / "missing.blend", "--mode", "basis", "--out",
                 tmp_path / "x.glb")
    assert bad.returncode == 1 and "does not exist" in bad.stderr and not (tmp_path / "x.glb").exists()
