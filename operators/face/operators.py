# SPDX-License-Identifier: GPL-3.0-or-later
"""Face rig operators: build, reset, live simulation, bake (basis / expressions / animation), export."""
from __future__ import annotations

import bpy

from ...faces_hands_addon.core.errors import UserError
from ..adapters import controls
from ..bases.file_operators import ExportRigOperator
from ..bases.hardened import HardenedOperator
from ..bases.jobs import Job
from ..bases.live import LiveSimulationOperator, live_object
from ..bases.modal import JobOperator
from ..adapters.rig_store import get_rig, rig_of
from . import services
from .jobs import BuildDefaultRigJob
from .objects import update_muscle_display

EXPRESSION_SET_ITEMS = [
    ("arkit", "ARKit (52)", "The 52 ARKit face-tracking blendshapes (eyeBlinkLeft, jawOpen, ...)"),
    ("visemes", "Visemes (15)", "The 15 Oculus/Meta visemes (viseme_sil, viseme_PP, ...)"),
    ("named", "Emotions", "Named expressions: smile, frown, surprise, ..."),
    ("all", "All", "ARKit, visemes and named expressions")]


def _active_rig(context):
    obj = rig_of(context.active_object)
    if obj is None:
        raise UserError("select a face rig (or one of its parts) first")
    return obj


class FH_OT_build_face_rig(JobOperator, bpy.types.Operator):
    """Build the default MEDUSA head: skin as a mass-spring network over skull and jaw, driven by the 24+
    muscles of facial expression, with eyes, lids, teeth and tongue"""

    bl_idname = "faces_hands.build_face_rig"
    bl_label = "Build Default Face Rig"
    bl_options = {"REGISTER", "UNDO"}

    name: bpy.props.StringProperty(name="Name", default="FH Head", description="Name of the new rig object")
    resolution: bpy.props.EnumProperty(
        name="Resolution", default="default", description="How finely the skin is simulated",
        items=[("default", "Default (~2.9k nodes)", "Smooth and fast enough for live preview"),
               ("10k", "High (~11k nodes)", "Finer skin, slower simulation")])

    def make_job(self, context) -> Job:
        return BuildDefaultRigJob(self.name, self.resolution)


class FH_OT_reset_controls(HardenedOperator, bpy.types.Operator):
    """Set every control of the active rig back to its default (rest) value"""

    bl_idname = "faces_hands.reset_controls"
    bl_label = "Reset Controls"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context):
        obj = _active_rig(context)
        controls.reset_controls(obj, get_rig(obj).control_specs())
        obj.update_tag()
        return {"FINISHED"}


class FH_OT_live_simulation(LiveSimulationOperator, bpy.types.Operator):
    """Simulate the face live while you drag sliders or scrub the timeline (writes the 'FH Simulation'
    shape key; the base mesh stays untouched). Esc or the button again stops it"""

    bl_idname = "faces_hands.live_simulation"
    bl_label = "Live Simulation"
    bl_options = {"REGISTER", "UNDO"}

    after_push = staticmethod(update_muscle_display)


class FH_OT_bake_face(JobOperator, bpy.types.Operator):
    """Bake the simulated face to shape keys: one per control (driven by it), named expressions (ARKit,
    visemes), or the animation frame by frame, for export to game engines"""

    bl_idname = "faces_hands.bake_face"
    bl_label = "Bake Face"
    bl_options = {"REGISTER", "UNDO"}

    mode: bpy.props.EnumProperty(
        name="Mode", default="EXPRESSIONS", description="What to bake",
        items=[("BASIS", "Muscle Basis", "One shape key FH.<control> per control at full value, driven by it"),
               ("EXPRESSIONS", "Expressions", "Named expressions (ARKit, visemes, emotions) as shape keys"),
               ("ANIMATION", "Animation (Weights)",
                "Simulate the animated controls over the frame range and express every frame as weights of the "
                "ARKit, viseme and emotion targets: what game engines retarget, blend and stream"),
               ("FRAMES", "Animation (Per-Frame Cache)",
                "Simulate the animated controls over the frame range; one exact shape key per frame (offline "
                "renders; grows with the length of the animation)")])
    expression_set: bpy.props.EnumProperty(name="Expressions", items=EXPRESSION_SET_ITEMS, default="all",
                                           description="Which expressions Expressions bakes, and which targets an "
                                                       "animation is expressed with")

    def make_job(self, context) -> Job:
        if live_object(context):
            raise UserError("stop the live simulation before baking")
        if self.mode == "FRAMES":
            return services.bake_job(context, _active_rig(context), "ANIMATION", self.expression_set, "frames")
        return services.bake_job(context, _active_rig(context), self.mode, self.expression_set)


class FH_OT_export_face(HardenedOperator, ExportRigOperator, bpy.types.Operator):
    """Export the baked face (skin, eyes, teeth, tongue) with its shape keys and their animation to glTF
    (.glb) or FBX, ready for game engines"""

    bl_idname = "faces_hands.export_face"
    bl_label = "Export Baked Face"
    bl_options = {"REGISTER"}

    def default_stem(self, context) -> str:
        rig = rig_of(context.active_object)
        return bpy.path.display_name_from_filepath(bpy.data.filepath) or (rig.name if rig else "face")

    def run(self, context):
        path = services.export(context, _active_rig(context), self.filepath, self.export_options())
        self.report({"INFO"}, f"Exported {path}")
        return {"FINISHED"}


CLASSES = [FH_OT_build_face_rig, FH_OT_reset_controls, FH_OT_live_simulation, FH_OT_bake_face,
           FH_OT_export_face]
