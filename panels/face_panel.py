# SPDX-License-Identifier: GPL-3.0-or-later
"""Face rig sub-panel: build, live simulation, controls by face region (with a filter), bake, export.
Only draws; the control list comes from the rig object's ``fh_rig_controls`` (no engine work here)."""
from __future__ import annotations

import json

import bpy

REGIONS = ("brow", "eyes", "nose", "cheeks", "mouth", "jaw", "tongue")


def _rig_object(context):
    obj = context.active_object
    while obj is not None and not obj.get("fh_rig"):
        obj = obj.parent
    return obj


def _live_running() -> bool:
    from ..operators.ops_face import live_running
    return live_running()


class FH_PT_face(bpy.types.Panel):
    bl_label = "Face Rig"
    bl_idname = "FH_PT_face"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Faces & Hands"
    bl_parent_id = "FH_PT_main"

    def draw(self, context):
        layout = self.layout
        col = layout.column(align=True)
        col.operator("faces_hands.build_face_rig", icon="USER")
        if hasattr(bpy.types, "FACES_HANDS_OT_locate_landmarks"):
            col.operator("faces_hands.locate_landmarks", icon="EMPTY_AXIS")
            col.operator("faces_hands.fit_face_rig", icon="MOD_MESHDEFORM")
        obj = _rig_object(context)
        if obj is None:
            layout.label(text="Select a face rig to edit its controls", icon="INFO")
            return
        row = layout.row(align=True)
        running = _live_running()
        row.operator("faces_hands.live_simulation", text="Stop Live" if running else "Live Simulation",
                     icon="PAUSE" if running else "PLAY", depress=running)
        row.operator("faces_hands.reset_controls", icon="LOOP_BACK")
        box = layout.box()
        row = box.row(align=True)
        row.operator_menu_enum("faces_hands.bake_face", "mode", text="Bake", icon="SHAPEKEY_DATA")
        row.operator("faces_hands.export_face", text="Export", icon="EXPORT")


class FH_PT_face_controls(bpy.types.Panel):
    bl_label = "Controls"
    bl_idname = "FH_PT_face_controls"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Faces & Hands"
    bl_parent_id = "FH_PT_face"

    @classmethod
    def poll(cls, context):
        return _rig_object(context) is not None

    def draw(self, context):
        layout = self.layout
        obj = _rig_object(context)
        settings = context.scene.faces_hands
        layout.prop(settings, "control_filter", text="", icon="VIEWZOOM")
        needle = settings.control_filter.strip().lower()
        try:
            controls = json.loads(obj.get("fh_rig_controls", "[]"))
        except ValueError:
            controls = []
        by_region = {}
        for name, region, _kind in controls:
            if needle and needle not in name.lower():
                continue
            by_region.setdefault(region, []).append(name)
        if not by_region:
            layout.label(text="No control matches the filter")
        for region in [r for r in REGIONS if r in by_region] + sorted(set(by_region) - set(REGIONS)):
            box = layout.box()
            box.label(text=region.title())
            column = box.column(align=True)
            for name in by_region[region]:
                prop = f"fh.ctrl.{name}"
                if prop in obj.keys():
                    column.prop(obj, f'["{prop}"]', text=name.replace("_", " "), slider=True)


CLASSES = [FH_PT_face, FH_PT_face_controls]
