# SPDX-License-Identifier: GPL-3.0-or-later
"""The face's long work as jobs (``bases.jobs``): build the default head, locate landmarks on an artist's
mesh, fit a rig to it. Each computes in ``step`` and writes Blender data only in ``commit``."""
from __future__ import annotations

import bpy
import numpy as np

from ..bases.jobs import Job
from . import fit
from .objects import create_rig_objects, set_wrinkle_drivers

__all__ = ["BuildDefaultRigJob", "LocateJob", "FitRigJob"]


class BuildDefaultRigJob(Job):
    label = "Building face rig"

    def __init__(self, name: str, resolution: str):
        self.name, self.resolution, self.rig = name, resolution, None

    def step(self) -> float:
        from ...faces_hands_addon.face.rig import build_default_rig
        self.rig = build_default_rig(self.resolution)
        return 1.0

    def commit(self, context) -> str:
        obj = create_rig_objects(context, self.rig, self.name)
        set_wrinkle_drivers(obj, self.rig)
        for other in context.view_layer.objects.selected:
            other.select_set(False)
        obj.select_set(True)
        context.view_layer.objects.active = obj
        return (f"Built face rig '{obj.name}': {len(self.rig.rest_positions)} skin nodes, "
                f"{len(self.rig.control_specs())} controls")


def _refused_preview(job, error):
    """A refused fit (``fitting.quality.FitRefused``) as a UserError naming its preview PNG."""
    from pathlib import Path
    path = Path(job.preview) if job.preview else fit.default_preview_path(job.head_name)
    return fit.refuse_with_preview(error, path)


class LocateJob(Job):
    label = "Locating landmarks"

    def __init__(self, context, head, forward=None, up=None, preview=None):
        self.head_name = head.name
        self.forward, self.up = fit.axes_argument(forward, up)
        self.preview = preview
        self.world, self.faces = fit.world_geometry(head)
        self.fit = None

    def step(self) -> float:
        from ...faces_hands_addon.fitting import locate_landmarks
        from ...faces_hands_addon.fitting.quality import FitRefused
        try:
            self.fit = locate_landmarks(self.world, self.faces, seed=0, forward=self.forward, up=self.up)
        except FitRefused as error:
            raise _refused_preview(self, error) from None
        return 1.0

    def commit(self, context) -> str:
        head = bpy.data.objects[self.head_name]
        markers = fit.create_markers(context, head, np.asarray(self.fit.positions))
        quality = self.fit.quality() if callable(getattr(self.fit, "quality", None)) else ""
        return (f"Placed 468 landmarks on '{head.name}' ({quality}); drag them in Edit Mode of "
                f"'{markers.name}' if needed, then Fit Face Rig")


class FitRigJob(Job):
    label = "Fitting face rig"

    def __init__(self, context, head, name: str | None = None, forward=None, up=None, preview=None):
        self.head_name = head.name
        self.name = name
        self.forward, self.up = fit.axes_argument(forward, up)
        self.preview = preview
        self.world, self.faces = fit.world_geometry(head)
        self.matrix = np.array(head.matrix_world, dtype=np.float64)
        self.landmarks = fit.marker_positions_world(head)
        self.rig = None

    def step(self) -> float:
        from ...faces_hands_addon.face.fitted import build_fitted_rig
        from ...faces_hands_addon.fitting import project_to_surface
        landmarks = self.landmarks
        if landmarks is not None:  # markers dragged by hand: put them back onto the surface
            landmarks = project_to_surface(landmarks, self.world, self.faces)[0]
        from ...faces_hands_addon.fitting.quality import FitRefused
        try:
            self.rig = build_fitted_rig(self.world, self.faces, landmarks, seed=0, forward=self.forward, up=self.up)
        except FitRefused as error:
            raise _refused_preview(self, error) from None
        return 1.0

    def commit(self, context) -> str:
        head = bpy.data.objects[self.head_name]
        markers = fit.landmark_object(head)
        obj = fit.attach_rig(context, head, self.rig, self.matrix, self.name)
        if markers is not None:
            markers.hide_set(True)
        warnings = list(getattr(self.rig, "warnings", []) or [])
        note = f"; warnings: {'; '.join(warnings)}" if warnings else ""
        return (f"Fitted face rig to '{obj.name}': {len(self.world)} skin vertices, "
                f"{len(self.rig.control_specs())} controls{note}")
