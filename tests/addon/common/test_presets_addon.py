"""Presets an artist edits: "Copy Presets for Editing" puts them into the extension's user folder (never the
installed extension), the engine prefers those copies, and copying again keeps the artist's edits."""
from __future__ import annotations

import json
from pathlib import Path

from conftest import addon_module


def test_copy_presets_then_edit_overrides_the_shipped_one(bpy_clean, installed):
    bpy = bpy_clean
    from faces_hands_addon.core import presets
    from faces_hands_addon.face.expressions import load_expressions
    folder = presets.user_folder()
    assert folder is not None and Path(folder).resolve().is_relative_to(installed.user_dir.resolve())
    assert not Path(folder).resolve().is_relative_to(installed.extension_dir.resolve())
    assert bpy.ops.faces_hands.copy_presets() == {"FINISHED"}
    named = Path(folder) / "expressions" / "named.json"
    assert named.is_file() and (Path(folder) / "face" / "muscles.json").is_file()
    doc = json.loads(named.read_text(encoding="utf-8"))
    doc["expressions"]["smile"]["jaw_open"] = 0.42
    named.write_text(json.dumps(doc), encoding="utf-8")
    try:
        assert load_expressions("named")["smile"]["jaw_open"] == 0.42
        assert bpy.ops.faces_hands.copy_presets() == {"FINISHED"}          # keeps the edit
        assert load_expressions("named")["smile"]["jaw_open"] == 0.42
        assert bpy.ops.faces_hands.copy_presets(overwrite=True) == {"FINISHED"}
        assert load_expressions("named")["smile"]["jaw_open"] == 0.08
    finally:
        for path in sorted(Path(folder).rglob("*"), reverse=True):
            path.unlink() if path.is_file() else path.rmdir()
    assert load_expressions("named")["smile"]["jaw_open"] == 0.08


def test_broken_user_preset_refuses_the_bake_and_changes_nothing(bpy_clean):
    bpy = bpy_clean
    from faces_hands_addon.core import presets
    assert bpy.ops.faces_hands.build_face_rig() == {"FINISHED"}
    rig = bpy.context.active_object
    broken = Path(presets.user_folder()) / "expressions" / "visemes.json"
    broken.parent.mkdir(parents=True, exist_ok=True)
    broken.write_text('{"format": "faces_hands.expressions", "version": 1, "expressions": {', encoding="utf-8")
    try:
        import pytest
        with pytest.raises(RuntimeError, match="visemes.json: not valid JSON"):
            bpy.ops.faces_hands.bake_face(mode="EXPRESSIONS", expression_set="visemes")
        assert rig.data.shape_keys is None
    finally:
        broken.unlink()
    assert addon_module("operators.adapters.paths").user_preset_folder("nonexistent.package") is None
