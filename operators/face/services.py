# SPDX-License-Identifier: GPL-3.0-or-later
"""The face's services for commands and other subsystems (plain functions; no operator classes): build a
rig object, bake and export it. Speech and the demo reach face rigs through here, not through commands."""
from __future__ import annotations

from pathlib import Path

import bpy
import numpy as np

from ...faces_hands_addon.core.errors import UserError
from ..bases import bake as common_bake
from ..adapters.blendfile import open_blend
from ..adapters.export import ExportOptions, export_rig, save_or_export
from ..bases.jobs import run_job
from ..adapters.rig_store import find_rig
from .fit import attach_rig, import_head, import_meshes
from .jobs import BuildDefaultRigJob, FitRigJob
from .objects import EXPORT_ROLES

__all__ = ["EXPRESSION_SETS", "ANIMATION_KINDS", "KIND", "build_default_rig_object", "build_fitted_from_file",
           "rig_object", "expressions", "bake", "export", "retarget", "attach_fitted_rig"]

KIND = "face"
EXPRESSION_SETS = ("arkit", "visemes", "named")


def build_default_rig_object(progress=None, name: str = "FH Head", resolution: str = "default"):
    """A new empty file holding the default head; returns its rig object."""
    bpy.ops.wm.read_homefile(use_empty=True)
    run_job(BuildDefaultRigJob(name, resolution), bpy.context, progress)
    return find_rig(bpy.data.objects, name, KIND)


def build_fitted_from_file(path: str, name: str, progress=None, forward=None, up=None, preview=None):
    """A new empty file holding the mesh of ``path`` fitted as a face rig; returns the rig object.
    ``forward``/``up``: the mesh's axes after import (None: searched); ``preview``: where a refused fit's
    picture goes."""
    bpy.ops.wm.read_homefile(use_empty=True)
    head = import_head(path)
    print(run_job(FitRigJob(bpy.context, head, name, forward, up, preview), bpy.context, progress))
    return head


def rig_object(blend: str | None, rig_name: str | None = None, progress=None):
    """The face rig object of ``blend`` (picked by ``rig_name`` when there are several), or a new default
    head."""
    if blend:
        open_blend(blend)
        return find_rig(bpy.data.objects, rig_name, KIND)
    return build_default_rig_object(progress)


def expressions(preset: str) -> dict[str, dict[str, float]]:
    """The expressions of a set (``arkit``, ``visemes``, ``named``), or of all of them (``all``)."""
    from ...faces_hands_addon.face.expressions import load_expressions
    names = EXPRESSION_SETS if preset == "all" else (preset,)
    out: dict[str, dict[str, float]] = {}
    for name in names:
        out.update(load_expressions(name))
    return out


ANIMATION_KINDS = ("weights", "frames")
TAKE_FILES = (".glb", ".fbx")
CUE_FILES = (".tsv", ".txt", ".json")
CUE_FPS = 30.0


def bake_job(context, obj, mode: str, preset: str = "all", animation: str = "weights", take=None):
    """The bake of ``mode`` (basis | expressions | animation). An animation is baked as engine-ready
    ``weights`` of the fixed target set (ARKit + visemes + emotions, whatever ``preset`` names), or as the
    exact per-frame cache (``frames``: one key per frame, for offline renders). ``take`` = (engine take,
    start frame) bakes that take (the command line); without it, the take the rig object holds."""
    mode = mode.upper()
    if mode not in common_bake.MODES:
        raise UserError(f"unknown bake mode {mode.lower()!r}; use basis, expressions or animation")
    if animation not in ANIMATION_KINDS:
        raise UserError(f"unknown animation bake {animation!r}; use weights or frames")
    if mode == "ANIMATION" and animation == "weights":
        return common_bake.WeightsBakeJob.of_object(context, obj, expressions(preset), EXPORT_ROLES, take=take)
    inputs = common_bake.bake_inputs(context, obj, take, animated=mode == "ANIMATION")
    return common_bake.BakeJob(inputs, mode, expressions(preset) if mode != "BASIS" else None)


def bake(context, obj, mode: str, preset: str = "all", progress=None, animation: str = "weights",
         take=None) -> str:
    """Bake the face rig object ``obj`` (basis | expressions | animation) to the end; returns the report."""
    return run_job(bake_job(context, obj, mode, preset, animation, take), context, progress)


def export(context, obj, path: str, options: ExportOptions = ExportOptions()):
    """Export the face rig object ``obj`` (skin, eyes, teeth, tongue) to ``path`` (.glb or .fbx)."""
    return export_rig(context, obj, path, EXPORT_ROLES, options)


def _take_weights(args, progress):
    """Frames (from 0), weights and frame rate of the take ``--source`` names: a rig .blend, a Live Link CSV,
    a take exported as GLB/FBX (ours or any file whose mesh animates named shape keys), or Rhubarb mouth
    cues (each shape's viseme held until the next cue). A file's take plays at ``--fps`` or, by default, at
    its own rate (the steps between its rows or keys; 30 for cues)."""
    from ...faces_hands_addon.anim.retarget import read_live_link_csv, take_rate
    from ..adapters.foreign_import import import_foreign
    from ..adapters.targets import animated_weights, keyed_weights
    from ..adapters.timing import scene_fps
    for option in ("fps", "csv_fps"):
        value = getattr(args, option, None)
        if value is not None and not 1.0 <= value <= 240.0:          # NaN fails too
            raise UserError(f"--{option.replace('_', '-')} {value} is outside 1..240 frames per second")
    suffix = Path(args.source).suffix.lower()
    if suffix in CUE_FILES:                        # Rhubarb mouth cues: no rate of their own
        from ...faces_hands_addon.speech.cues import cue_weights, read_cues
        fps = float(args.fps or CUE_FPS)
        frames, weights = cue_weights(read_cues(args.source), fps)
        return frames, weights, fps
    if suffix == ".csv" or suffix in TAKE_FILES:
        if suffix == ".csv":
            times, weights = read_live_link_csv(args.source, args.csv_fps)
        else:
            bpy.ops.wm.read_homefile(use_empty=True)
            imported = import_foreign(args.source, "--source", TAKE_FILES)
            _, times, weights = keyed_weights(imported.objects, imported.fps)
        fps = float(args.fps) if args.fps else take_rate(times)
        frames = np.arange(0, int(np.floor(times[-1] * fps + 0.01)) + 1, dtype=np.float64)   # float32 key times
        return frames, {n: np.interp(frames / fps, times, v) for n, v in weights.items()}, fps
    rig = rig_object(args.source, args.rig, progress)
    frames, weights = animated_weights(rig, bpy.context.scene)
    return frames - frames[0], weights, scene_fps(bpy.context.scene)


def _character(args):
    if Path(args.character).suffix.lower() == ".blend":
        open_blend(args.character)
        meshes = [o for o in bpy.data.objects if o.type == "MESH" and o.data.shape_keys is not None]
    else:
        bpy.ops.wm.read_homefile(use_empty=True)
        meshes = [o for o in import_meshes(args.character) if o.data.shape_keys is not None]
    if args.object:
        meshes = [o for o in meshes if o.name == args.object]
    if not meshes:
        raise UserError(f"{args.character} has no mesh with shape keys" + (f" named {args.object!r}" if args.object else ""))
    return max(meshes, key=lambda o: len(o.data.shape_keys.key_blocks))


def retarget(args, out, progress=None) -> str:
    """CLI ``retarget``: the take of ``args.source`` onto the character of ``args.character``, saved to ``out``."""
    from ..adapters.targets import transfer_weights
    from ..adapters.timing import set_scene_fps
    frames, weights, fps = _take_weights(args, progress)
    character = _character(args)
    scene = bpy.context.scene
    set_scene_fps(scene, fps)
    scene.frame_start, scene.frame_end = 0, int(frames[-1])
    matched = transfer_weights(character, frames, weights)
    save_or_export(bpy.context, character, out, ())
    return (f"Transferred {len(frames)} frames at {fps:g} fps onto '{character.name}': "
            f"{len(matched)} of its shape keys play the take")


def attach_fitted_rig(context, head, rig, world_matrix, name: str | None = None):
    """Make ``head`` (a mesh object) the skin of ``rig``, a fitted rig built in world coordinates with the
    head's world matrix ``world_matrix`` (other subsystems hand their meshes to the face rig through here)."""
    return attach_rig(context, head, rig, world_matrix, name)
