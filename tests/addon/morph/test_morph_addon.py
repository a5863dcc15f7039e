"""Morphable faces through the installed add-on: new face, sliders with undo-able operators, the Fig. 3.8
experiment in Blender, segments, save/load, Build Model from Meshes (good and bad input), the CLI, and a
rendered contact sheet whose cells differ. The default model is the whole head on the character's topology;
the tests of the mask's own attributes (eyebrows, colour, the MediaPipe topology Make Animatable needs) ask
for the synthetic mask model ('mask') by name."""
from __future__ import annotations

import json
import re

import numpy as np
import pytest

from conftest import addon_module, run_fh

MASC, BROWS = "masculine-feminine", "eyebrows-eyes distance"


def _vertices(obj):
    out = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.attributes["position"].data.foreach_get("vector", out)
    return out.reshape(-1, 3)


def _new(bpy, model="mask", **kwargs):
    bpy.context.scene.faces_hands_morph.model_path = model
    assert bpy.ops.faces_hands.morph_new_face(**kwargs) == {"FINISHED"}
    obj = bpy.context.active_object
    assert obj.get("fh_morph") and (model != "mask" or len(obj.data.vertices) == 468)
    return obj


def test_the_default_model_is_the_characters_whole_head(bpy_clean):
    bpy = bpy_clean
    services = addon_module("operators.morph.services")
    heads = addon_module("faces_hands_addon.morph.heads")
    obj = _new(bpy, model="", kind="random", seed=5)
    model = services.face_of(obj).model
    assert model.info["topology"] == heads.TOPOLOGY and len(obj.data.vertices) == model.vertex_count > 4000
    sliders = {item.name: item for item in obj.faces_hands_morph.sliders}
    assert {MASC, "thin-full lips", "small-large ears"} <= set(sliders)
    before = _vertices(obj).copy()
    sliders["short-long nose"].shape = 1.5
    moved = np.linalg.norm(_vertices(obj) - before, axis=1)
    nose = model.segments["nose"]
    assert moved[nose].max() > 1e-3 and moved[model.segments["ears"]].max() < 1e-6    # the nose, not the ears
    colours = np.empty(len(obj.data.vertices) * 4, np.float32)
    obj.data.color_attributes["FH Albedo"].data.foreach_get("color", colours)
    assert 0.3 < colours.reshape(-1, 4)[:, :3].mean() < 0.9                         # skin, not black


@pytest.mark.smoke
def test_new_face_sliders_and_history(bpy_clean):
    bpy = bpy_clean
    services = addon_module("operators.morph.services")
    obj = _new(bpy)
    sliders = {item.name: item for item in obj.faces_hands_morph.sliders}
    assert {MASC, BROWS, "narrow-wide", "dark-light skin"} <= set(sliders)
    before = _vertices(obj).copy()
    sliders[MASC].shape = -1.0                    # the update calls faces_hands.morph_set_attribute
    moved = _vertices(obj)
    assert np.abs(moved - before).max() > 1e-3
    face = services.face_of(obj)
    assert abs(face.value(MASC) + 1.0) < 1e-9
    assert "masculine-feminine (shape) = -1.00" in obj["fh_morph_history"]
    colours = np.empty(468 * 4, np.float32)
    obj.data.color_attributes["FH Albedo"].data.foreach_get("color", colours)
    assert 0.05 < colours.reshape(-1, 4)[:, :3].mean() < 0.9


def test_fig_3_8_in_blender_constraint_keeps_masculinity(bpy_clean):
    bpy = bpy_clean
    services = addon_module("operators.morph.services")
    obj = _new(bpy)
    bpy.ops.faces_hands.morph_set_attribute(name=MASC, part="shape", value=-1.5)
    masculine = services.face_of(obj).value(MASC)
    bpy.ops.faces_hands.morph_constrain(name=MASC, part="shape")
    bpy.ops.faces_hands.morph_set_attribute(name=BROWS, part="shape", value=1.5)
    assert abs(services.face_of(obj).value(MASC) - masculine) < 1e-9
    other = _new(bpy)
    bpy.ops.faces_hands.morph_set_attribute(name=MASC, part="shape", value=-1.5)
    bpy.ops.faces_hands.morph_set_attribute(name=BROWS, part="shape", value=1.5)
    assert services.face_of(other).value(MASC) - masculine > 0.1      # less masculine without the constraint


def test_segment_edit_and_save_load(bpy_clean, tmp_path):
    bpy = bpy_clean
    services = addon_module("operators.morph.services")
    obj = _new(bpy, kind="random", seed=2)
    face = services.face_of(obj)
    for item in obj.faces_hands_morph.segments:
        item["selected"] = item.name == "mouth"
    before = _vertices(obj).copy()
    bpy.ops.faces_hands.morph_set_attribute(name="narrow-wide", part="shape", value=2.0)
    zone = face.blender.zone(face.model.segments["mouth"])
    after = _vertices(obj)
    assert np.array_equal(after[~zone], before[~zone]) and np.abs(after - before).max() > 1e-3
    path = tmp_path / "face.json"
    assert bpy.ops.faces_hands.morph_save_face(filepath=str(path)) == {"FINISHED"}
    saved = json.loads(path.read_text())
    assert saved["history"][-1]["segments"] == ["mouth"]
    fresh = _new(bpy)
    assert bpy.ops.faces_hands.morph_load_face(filepath=str(path)) == {"FINISHED"}
    assert np.abs(_vertices(fresh) - after).max() < 1e-6
    path.write_text("{not json")
    state = fresh["fh_morph_state"]
    with pytest.raises(RuntimeError, match="not a saved morphable face"):
        bpy.ops.faces_hands.morph_load_face(filepath=str(path))
    assert fresh["fh_morph_state"] == state


def _examples(bpy, count=5, seed=0):
    mesh_from_arrays = addon_module("operators.adapters.meshes").mesh_from_arrays
    assets = addon_module("faces_hands_addon.assets")
    base = assets.canonical_face()
    rng = np.random.default_rng(seed)
    objects = []
    for index in range(count):
        vertices = base.vertices + 0.003 * rng.standard_normal(base.vertices.shape)
        mesh = mesh_from_arrays(f"ex{index}", vertices, base.faces)
        obj = bpy.data.objects.new(f"ex{index}", mesh)
        bpy.context.scene.collection.objects.link(obj)
        obj.select_set(True)
        objects.append(obj)
    return objects


def test_build_model_from_meshes_with_labels_and_bad_input(bpy_clean, tmp_path):
    bpy = bpy_clean
    objects = _examples(bpy)
    labels = tmp_path / "labels.csv"
    labels.write_text("name,age\n" + "".join(f"ex{i},{20 + 7 * i}\n" for i in range(5)))
    out = tmp_path / "mine.npz"
    assert bpy.ops.faces_hands.morph_build_model(labels=str(labels), out=str(out)) == {"FINISHED"}
    assert out.is_file() and bpy.context.scene.faces_hands_morph.model_path == str(out)
    obj = _new(bpy, model=str(out))
    assert [item.name for item in obj.faces_hands_morph.sliders] == ["age"]
    names = sorted(o.name for o in bpy.data.objects)
    labels.write_text("name,age\nex0,1\nex1,2\n")
    out.unlink()
    for o in objects:
        o.select_set(True)
    with pytest.raises(RuntimeError, match="no row for 3 example"):
        bpy.ops.faces_hands.morph_build_model(labels=str(labels), out=str(out))
    mesh = objects[2].data
    mesh.vertices.add(1)
    with pytest.raises(RuntimeError, match="another topology"):
        bpy.ops.faces_hands.morph_build_model(out=str(out))
    assert not out.exists() and sorted(o.name for o in bpy.data.objects) == names


def test_contact_sheet_cells_differ(bpy_clean, tmp_path):
    bpy = bpy_clean
    sheet = addon_module("operators.morph.sheet")
    render = addon_module("operators.adapters.render")
    obj = _new(bpy)
    path = tmp_path / "sheet.png"
    sheet.render_sheet(bpy.context, obj, sheet.fig_3_8_cells(), path, cell_size=(160, 180), columns=5)
    image = render.read_png(path)
    cells = [image[:, i * 160:(i + 1) * 160, :3] for i in range(5)]
    assert all(np.abs(cells[0] - c).mean() > 1e-3 for c in cells[1:])


def test_cli_morph_fig_3_8_and_bad_input(installed, tmp_path):
    out = tmp_path / "face.glb"
    result = run_fh(installed, "morph", "--model", "mask", "--seed", "11", "--set", f"{MASC}@shape=-1.5",
                    "--constrain", MASC,
                    "--set", f"{BROWS}@shape=1.5", "--set", "mouth:narrow-wide@shape=-0.4",
                    "--sheet", tmp_path / "sheet.png", "--out", out)
    assert result.returncode == 0, result.stderr
    assert out.is_file() and out.read_bytes()[:4] == b"glTF"                  # also after a contact sheet
    assert (tmp_path / "sheet.png").read_bytes()[:4] == b"\x89PNG"
    kept = re.search(r"constraint masculine-feminine: shape \S+, now (\S+)", result.stdout)
    assert kept and abs(float(kept.group(1)) + 1.5) < 1e-6, result.stdout    # absolute, from a random face
    bad = tmp_path / "broken.h5"
    bad.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 20)
    result = run_fh(installed, "morph", "--model", bad, "--out", tmp_path / "x.glb")
    assert result.returncode == 1 and "broken.h5" in result.stderr and not (tmp_path / "x.glb").exists()
    result = run_fh(installed, "morph", "--set", "nonsense=1", "--out", tmp_path / "y.glb")
    assert result.returncode == 1 and "no attribute" in result.stderr


def test_cli_set_is_absolute_on_the_head_model(installed, tmp_path):
    out = tmp_path / "head.glb"
    result = run_fh(installed, "morph", "--seed", "11", "--set", f"{MASC}=0", "--constrain", MASC,
                    "--set", "thin-full lips=1.5", "--caricature", "1.5", "--out", out)
    assert result.returncode == 0, result.stderr
    kept = re.search(r"constraint masculine-feminine: shape \S+, now (\S+)", result.stdout)
    assert kept and abs(float(kept.group(1))) < 1e-6, result.stdout     # 0 from a random face, kept
    assert out.read_bytes()[:4] == b"glTF"
    body = tmp_path / "character.glb"
    result = run_fh(installed, "morph", "--seed", "2", "--character", "--out", body)
    assert result.returncode == 0, result.stderr
    data = body.read_bytes()
    length = int.from_bytes(data[12:16], "little")
    gltf = json.loads(data[20:20 + length])
    positions = [p["attributes"]["POSITION"] for m in gltf["meshes"] for p in m["primitives"]]
    assert sum(gltf["accessors"][i]["count"] for i in positions) >= 13886          # the whole body
    result = run_fh(installed, "morph", "--model", "mask", "--character", "--out", tmp_path / "no.glb")
    assert result.returncode == 1 and "topology" in result.stderr and not (tmp_path / "no.glb").exists()


def test_thumbnails_of_filtered_examples(bpy_clean):
    bpy = bpy_clean
    obj = _new(bpy)
    settings = bpy.context.scene.faces_hands_morph
    settings.filter_sex, settings.filter_population = "female", "Asian"
    assert bpy.ops.faces_hands.morph_render_thumbnails(count=3) == {"FINISHED"}
    examples = {i: labels for i, _, labels in json.loads(obj["fh_morph_examples"])}
    images = [im for im in bpy.data.images if im.name.startswith("FH Example ")]
    assert len(images) == 3 and all(im.size[:] == (96, 96) and im.packed_file for im in images)
    for image in images:
        labels = examples[int(image.name.split()[-1])]
        assert labels["sex"] == "female" and labels["population"] == "Asian"
    pixels = [np.array(im.pixels[:]).reshape(96, 96, 4)[:, :, :3] for im in images]
    assert np.abs(pixels[0] - pixels[1]).mean() > 1e-3


def test_stored_state_wins_after_undo_and_history_replays(bpy_clean):
    bpy = bpy_clean
    services = addon_module("operators.morph.services")
    obj = _new(bpy)
    bpy.ops.faces_hands.morph_set_attribute(name=MASC, part="shape", value=1.0)
    earlier, vertices = obj["fh_morph_state"], _vertices(obj).copy()
    bpy.ops.faces_hands.morph_set_attribute(name="narrow-wide", part="shape", value=-2.0)
    obj["fh_morph_state"] = earlier               # what Blender's undo restores (with the mesh)
    face = services.face_of(obj)
    assert np.abs(face.shape - vertices).max() < 1e-6 and abs(face.value(MASC) - 1.0) < 1e-9
    assert bpy.ops.faces_hands.morph_undo_edit() == {"FINISHED"}
    assert abs(services.face_of(obj).value(MASC)) < 1e-9


def test_make_animatable_builds_a_face_rig_on_the_morphed_face(bpy_clean):
    bpy = bpy_clean
    obj = _new(bpy, kind="random", seed=1)
    morphed = _vertices(obj).copy()
    assert bpy.ops.faces_hands.morph_make_animatable() == {"FINISHED"}
    rig = bpy.context.active_object
    assert rig is not obj and rig.get("fh_rig") and "fh.ctrl.jaw_open" in rig.keys()
    assert np.abs(_vertices(rig) - morphed).max() < 1e-6
    assert sorted(c.get("fh_part") for c in rig.children) == ["eye_L", "eye_R", "jaw", "muscles", "skull",
                                                               "teeth_lower", "teeth_upper", "tongue"]


def test_morph_panels_draw(bpy_clean):
    from types import SimpleNamespace

    from ui_layout import CheckedLayout
    bpy = bpy_clean

    _new(bpy)
    for name in ("FH_PT_morph", "FH_PT_morph_attributes", "FH_PT_morph_segments", "FH_PT_morph_constraints"):
        cls = getattr(bpy.types, name)
        log = []
        assert not hasattr(cls, "poll") or cls.poll(bpy.context)
        cls.draw(SimpleNamespace(layout=CheckedLayout(bpy, log)), bpy.context)
        assert log, name
        if name == "FH_PT_morph_attributes":
            props = [c[1][1] for c in log if c[0] == "prop"]
            assert props.count("shape") >= 30 and "colour" in props
            assert {c[2].get("text") for c in log if c[0] == "label"} >= {"Overall", "Eyes", "Nose", "Mouth"}


def test_new_face_with_a_bad_model_file_changes_nothing(bpy_clean, tmp_path):
    bpy = bpy_clean
    _new(bpy)
    before = sorted(o.name for o in bpy.data.objects), len(bpy.data.meshes)
    bad = tmp_path / "model.npz"
    bad.write_bytes(b"PK\x03\x04 truncated")
    nan = tmp_path / "nan.mat"
    from scipy.io import savemat
    savemat(nan, {"shapeMU": np.full((30, 1), np.nan), "shapePC": np.eye(30)[:, :2], "shapeEV": np.ones((2, 1)),
                  "tl": np.array([[1, 2, 3]])})
    for path, message in ((bad, "not a readable .npz"), (nan, "NaN"), (tmp_path / "none.h5", "does not exist")):
        bpy.context.scene.faces_hands_morph.model_path = str(path)
        with pytest.raises(RuntimeError, match=message):
            bpy.ops.faces_hands.morph_new_face()
        assert (sorted(o.name for o in bpy.data.objects), len(bpy.data.meshes)) == before


def test_a_morph_head_reshapes_the_characters_head(bpy_clean):
    bpy = bpy_clean
    body_mesh = addon_module("operators.character.objects").body_mesh
    character = addon_module("faces_hands_addon.character.body").character_mesh()
    services = addon_module("operators.morph.services")
    body = bpy.data.objects.new("Body", body_mesh("Body", character))
    bpy.context.scene.collection.objects.link(body)
    head = _new(bpy, model="", kind="random", seed=3)
    model = services.face_of(head).model
    local = addon_module("faces_hands_addon.morph.heads").character_ids(model, character.base_index)
    wrong = bpy.data.objects.new("Wrong", bpy.data.meshes.new("Wrong"))
    wrong.data.vertices.add(12)
    bpy.context.scene.collection.objects.link(wrong)
    for other, message in ((wrong, "not the character's topology"), (None, "select the character's body")):
        for o in bpy.context.selected_objects:
            o.select_set(False)
        if other is not None:
            other.select_set(True)
        head.select_set(True)
        bpy.context.view_layer.objects.active = head
        with pytest.raises(RuntimeError, match=message):
            bpy.ops.faces_hands.morph_link_character()
        assert body.data.shape_keys is None and not head.get("fh_morph_character")
    body.select_set(True)
    assert bpy.ops.faces_hands.morph_link_character() == {"FINISHED"}

    def keyed():
        out = np.empty(len(body.data.vertices) * 3, np.float32)
        body.data.shape_keys.key_blocks["FH Morph Head"].data.foreach_get("co", out)
        return out.reshape(-1, 3)
    assert np.abs(keyed()[local] - _vertices(head)).max() < 1e-6
    rest = np.setdiff1d(np.arange(len(character.vertices)), local)
    assert np.abs(keyed()[rest] - character.vertices[rest]).max() < 1e-6     # the body stays
    before = keyed().copy()
    next(i for i in head.faces_hands_morph.sliders if i.name == "narrow-wide jaw").shape = 2.0
    assert np.abs(keyed()[local] - _vertices(head)).max() < 1e-6 and np.abs(keyed() - before).max() > 1e-3
    assert bpy.ops.faces_hands.morph_new_face(kind="example", index=4) == {"FINISHED"}   # a new face keeps it
    example = bpy.context.active_object
    assert example is not head and np.abs(keyed()[local] - _vertices(example)).max() < 1e-6
