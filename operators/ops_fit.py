# SPDX-License-Identifier: GPL-3.0-or-later
"""Locate Landmarks and Fit Face Rig: make the artist's own head mesh animatable (thesis 3.1.2)."""
from __future__ import annotations

import bpy
import numpy as np

from ..faces_hands_addon.errors import UserError
from . import bl_face, bl_fit
from .jobs import Job, JobOperator


def _selected_head(context):
    obj = context.active_object
    if obj is not None and obj.get(bl_face.PART_ROLE) == bl_fit.LANDMARKS_ROLE:
        obj = obj.parent
    if obj is None or obj.type != "MESH":
        raise UserError("select the head mesh (facing -Y, Z up) first")
    if bl_face.is_rig(obj):
        raise UserError(f"'{obj.name}' is already a face rig")
    return obj


class LocateJob(Job):
    label = "Locating landmarks"

    def __init__(self, context, head):
        self.head_name = head.name
        self.world, self.faces = bl_fit.world_geometry(head)
        self.fit = None

    def step(self) -> float:
        from ..faces_hands_addon.fitting import locate_landmarks
        self.fit = locate_landmarks(self.world, self.faces, seed=0)
        return 1.0

    def commit(self, context) -> str:
        head = bpy.data.objects[self.head_name]
        markers = bl_fit.create_markers(context, head, np.asarray(self.fit.positions))
        quality = self.fit.quality() if callable(getattr(self.fit, "quality", None)) else ""
        return (f"Placed 468 landmarks on '{head.name}' ({quality}); drag them in Edit Mode of "
                f"'{markers.name}' if needed, then Fit Face Rig")


class FitRigJob(Job):
    label = "Fitting face rig"

    def __init__(self, context, head, name: str | None = None):
        self.head_name = head.name
        self.name = name
        self.world, self.faces = bl_fit.world_geometry(head)
        self.matrix = np.array(head.matrix_world, dtype=np.float64)
        self.landmarks = bl_fit.marker_positions_world(head)
        self.rig = None

    def step(self) -> float:
        from ..faces_hands_addon.face.fitted import build_fitted_rig
        from ..faces_hands_addon.fitting import project_to_surface
        landmarks = self.landmarks
        if landmarks is not None:  # markers dragged by hand: put them back onto the surface
            landmarks = project_to_surface(landmarks, self.world, self.faces)[0]
        self.rig = build_fitted_rig(self.world, self.faces, landmarks, seed=0)
        return 1.0

    def commit(self, context) -> str:
        head = bpy.data.objects[self.head_name]
        markers = bl_fit.landmark_object(head)
        obj = bl_fit.attach_rig(context, head, self.rig, self.matrix, self.name)
        if markers is not None:
            markers.hide_set(True)
        warnings = list(getattr(self.rig, "warnings", []) or [])
        note = f"; warnings: {'; '.join(warnings)}" if warnings else ""
        return (f"Fitted face rig to '{obj.name}': {len(self.world)} skin vertices, "
                f"{len(self.rig.control_specs())} controls{note}")


class FH_OT_locate_landmarks(JobOperator, bpy.types.Operator):
    """Find the 468 face landmarks on the selected head mesh automatically (registration of the
    template face) and show them as an editable landmark mesh you can adjust before fitting"""

    bl_idname = "faces_hands.locate_landmarks"
    bl_label = "Locate Landmarks"
    bl_options = {"REGISTER", "UNDO"}

    def make_job(self, context) -> Job:
        return LocateJob(context, _selected_head(context))


class FH_OT_fit_face_rig(JobOperator, bpy.types.Operator):
    """Make the selected head mesh animatable: warp the template's skull, jaw, muscles, eyes, teeth
    and tongue to it and build the spring network on the mesh itself (its topology, UVs, materials and
    shape keys are kept). Uses the landmark mesh if you located and edited landmarks"""

    bl_idname = "faces_hands.fit_face_rig"
    bl_label = "Fit Face Rig"
    bl_options = {"REGISTER", "UNDO"}

    def make_job(self, context) -> Job:
        return FitRigJob(context, _selected_head(context))


CLASSES = [FH_OT_locate_landmarks, FH_OT_fit_face_rig]
