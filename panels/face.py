# SPDX-License-Identifier: GPL-3.0-or-later
"""Face rig sub-panels: build, live simulation, controls by face region (with a filter), bake, export.
Only draws; the control list comes from the rig object's stored control list (no engine work here)."""
from __future__ import annotations


import bpy

from .base import ROOT, SidebarPanel, draw_rig_controls, rig_object, rig_of_kind

REGIONS = ("brow", "eyes", "nose", "cheeks", "mouth", "jaw", "tongue")


class FH_PT_face(SidebarPanel, bpy.types.Panel):
    bl_label = "Face Rig"
    bl_idname = "FH_PT_face"
    bl_parent_id = ROOT

    def draw(self, context):
        layout = self.layout
        col = layout.column(align=True)
        col.operator("faces_hands.build_face_rig", icon="USER")
        col.operator("faces_hands.locate_landmarks", icon="EMPTY_AXIS")
        col.operator("faces_hands.fit_face_rig", icon="MOD_MESHDEFORM")
        obj = rig_object(context)
        if obj is None:
            layout.label(text="Select a face rig to edit its controls", icon="INFO")
            return
        row = layout.row(align=True)
        running = bool(context.window_manager.faces_hands_runtime.live_object)
        row.operator("faces_hands.live_simulation", text="Stop Live" if running else "Live Simulation",
                     icon="PAUSE" if running else "PLAY", depress=running)
        row.operator("faces_hands.reset_controls", icon="LOOP_BACK")
        box = layout.box()
        row = box.row(align=True)
        row.operator_menu_enum("faces_hands.bake_face", "mode", text="Bake", icon="SHAPEKEY_DATA")
        row.operator("faces_hands.export_face", text="Export", icon="EXPORT")


class FH_PT_face_controls(SidebarPanel, bpy.types.Panel):
    bl_label = "Controls"
    bl_idname = "FH_PT_face_controls"
    bl_parent_id = "FH_PT_face"

    @classmethod
    def poll(cls, context):
        return rig_of_kind(context, "face") is not None

    def draw(self, context):
        draw_rig_controls(self.layout, context, rig_of_kind(context, "face"), REGIONS)


CLASSES = [FH_PT_face, FH_PT_face_controls]
