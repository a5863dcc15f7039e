# SPDX-License-Identifier: GPL-3.0-or-later
"""The photo work's operators: Head from Photo (a photo file -> a textured head with its face rig), Edit
Photo Landmarks (the landmarks as points over the photo, to correct by hand or to place when no face is
found), Head from Landmarks (the head from those points)."""
from __future__ import annotations

from pathlib import Path

import bpy

from ...faces_hands_addon.core.errors import UserError
from ..bases.hardened import HardenedOperator
from ..bases.jobs import Job
from ..bases.modal import JobOperator
from . import landmark_points
from .images import load_photo
from .jobs import HeadFromPhotoJob

IMAGE_GLOB = "*.jpg;*.jpeg;*.png;*.webp;*.tif;*.tiff;*.bmp"


class _ChoosePhoto:
    """Mixin: a file browser for the photo first, then the job (modal in the UI)."""

    filepath: bpy.props.StringProperty(subtype="FILE_PATH", description="The photo of the face (JPEG, PNG, ...)")
    filter_glob: bpy.props.StringProperty(default=IMAGE_GLOB, options={"HIDDEN"},
                                          description="Show pictures only")

    def invoke(self, context, event):
        if not self.filepath and context.window is not None:
            context.window_manager.fileselect_add(self)
            return {"RUNNING_MODAL"}
        parent = getattr(super(), "invoke", None)
        return parent(context, event) if parent is not None else self.execute(context)

    def execute(self, context):
        if context.window is not None and getattr(self, "_job", None) is None and hasattr(self, "make_job"):
            return super().invoke(context, None)
        return super().execute(context)


class FH_OT_head_from_photo(_ChoosePhoto, JobOperator, bpy.types.Operator):
    """Make a textured head of the person in a photo, with a face rig fitted to it (speech, behaviour and emotions work on it at once), and a camera that sees it as the photo did"""

    bl_idname = "faces_hands.head_from_photo"
    bl_label = "Head from Photo"
    bl_options = {"REGISTER", "UNDO"}

    face: bpy.props.IntProperty(name="Face", default=1, min=1, max=64,
                                description="Which face when the photo shows several (1 = the largest)")
    profile: bpy.props.StringProperty(name="Profile Photo", subtype="FILE_PATH", default="",
                                      description="Optional second photo of the same person (a side view), "
                                                  "fitted together with the first")
    name: bpy.props.StringProperty(name="Name", default="FH Photo Head", description="Name of the new head object")
    older: bpy.props.FloatProperty(name="Younger - Older", default=0.0, min=-3.0, max=3.0,
                                   description="Make the person younger (negative) or older (positive) with the "
                                               "morphable model's attribute, before the rig is fitted")
    heavier: bpy.props.FloatProperty(name="Slender - Obese", default=0.0, min=-3.0, max=3.0,
                                     description="Make the person slimmer (negative) or heavier (positive)")
    caricature: bpy.props.FloatProperty(name="Caricature", default=1.0, min=0.05, max=3.0,
                                        description="Caricature level: 1 = the person, more = further from the "
                                                    "average face (3.2.2)")

    def make_job(self, context) -> Job:
        photos = [load_photo(bpy.path.abspath(self.filepath), "the photo", face=self.face)[0]]
        if self.profile:
            photos.append(load_photo(bpy.path.abspath(self.profile), "the profile photo", role="profile")[0])
        edits = [(name, value) for name, value in (("younger-older", self.older), ("slender-obese", self.heavier))
                 if value != 0.0]
        if self.caricature != 1.0:
            edits.append(("caricature", self.caricature))
        return HeadFromPhotoJob(photos, self.name, edits=edits)


class FH_OT_photo_edit_landmarks(_ChoosePhoto, HardenedOperator, bpy.types.Operator):
    """Show a photo as a camera's background with its 478 face landmarks as points you can drag (Edit Mode), to correct them or to place them when no face is found; then use Head from Landmarks"""

    bl_idname = "faces_hands.photo_edit_landmarks"
    bl_label = "Edit Photo Landmarks"
    bl_options = {"REGISTER", "UNDO"}

    face: bpy.props.IntProperty(name="Face", default=1, min=1, max=64,
                                description="Which face when the photo shows several (1 = the largest)")

    def run(self, context):
        from ...faces_hands_addon.photo.pipeline import find_landmarks
        from .services import head_model
        path = Path(bpy.path.abspath(self.filepath))
        photo, _ = load_photo(path, "the photo", face=self.face)
        height, width = photo.pixels.shape[:2]
        try:
            points, notes = find_landmarks(photo)
            found = "the detected landmarks"
        except UserError as error:
            points, notes = landmark_points.default_points(head_model(), width, height), [str(error)]
            found = "the average face (no face was detected)"
        obj = landmark_points.add_landmark_points(context, photo, points, str(path))
        for other in context.view_layer.objects.selected:
            other.select_set(False)
        obj.select_set(True)
        context.view_layer.objects.active = obj
        for note in notes:
            self.report({"WARNING"}, note)
        self.report({"INFO"}, f"Placed {found} over {path.name}: look through the camera (Numpad 0), drag the "
                              "points in Edit Mode, then Head from Landmarks")
        return {"FINISHED"}


class FH_OT_photo_head_from_landmarks(JobOperator, bpy.types.Operator):
    """Make the head from the landmark points placed over the photo (Edit Photo Landmarks) instead of detecting them"""

    bl_idname = "faces_hands.photo_head_from_landmarks"
    bl_label = "Head from Landmarks"
    bl_options = {"REGISTER", "UNDO"}

    name: bpy.props.StringProperty(name="Name", default="FH Photo Head", description="Name of the new head object")

    def make_job(self, context) -> Job:
        points_obj = landmark_points.find_points(context)
        points, record = landmark_points.landmarks_of(points_obj)
        photo, _ = load_photo(landmark_points.photo_path(record), "the photo")
        if photo.pixels.shape[1] != int(record["width"]) or photo.pixels.shape[0] != int(record["height"]):
            raise UserError("the photo changed size since the points were made; make the points again")
        photo.landmarks = points
        return HeadFromPhotoJob([photo], self.name)


CLASSES = [FH_OT_head_from_photo, FH_OT_photo_edit_landmarks, FH_OT_photo_head_from_landmarks]
