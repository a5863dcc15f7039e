# SPDX-License-Identifier: GPL-3.0-or-later
"""Face rig operators: build, reset, live simulation, bake (basis / expressions / animation), export."""
from __future__ import annotations

import time

import bpy

from ..faces_hands_addon.errors import UserError
from . import bl_bake, bl_export, bl_face
from .hardened import HardenedOperator
from .jobs import Job, JobOperator

EXPRESSION_SETS = [("arkit", "ARKit (52)", "The 52 ARKit face-tracking blendshapes (eyeBlinkLeft, jawOpen, ...)"),
                   ("visemes", "Visemes (15)", "The 15 Oculus/Meta visemes (viseme_sil, viseme_PP, ...)"),
                   ("named", "Emotions", "Named expressions: smile, frown, surprise, ..."),
                   ("all", "All", "ARKit, visemes and named expressions")]


def _active_rig(context):
    obj = bl_face.rig_of(context.active_object)
    if obj is None:
        raise UserError("select a face rig (or one of its parts) first")
    return obj


class BuildDefaultRigJob(Job):
    label = "Building face rig"

    def __init__(self, name: str, resolution: str):
        self.name, self.resolution, self.rig = name, resolution, None

    def step(self) -> float:
        from ..faces_hands_addon.face.rig import build_default_rig
        self.rig = build_default_rig(self.resolution)
        return 1.0

    def commit(self, context) -> str:
        obj = bl_face.create_rig_objects(context, self.rig, self.name)
        bl_face.set_wrinkle_drivers(obj, self.rig)
        for other in context.view_layer.objects.selected:
            other.select_set(False)
        obj.select_set(True)
        context.view_layer.objects.active = obj
        return (f"Built face rig '{obj.name}': {len(self.rig.rest_positions)} skin nodes, "
                f"{len(self.rig.control_specs())} controls")


class FH_OT_build_face_rig(JobOperator, bpy.types.Operator):
    """Build the default MEDUSA head: skin as a mass-spring network over skull and jaw, driven by
    the 24+ muscles of facial expression, with eyes, lids, teeth and tongue"""

    bl_idname = "faces_hands.build_face_rig"
    bl_label = "Build Default Face Rig"
    bl_options = {"REGISTER", "UNDO"}

    name: bpy.props.StringProperty(name="Name", default="FH Head")
    resolution: bpy.props.EnumProperty(
        name="Resolution", default="default",
        items=[("default", "Default (~2.6k nodes)", "Smooth and fast enough for live preview"),
               ("10k", "High (~10k nodes)", "Finer skin, slower simulation")])

    def make_job(self, context) -> Job:
        return BuildDefaultRigJob(self.name, self.resolution)


class FH_OT_reset_controls(HardenedOperator, bpy.types.Operator):
    """Set every control of the active face rig back to its default (rest) value"""

    bl_idname = "faces_hands.reset_controls"
    bl_label = "Reset Controls"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context):
        obj = _active_rig(context)
        bl_face.reset_controls(obj, bl_face.get_rig(obj))
        obj.update_tag()
        return {"FINISHED"}


# ------------------------------------------------------------------------------------------ live
_live = {"object": None, "last": 0.0, "frames": 0, "busy_ms": 0.0}


def live_step(context, obj, dt: float | None = None) -> float:
    """One live-preview step: read the controls (as animated now), simulate one frame, push the pose.
    Returns the milliseconds it took."""
    started = time.perf_counter()
    rig = bl_face.get_rig(obj)
    scene = context.scene
    dt = dt or scene.render.fps_base / scene.render.fps
    rig.set_controls(bl_face.read_controls(obj, rig))
    rig.step_frame(dt)
    bl_face.push_pose(obj, rig)
    return (time.perf_counter() - started) * 1000.0


def live_running() -> bool:
    return _live["object"] is not None


class FH_OT_live_simulation(bpy.types.Operator):
    """Simulate the face live while you drag sliders or scrub the timeline (writes the 'FH Simulation'
    shape key; the base mesh stays untouched). Esc or the button again stops it"""

    bl_idname = "faces_hands.live_simulation"
    bl_label = "Live Simulation"
    bl_options = {"REGISTER"}

    _timer = None

    def execute(self, context):
        self.report({"ERROR"}, "live simulation needs a Blender window; use Bake in background mode")
        return {"CANCELLED"}

    def invoke(self, context, event):
        if live_running():
            _live["object"] = None  # the running modal operator sees this and stops
            return {"FINISHED"}
        try:
            obj = _active_rig(context)
            bl_face.get_rig(obj)
        except UserError as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        if context.window is None:
            self.report({"ERROR"}, "live simulation needs a Blender window; use Bake in background mode")
            return {"CANCELLED"}
        _live.update(object=obj.name, frames=0, busy_ms=0.0)
        self._timer = context.window_manager.event_timer_add(1 / 30, window=context.window)
        context.window_manager.modal_handler_add(self)
        context.workspace.status_text_set("Faces & Hands live simulation (Esc to stop)")
        return {"RUNNING_MODAL"}

    def _stop(self, context):
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
            self._timer = None
        context.workspace.status_text_set(None)
        _live["object"] = None

    def modal(self, context, event):
        name = _live["object"]
        obj = bpy.data.objects.get(name) if name else None
        if event.type == "ESC" or obj is None:
            self._stop(context)
            return {"CANCELLED"}
        if event.type == "TIMER":
            try:
                _live["busy_ms"] += live_step(context, obj)
                _live["frames"] += 1
            except UserError as error:
                self.report({"ERROR"}, str(error))
                self._stop(context)
                return {"CANCELLED"}
        return {"PASS_THROUGH"}

    def cancel(self, context):
        self._stop(context)


# ------------------------------------------------------------------------------------------ bake
class BakeJob(Job):
    """Simulates shapes step by step (nothing written), then writes them all in ``commit``."""

    def __init__(self, context, obj, mode: str, expression_set: str):
        from ..faces_hands_addon.face import baking
        from ..faces_hands_addon.face.expressions import load_expressions
        self.obj_name, self.mode = obj.name, mode
        self.rig = bl_face.get_rig(obj)
        self.shapes = []
        self.scene = context.scene
        self.original_frame = context.scene.frame_current
        if mode == "BASIS":
            self.total = len(self.rig.control_specs())
            self.label = "Baking muscle basis"
            self.generator = baking.basis_shapes(self.rig)
        elif mode == "EXPRESSIONS":
            sets = ["arkit", "visemes", "named"] if expression_set == "all" else [expression_set]
            expressions = {}
            for name in sets:
                expressions.update(load_expressions(name))
            self.total = len(expressions)
            self.label = f"Baking {len(expressions)} expressions"
            self.generator = baking.expression_shapes(self.rig, expressions)
        elif mode == "ANIMATION":
            frames = bl_bake.frame_range(context.scene)
            if len(frames) > 5000:
                raise UserError(f"{len(frames)} frames is too long for one bake; bake at most 5000 frames")
            self.total = len(frames)
            self.label = f"Baking {len(frames)} frames"
            fps = context.scene.render.fps / context.scene.render.fps_base

            def controls_at(frame):
                self.scene.frame_set(frame)
                return bl_face.read_controls(bpy.data.objects[self.obj_name], self.rig)
            self.generator = baking.animation_frames(self.rig, controls_at, frames, 1.0 / fps)
        else:
            raise UserError(f"unknown bake mode {mode!r}")

    def step(self) -> float:
        shape = next(self.generator, None)
        if shape is None:
            return 1.0
        self.shapes.append(shape)
        return min(len(self.shapes) / max(self.total, 1), 0.999)

    def cleanup(self) -> None:
        if self.scene.frame_current != self.original_frame:
            self.scene.frame_set(self.original_frame)

    def commit(self, context) -> str:
        obj = bpy.data.objects[self.obj_name]
        if self.mode == "ANIMATION":
            bl_bake.remove_keys(obj, "FH.frame_")
            names = bl_bake.commit_animation(obj, self.shapes, context.scene, self.rig)
        else:
            names = bl_bake.commit_shapes(obj, self.shapes, drive=self.mode == "BASIS", rig=self.rig)
        return f"Baked {len(names)} shape keys on '{obj.name}'"


class FH_OT_bake_face(JobOperator, bpy.types.Operator):
    """Bake the simulated face to shape keys: one per control (driven by it), named expressions
    (ARKit, visemes), or the animation frame by frame, for export to game engines"""

    bl_idname = "faces_hands.bake_face"
    bl_label = "Bake Face"
    bl_options = {"REGISTER", "UNDO"}

    mode: bpy.props.EnumProperty(
        name="Mode", default="EXPRESSIONS",
        items=[("BASIS", "Muscle Basis", "One shape key FH.<control> per control at full value, driven by it"),
               ("EXPRESSIONS", "Expressions", "Named expressions (ARKit, visemes, emotions) as shape keys"),
               ("ANIMATION", "Animation", "Simulate the animated controls over the frame range; one key per frame")])
    expression_set: bpy.props.EnumProperty(name="Expressions", items=EXPRESSION_SETS, default="all")

    def make_job(self, context) -> Job:
        if live_running():
            raise UserError("stop the live simulation before baking")
        return BakeJob(context, _active_rig(context), self.mode, self.expression_set)


class FH_OT_export_face(HardenedOperator, bpy.types.Operator):
    """Export the face rig (skin, eyes, teeth, tongue) with its shape keys and their animation to
    glTF (.glb) or FBX, ready for game engines"""

    bl_idname = "faces_hands.export_face"
    bl_label = "Export Baked Face"
    bl_options = {"REGISTER"}

    filepath: bpy.props.StringProperty(subtype="FILE_PATH")
    filter_glob: bpy.props.StringProperty(default="*.glb;*.fbx", options={"HIDDEN"})

    def invoke(self, context, event):
        if not self.filepath:
            self.filepath = bpy.path.ensure_ext(bpy.path.display_name_from_filepath(
                bpy.data.filepath) or "face", ".glb")
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def run(self, context):
        obj = _active_rig(context)
        path = bl_export.export_rig(context, obj, self.filepath)
        self.report({"INFO"}, f"Exported {path}")
        return {"FINISHED"}


CLASSES = [FH_OT_build_face_rig, FH_OT_reset_controls, FH_OT_live_simulation, FH_OT_bake_face,
           FH_OT_export_face]
