# SPDX-License-Identifier: GPL-3.0-or-later
"""Hand rig sub-panels: build (reference or from a photo), poses and motions, live simulation, Solve
Contractions, bake, export, retarget, and the muscle controls by finger. Only draws; the control list comes
from the rig object's stored control list (no engine work here)."""
from __future__ import annotations


import bpy

from .base import ROOT, SidebarPanel, draw_rig_controls, rig_of_kind

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
        row = layout.row(align=True)
        running = bool(context.window_manager.faces_hands_runtime.live_object)
        row.operator("faces_hands.live_hand", text="Stop Live" if running else "Live Simulation",
                     icon="PAUSE" if running else "PLAY", depress=running)
        row.operator("faces_hands.reset_controls", icon="LOOP_BACK")
        row = layout.row(align=True)
        row.operator_menu_enum("faces_hands.apply_hand_pose", "pose", text="Pose", icon="HAND")
        row.operator_menu_enum("faces_hands.animate_hand", "motion", text="Motion", icon="ANIM")
        layout.operator("faces_hands.solve_contractions", icon="CON_KINEMATIC")
        box = layout.box()
        row = box.row(align=True)
        row.operator("faces_hands.bake_hand", text="Bake", icon="ACTION")
        row.operator("faces_hands.export_hand", text="Export", icon="EXPORT")
        box.operator("faces_hands.retarget_hand", icon="ARMATURE_DATA")


class FH_PT_hand_controls(SidebarPanel, bpy.types.Panel):
    bl_label = "Muscles"
    bl_idname = "FH_PT_hand_controls"
    bl_parent_id = "FH_PT_hand"

    @classmethod
    def poll(cls, context):
        return _hand(context) is not None

    def draw(self, context):
        draw_rig_controls(self.layout, context, _hand(context), GROUPS, "No muscle matches the filter")


CLASSES = [FH_PT_hand, FH_PT_hand_controls]
