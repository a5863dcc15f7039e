"""Blender conventions: menus (File > Export, Add, Object), one-line tooltips, every property described,
undo, the preferences page, and the export options of File > Export."""
from __future__ import annotations

import json
import struct
from types import SimpleNamespace

import pytest

from conftest import addon_module
from ui_layout import CheckedLayout


def _operators(bpy):
    classes = addon_module("operators").CLASSES
    for cls in classes:
        if issubclass(cls, bpy.types.Operator):
            module, name = cls.bl_idname.split(".")
            yield cls, getattr(getattr(bpy.ops, module), name).get_rna_type()


def test_every_tooltip_is_one_clean_line(bpy_clean):
    bpy = bpy_clean
    classes = addon_module("operators").CLASSES + addon_module("panels").CLASSES
    checked = 0
    for cls in classes:
        description = cls.bl_rna.description if not issubclass(cls, bpy.types.Operator) else None
        if issubclass(cls, bpy.types.Operator):
            module, name = cls.bl_idname.split(".")
            description = getattr(getattr(bpy.ops, module), name).get_rna_type().description
            assert description, f"{cls.bl_idname} has no tooltip"
        if description:
            assert "\n" not in description and "  " not in description, (cls.__name__, description)
            assert description == description.strip() and len(description) <= 300, (cls.__name__, description)
            checked += 1
    assert checked >= 30


def test_every_property_has_a_description(bpy_clean):
    bpy = bpy_clean
    missing = [f"{cls.bl_idname}.{p.identifier}" for cls, rna in _operators(bpy)
               for p in rna.properties if p.identifier != "rna_type" and not p.description.strip()]
    for cls in addon_module("panels").PROPERTY_CLASSES + addon_module("operators.general.preferences").CLASSES:
        missing += [f"{cls.__name__}.{p.identifier}" for p in cls.bl_rna.properties
                    if p.identifier not in ("rna_type", "name", "bl_idname") and not p.description.strip()]
    assert not missing, missing


def test_operators_that_change_data_can_be_undone(bpy_clean):
    bpy = bpy_clean
    read_only = {"faces_hands.export_face", "faces_hands.export_hand", "faces_hands.export_live_link",
                 "faces_hands.export_mouth_cues", "faces_hands.copy_presets", "faces_hands.clear_shape_cache", "faces_hands.morph_save_face"}
    lacking = [cls.bl_idname for cls, _ in _operators(bpy)
               if cls.bl_idname not in read_only and "UNDO" not in getattr(cls, "bl_options", set())]
    assert not lacking, lacking


def test_menus_list_existing_operators_and_are_hooked_into_blender(bpy_clean):
    bpy = bpy_clean
    menus = addon_module("panels.menus")
    for menu_name, draw in menus.MENUS:
        assert draw in getattr(bpy.types, menu_name).draw._draw_funcs, menu_name
    layout = CheckedLayout(bpy)                   # holds every call to Blender's own UILayout signatures
    fake = SimpleNamespace(layout=layout)
    for cls in (menus.FH_MT_add, menus.FH_MT_object):
        cls.draw(fake, bpy.context)
    menus.draw_export(fake, bpy.context)
    operators = [args[0] if args else kwargs["operator"] for name, args, kwargs in layout.log if name == "operator"]
    assert "faces_hands.export_face" in operators and "faces_hands.build_hand_rig" in operators
    for idname in operators:
        module, name = idname.split(".")
        assert hasattr(getattr(bpy.ops, module), name) and getattr(getattr(bpy.ops, module), name).get_rna_type(), idname
    every = {cls.bl_idname for cls, _ in _operators(bpy)}
    internal = {cls.bl_idname for cls, _ in _operators(bpy) if "INTERNAL" in getattr(cls, "bl_options", set())}
    assert len(set(operators)) >= 0.6 * len(every - internal)


def test_preferences_page_and_preset_folder(bpy_clean, tmp_path):
    bpy = bpy_clean
    paths = addon_module("operators.adapters.paths")
    presets = addon_module("faces_hands_addon.core.presets")
    prefs = paths.preferences()
    assert prefs is not None and {"output_folder", "preset_folder", "voice"} <= set(prefs.bl_rna.properties.keys())
    before = presets.user_folder()
    try:
        prefs.preset_folder = str(tmp_path)
        assert presets.user_folder() == tmp_path
        prefs.output_folder = str(tmp_path / "exports")
        assert paths.output_folder() == tmp_path / "exports"
        prefs.voice = "de"
        assert paths.default_voice() == "de"
    finally:
        prefs.preset_folder, prefs.output_folder, prefs.voice = "", "//", "en-us"
    assert presets.user_folder() == before


def _glb(path):
    data = path.read_bytes()
    length = struct.unpack_from("<I", data, 12)[0]
    return json.loads(data[20:20 + length])


def test_export_frame_range_scale_and_selected_parts(bpy_clean, tmp_path):
    bpy = bpy_clean
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 20
    scene.render.fps = 24
    bpy.ops.faces_hands.build_face_rig()
    rig = bpy.context.active_object
    rig["fh.ctrl.jaw_open"] = 0.0
    rig.keyframe_insert('["fh.ctrl.jaw_open"]', frame=1)
    rig["fh.ctrl.jaw_open"] = 1.0
    rig.keyframe_insert('["fh.ctrl.jaw_open"]', frame=20)
    assert bpy.ops.faces_hands.bake_face(mode="ANIMATION") == {"FINISHED"}
    out = tmp_path / "part.glb"
    for obj in bpy.context.view_layer.objects:
        obj.select_set(obj is rig)
    result = bpy.ops.faces_hands.export_face(filepath=str(out), use_scene_range=False, frame_start=5,
                                             frame_end=12, use_selection=True, global_scale=100.0)
    assert result == {"FINISHED"}
    doc = _glb(out)
    times = [doc["accessors"][s["input"]] for a in doc["animations"] for s in a["samplers"]]
    assert min(t["min"][0] for t in times) == pytest.approx(0.0, abs=1e-6)
    assert max(t["max"][0] for t in times) == pytest.approx(7 / 24, abs=1e-4)
    assert [a["name"] for a in doc["animations"]] == [rig.name]   # not the name the original steps aside to
    assert [m["name"] for m in doc["meshes"]] and len(doc["meshes"]) == 1            # the skin only
    assert any(n.get("scale", [1, 1, 1])[0] == pytest.approx(100.0) for n in doc["nodes"])
    assert (scene.frame_start, scene.frame_end) == (1, 20)
    assert [o.name for o in bpy.context.view_layer.objects if o.select_get()] == [rig.name]


def test_building_rigs_and_faces_uses_no_api_blender_deprecates(bpy_clean):
    """The face rig (its materials and wrinkle material), the hand rig and a morph face are built without
    touching anything Blender has deprecated (on 5.x ``Material.use_nodes`` warns that 6.0 removes it)."""
    import warnings
    bpy = bpy_clean
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert bpy.ops.faces_hands.build_face_rig() == {"FINISHED"}
        assert bpy.ops.faces_hands.build_hand_rig() == {"FINISHED"}
        assert bpy.ops.faces_hands.morph_new_face() == {"FINISHED"}
    deprecated = sorted({str(w.message) for w in caught if issubclass(w.category, DeprecationWarning)
                         and "Blender" in str(w.message)})
    assert not deprecated, deprecated
