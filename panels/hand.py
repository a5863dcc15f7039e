# SPDX-License-Identifier: GPL-3.0-or-later
"""Hand rig sub-panels: build (reference or from a photo), poses and motions, live simulation, Solve
Contractions, bake, export, retarget, and the muscle controls by finger. Only draws; the control list comes
from the rig object's stored control list (no engine work here)."""
from __future__ import annotations

import bpy

from .base import ROOT, RigControlsPanel, SidebarPanel, draw_bake_box, draw_live_row, rig_of_kind

GROUPS = ("thumb", "index", "middle", "ring", "pinky", "wrist")


def _hand(context):
    return rig_of_kind(context, "hand")


class FH_PT_hand(SidebarPanel, bpy.types.Panel):
    bl_label = "Hand Rig"
    bl_idname = "FH_PT_hand"
    bl_parent_id = ROOT

    def draw(self, context):
        layout = self.layout
        col = layout.column(align=True)
        col.operator("faces_hands.build_hand_rig", icon="VIEW_PAN")
        row = col.row(align=True)
        row.operator("faces_hands.load_hand_photo", icon="IMAGE_DATA")
        row.operator("faces_hands.build_hand_from_photo", icon="MOD_MESHDEFORM")
        obj = _hand(context)
        if obj is None:
            layout.label(text="Select a hand rig to pose and animate it", icon="INFO")
            return
        draw_live_row(layout, context, "faces_hands.live_hand")
        row = layout.row(align=True)
        row.operator_menu_enum("faces_hands.apply_hand_pose", "pose", text="Pose", icon="HAND")
        row.operator_menu_enum("faces_hands.animate_hand", "motion", text="Motion", icon="ANIM")
        layout.operator("faces_hands.solve_contractions", icon="CON_KINEMATIC")
        box = draw_bake_box(layout, "faces_hands.bake_hand", "faces_hands.export_hand", bake_icon="ACTION")
        box.operator("faces_hands.retarget_hand", icon="ARMATURE_DATA")


class FH_PT_hand_controls(RigControlsPanel, bpy.types.Panel):
    bl_label = "Muscles"
    bl_idname = "FH_PT_hand_controls"
    bl_parent_id = "FH_PT_hand"
    rig_kind, group_order, nothing = "hand", GROUPS, "No muscle matches the filter"


CLASSES = [FH_PT_hand, FH_PT_hand_controls]
