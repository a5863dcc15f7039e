# SPDX-License-Identifier: GPL-3.0-or-later
"""Face rig sub-panels: build, live simulation, controls by face region (with a filter), bake, export.
Only draws; the control list comes from the rig object's stored control list (no engine work here)."""
from __future__ import annotations

import bpy

from .base import ROOT, RigControlsPanel, SidebarPanel, draw_bake_box, draw_live_row, rig_object

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
        draw_live_row(layout, context, "faces_hands.live_simulation")
        draw_bake_box(layout, "faces_hands.bake_face", "faces_hands.export_face", bake_enum="mode")


class FH_PT_face_controls(RigControlsPanel, bpy.types.Panel):
    bl_label = "Controls"
    bl_idname = "FH_PT_face_controls"
    bl_parent_id = "FH_PT_face"
    rig_kind, group_order = "face", REGIONS


CLASSES = [FH_PT_face, FH_PT_face_controls]
