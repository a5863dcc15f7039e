# SPDX-License-Identifier: GPL-3.0-or-later
"""The photo work's long jobs (``bases.jobs``): a head from photographs, stage by stage in ``step`` (the
engine's :class:`...faces_hands_addon.photo.pipeline.HeadBuild`), Blender objects only in ``commit``."""
from __future__ import annotations

from ...faces_hands_addon.photo.pipeline import HeadBuild
import bpy

from ..bases.jobs import Job, run_job
from . import services

__all__ = ["HeadFromPhotoJob", "build_head"]


class HeadFromPhotoJob(Job):
    label = "Head from photo"

    def __init__(self, photos, name: str = "FH Photo Head", model: str = "default", edits=()):
        self.photos, self.name = photos, name
        self.build = HeadBuild(photos, services.head_model(model), edits=list(edits))
        self.head_name = name
        self.warnings = ()

    def step(self) -> float:
        self.label = f"Head from photo: {self.build.label}"
        return self.build.step()

    def commit(self, context) -> str:
        result = self.build.result
        head = services.head_objects(context, result, self.photos[0].pixels, [p.name for p in self.photos],
                                     self.name)
        self.head_name = head.name
        self.warnings = tuple(result.notes)
        for other in context.view_layer.objects.selected:
            other.select_set(False)
        head.select_set(True)
        context.view_layer.objects.active = head
        camera = result.shape.cameras[0]
        return (f"Built '{head.name}' from {self.photos[0].name}: {len(head.data.vertices)} vertices, texture "
                f"{result.texture.srgb.shape[1]} px, focal {camera.focal:.0f} px, landmark residual "
                f"{float(sum(result.shape.residuals[0]) / len(result.shape.residuals[0])):.2f} px; the face rig "
                "is fitted (Speak Text and Lip Sync work on it)")


def build_head(context, photos, name: str = "FH Photo Head", model: str = "default", progress=None, edits=()):
    """Run the whole build (a job straight through); returns the head object and the engine's result.
    ``edits``: (attribute, value) pairs applied to the fitted person (``photo.edit``) before the rig."""
    job = HeadFromPhotoJob(photos, name, model, edits)
    print(run_job(job, context, progress))
    for warning in job.warnings:
        print(f"note: {warning}")
    return bpy.data.objects[job.head_name], job.build.result
