# SPDX-License-Identifier: GPL-3.0-or-later
"""Hand rig operators: build (reference or from a photo), poses and motions, live simulation, Solve
Contractions, bake, export, retarget."""
from __future__ import annotations

import bpy

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.hand import motion
from ..bases.file_operators import ExportRigOperator
from ..bases.hardened import HardenedOperator
from ..bases.jobs import Job
from ..bases.live import LiveSimulationOperator, live_object
from ..bases.modal import JobOperator
from ..adapters.rig_store import is_rig, rig_of
from . import photo_objects, services
from .jobs import BakeHandJob, BuildHandJob
from .objects import push_hand_pose

SIDE_ITEMS = [("right", "Right", "A right hand (the reference hand)"),
              ("left", "Left", "A left hand: the right one mirrored")]
MESH_ITEMS = [("tube", "Shaped", "The WebXR hand shaped round the bones"),
              ("mpfb2", "MPFB2", "MPFB2's hand (the character's), the skeleton fitted into it")]


def _active_hand(context):
    obj = rig_of(context.active_object)
    if obj is None or not is_rig(obj, "hand"):
        raise UserError("select a hand rig (or one of its parts) first")
    return obj


def _pose_items(self, context):
    return [(n, n.replace("_", " ").title(), f"Preset pose {n} (presets/hand/poses.json)")
            for n in motion.pose_names()]


def _motion_items(self, context):
    return [(n, n.replace("_", " ").title(), f"Preset motion {n} (presets/hand/poses.json)")
            for n in motion.motion_names()]


class FH_OT_build_hand_rig(JobOperator, bpy.types.Operator):
    """Build the anatomical reference hand: 29 bones on an armature, 42 pseudo muscles, 9 geometric muscles and a skin simulated as a mass-spring network"""

    bl_idname = "faces_hands.build_hand_rig"
    bl_label = "Build Hand Rig"
    bl_options = {"REGISTER", "UNDO"}

    name: bpy.props.StringProperty(name="Name", default="FH Hand", description="Name of the new rig object")
    side: bpy.props.EnumProperty(name="Side", items=SIDE_ITEMS, default="right", description="Which hand to build")
    mesh: bpy.props.EnumProperty(name="Mesh", items=MESH_ITEMS, default="tube", description="The hand's skin")

    def make_job(self, context) -> Job:
        return BuildHandJob(self.name, self.side, mesh=self.mesh)


class FH_OT_build_hand_from_photo(JobOperator, bpy.types.Operator):
    """Warp the reference hand to the hand of the loaded photo, using the feature points and ruler marks you placed on it"""

    bl_idname = "faces_hands.build_hand_from_photo"
    bl_label = "Build Hand from Photo"
    bl_options = {"REGISTER", "UNDO"}

    name: bpy.props.StringProperty(name="Name", default="FH Photo Hand", description="Name of the new rig object")
    side: bpy.props.EnumProperty(name="Side", items=SIDE_ITEMS, default="right", description="Which hand to build")

    def make_job(self, context) -> Job:
        return BuildHandJob(self.name, self.side, photo_objects.photo_input(context))


class FH_OT_load_hand_photo(HardenedOperator, bpy.types.Operator):
    """Load a photo of a flat hand with a ruler as a reference image, with movable markers for the 26 feature points and 2 ruler marks"""

    bl_idname = "faces_hands.load_hand_photo"
    bl_label = "Load Hand Photo"
    bl_options = {"REGISTER", "UNDO"}

    filepath: bpy.props.StringProperty(subtype="FILE_PATH", description="The photo (PNG or JPEG) of a flat hand")
    ruler_mm: bpy.props.FloatProperty(name="Ruler Distance (mm)", default=200.0, min=1.0, max=2000.0,
                                      description="Distance between the two ruler marks you will place")

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def run(self, context):
        photo = photo_objects.load_photo(context, self.filepath, self.ruler_mm)
        self.report({"INFO"}, f"Loaded '{photo.name}': move the markers onto the photo (delete hidden ones), "
                              "then Build Hand from Photo")
        return {"FINISHED"}


class FH_OT_apply_hand_pose(HardenedOperator, bpy.types.Operator):
    """Set the hand's muscle contractions to a preset pose (fist, point, thumbs up, ...)"""

    bl_idname = "faces_hands.apply_hand_pose"
    bl_label = "Apply Hand Pose"
    bl_options = {"REGISTER", "UNDO"}

    pose: bpy.props.EnumProperty(name="Pose", items=_pose_items, description="The preset pose")
    squeeze: bpy.props.BoolProperty(
        name="Squeeze", default=False,
        description="Set the pose's second stage, its squeeze (the fist's thenar muscles contract). Apply it once the "
                    "live preview has closed the hand: squeezing from an open hand swings the thumb across the palm")

    def run(self, context):
        _, staged = services.apply_pose(_active_hand(context), self.pose, self.squeeze)
        if staged and not self.squeeze:
            self.report({"INFO"}, f"'{self.pose}' has a squeeze: apply it again with Squeeze on once the hand has "
                                  "closed, or key both stages with Animate Hand")
        elif self.squeeze and not staged:
            self.report({"INFO"}, f"'{self.pose}' has no squeeze stage; its contractions are set")
        return {"FINISHED"}


class FH_OT_animate_hand(HardenedOperator, bpy.types.Operator):
    """Key a preset motion on the hand's muscle controls (Hermite-interpolated contraction keys)"""

    bl_idname = "faces_hands.animate_hand"
    bl_label = "Animate Hand"
    bl_options = {"REGISTER", "UNDO"}

    motion: bpy.props.EnumProperty(name="Motion", items=_motion_items, description="The preset motion")

    def run(self, context):
        first, last = services.animate(context, _active_hand(context), self.motion)
        self.report({"INFO"}, f"Keyed '{self.motion}' on frames {first}-{last}")
        return {"FINISHED"}


class FH_OT_live_hand(LiveSimulationOperator, bpy.types.Operator):
    """Simulate the hand live while you drag muscle sliders or scrub (poses the armature, writes the 'FH Simulation' shape key); Esc or the button again stops it"""

    bl_idname = "faces_hands.live_hand"
    bl_label = "Live Hand Simulation"
    bl_options = {"REGISTER", "UNDO"}

    after_push = staticmethod(push_hand_pose)


class FH_OT_solve_contractions(HardenedOperator, bpy.types.Operator):
    """Find the minimal-effort muscle contractions that hold the pose you gave the hand's bones in Pose Mode"""

    bl_idname = "faces_hands.solve_contractions"
    bl_label = "Solve Contractions"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context):
        obj = _active_hand(context)
        if context.mode != "OBJECT" and context.active_object is not None:
            bpy.ops.object.mode_set(mode="OBJECT")
        self.report({"INFO"}, services.solve(context, obj))
        return {"FINISHED"}


class FH_OT_bake_hand(JobOperator, bpy.types.Operator):
    """Bake the simulated hand over the frame range: bone rotations to an Action and a fixed set of corrective shape keys driven by joint angles and muscle bulge"""

    bl_idname = "faces_hands.bake_hand"
    bl_label = "Bake Hand"
    bl_options = {"REGISTER", "UNDO"}

    def make_job(self, context) -> Job:
        if live_object(context):
            raise UserError("stop the live simulation before baking")
        return BakeHandJob(context, _active_hand(context))


class FH_OT_export_hand(HardenedOperator, ExportRigOperator, bpy.types.Operator):
    """Export the baked hand (skinned mesh, armature, animation, corrective shape keys) to glTF (.glb) or FBX"""

    bl_idname = "faces_hands.export_hand"
    bl_label = "Export Baked Hand"
    bl_options = {"REGISTER"}

    def default_stem(self, context) -> str:
        return bpy.path.display_name_from_filepath(bpy.data.filepath) or "hand"

    def run(self, context):
        path = services.export(context, _active_hand(context), self.filepath, self.export_options())
        self.report({"INFO"}, f"Exported {path}")
        return {"FINISHED"}


class FH_OT_retarget_hand(HardenedOperator, bpy.types.Operator):
    """Copy the hand's baked bone animation onto the other selected armature: its hand bones named like the WebXR joints, MPFB2, Mixamo, VRM or Rigify bones (the character bone map)"""

    bl_idname = "faces_hands.retarget_hand"
    bl_label = "Retarget Hand Animation"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context):
        hand = _active_hand(context)
        targets = [o for o in context.selected_objects if o.type == "ARMATURE" and rig_of(o) is not hand]
        if not targets:
            raise UserError("select the armature to retarget onto as well (the hand rig active)")
        count = services.retarget(context, hand, targets[0])
        self.report({"INFO"}, f"Retargeted {count} bones onto '{targets[0].name}'")
        return {"FINISHED"}


CLASSES = [FH_OT_build_hand_rig, FH_OT_load_hand_photo, FH_OT_build_hand_from_photo, FH_OT_apply_hand_pose,
           FH_OT_animate_hand, FH_OT_live_hand, FH_OT_solve_contractions, FH_OT_bake_hand, FH_OT_export_hand,
           FH_OT_retarget_hand]
