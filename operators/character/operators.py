# SPDX-License-Identifier: GPL-3.0-or-later
"""Character operators: *Add > Faces & Hands > Character*."""
from __future__ import annotations

import bpy

from ...faces_hands_addon.core.errors import UserError
from ..bases.hardened import HardenedOperator
from ..bases.jobs import Job
from ..bases.modal import JobOperator
from ..adapters.rig_store import rig_of
from .fit_user import FitCharacterJob
from .jobs import BuildCharacterJob
from .objects import armature_of
from .retarget import retarget_animation

SKELETON_ITEMS = [
    ("game_engine", "Game Engine", "MPFB2's game-engine skeleton (53 bones, Unreal-style names): what engines and "
                                   "retargeting tools expect"),
    ("default", "MPFB2 Default", "MPFB2's default skeleton (163 bones: face, toes, breasts)"),
    ("rigify", "Rigify", "MPFB2's Rigify meta-rig, generated into a Rigify control rig"),
]


class FH_OT_add_character(JobOperator, bpy.types.Operator):
    """Add the default character: MakeHuman's MPFB2 body (CC0) with its eyes, teeth and tongue, skinned to an armature, with the face rig fitted to its head"""

    bl_idname = "faces_hands.add_character"
    bl_label = "Add Character"
    bl_options = {"REGISTER", "UNDO"}

    name: bpy.props.StringProperty(name="Name", default="FH Character", description="Name of the character object")
    skeleton: bpy.props.EnumProperty(name="Skeleton", items=SKELETON_ITEMS, default="game_engine",
                                     description="The armature the body is skinned to")
    hands: bpy.props.BoolProperty(name="Hand Rigs", default=True,
                                  description="Fit the anatomical hand rigs into the character's hands (their "
                                              "muscles pose the finger bones)")

    def make_job(self, context) -> Job:
        return BuildCharacterJob(self.name, self.skeleton, self.hands)


class FH_OT_fit_character(JobOperator, bpy.types.Operator):
    """Fit the face rig to your own character: its body mesh skinned to an armature with neck and head bones (MPFB2, Rigify, Mixamo or VRM names); its shape keys, modifiers and armature are kept"""

    bl_idname = "faces_hands.fit_character"
    bl_label = "Fit Face Rig to Character"
    bl_options = {"REGISTER", "UNDO"}

    def make_job(self, context) -> Job:
        return FitCharacterJob(context, context.active_object)


class FH_OT_retarget_character(HardenedOperator, bpy.types.Operator):
    """Key the character's armature animation (head on the neck, fingers) onto the other selected armature over the scene's frame range, through the bone map (MPFB2, Rigify, Mixamo, VRM names)"""

    bl_idname = "faces_hands.retarget_character"
    bl_label = "Retarget Character Animation"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context):
        body = rig_of(context.active_object)
        source = armature_of(body) if body is not None else None
        targets = [o for o in context.selected_objects if o.type == "ARMATURE" and o != source]
        if source is None or len(targets) != 1:
            raise UserError("select the character and one other armature (the one to key)")
        scene = context.scene
        count = retarget_animation(context, source, targets[0], range(scene.frame_start, scene.frame_end + 1))
        self.report({"INFO"}, f"Keyed {count} bones of '{targets[0].name}' over frames {scene.frame_start}-"
                              f"{scene.frame_end}")
        return {"FINISHED"}


CLASSES = [FH_OT_add_character, FH_OT_fit_character, FH_OT_retarget_character]
