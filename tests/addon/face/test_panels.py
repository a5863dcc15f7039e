"""The N-panel draws (with a stand-in layout that holds every call to Blender's real UILayout signatures:
the bpy module has no UI) for an empty scene, a face rig, and with the control filter."""
from __future__ import annotations

import pytest

from ui_layout import CheckedLayout, panel_host

def _draw_all(bpy):
    drawn = {}
    for name in ("FH_PT_main", "FH_PT_face", "FH_PT_face_controls", "FH_PT_speech"):
        cls = getattr(bpy.types, name)
        log = []
        context = bpy.context
        if hasattr(cls, "poll") and not cls.poll(context):
            drawn[name] = None
            continue
        cls.draw(panel_host(cls, CheckedLayout(bpy, log)), context)
        drawn[name] = log
    return drawn

@pytest.mark.smoke
def test_panels_draw_without_a_rig(bpy_clean):
    drawn = _draw_all(bpy_clean)
    assert drawn["FH_PT_face_controls"] is None
    assert any(call[0] == "operator" and call[1][0] == "faces_hands.build_face_rig" for call in drawn["FH_PT_face"])

def test_panels_draw_rig_controls_grouped_and_filtered(bpy_clean):
    bpy = bpy_clean
    bpy.ops.faces_hands.build_face_rig()
    drawn = _draw_all(bpy)
    sliders = [c for c in drawn["FH_PT_face_controls"] if c[0] == "prop" and c[1][1].startswith('["fh.ctrl.')]
    assert len(sliders) >= 36
    regions = [c[2].get("text") for c in drawn["FH_PT_face_controls"] if c[0] == "label"]
    assert {"Brow", "Eyes", "Mouth", "Jaw"} <= set(regions)
    bpy.context.scene.faces_hands.control_filter = "zygo"
    drawn = _draw_all(bpy)
    sliders = [c[1][1] for c in drawn["FH_PT_face_controls"] if c[0] == "prop" and c[1][1].startswith('["fh.')]
    assert sliders and all("zygomaticus" in s for s in sliders)
