# SPDX-License-Identifier: GPL-3.0-or-later
"""Locate Landmarks and Fit Face Rig: make the artist's own head mesh animatable (thesis 3.1.2)."""
from __future__ import annotations

import bpy

from ...faces_hands_addon.core.errors import UserError
from ..bases.jobs import Job
from ..bases.modal import JobOperator
from ..adapters.rig_store import PART_ROLE, is_rig
from .fit import AXIS_ITEMS, LANDMARKS_ROLE
from .jobs import FitRigJob, LocateJob


def _selected_head(context):
    obj = context.active_object
    if obj is not None and obj.get(PART_ROLE) == LANDMARKS_ROLE:
        obj = obj.parent
    if obj is None or obj.type != "MESH":
        raise UserError("select the head mesh first")
    if is_rig(obj):
        raise UserError(f"'{obj.name}' is already a face rig")
    return obj


def _forward():
    return bpy.props.EnumProperty(
        name="Forward", items=AXIS_ITEMS, default="AUTO",
        description="World axis the face looks along (Automatic: search the 24 axis orientations for the face; "
                    "set Up too)")


def _up():
    return bpy.props.EnumProperty(
        name="Up", items=AXIS_ITEMS, default="AUTO",
        description="World axis the top of the head points along (Automatic: searched; set Forward too)")


class FH_OT_locate_landmarks(JobOperator, bpy.types.Operator):
    """Find the 468 face landmarks on the selected head mesh automatically (registration of the template
    face) and show them as an editable landmark mesh you can adjust before fitting"""

    bl_idname = "faces_hands.locate_landmarks"
    bl_label = "Locate Landmarks"
    bl_options = {"REGISTER", "UNDO"}
    forward: _forward()
    up: _up()

    def make_job(self, context) -> Job:
        return LocateJob(context, _selected_head(context), self.forward, self.up)


class FH_OT_fit_face_rig(JobOperator, bpy.types.Operator):
    """Make the selected head mesh animatable: warp the template's skull, jaw, muscles, eyes, teeth and
    tongue to it and build the spring network on the mesh itself (topology, UVs, materials and shape keys
    kept), from your edited landmarks if any. A fit that does not look like a face is refused"""

    bl_idname = "faces_hands.fit_face_rig"
    bl_label = "Fit Face Rig"
    bl_options = {"REGISTER", "UNDO"}
    forward: _forward()
    up: _up()

    def make_job(self, context) -> Job:
        return FitRigJob(context, _selected_head(context), forward=self.forward, up=self.up)


CLASSES = [FH_OT_locate_landmarks, FH_OT_fit_face_rig]
