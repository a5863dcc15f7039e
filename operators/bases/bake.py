# SPDX-License-Identifier: GPL-3.0-or-later
"""The bakes of any rig as :class:`.jobs.Job`: the engine bakes (``anim.bakes``) compute step by step from
plain data without touching the scene; ``commit`` writes their result as shape keys (``shape_keys``).
Cancelling (ESC, an error) before the commit leaves the scene exactly as it was.

What a bake needs from Blender is gathered once, here, as plain data (:func:`bake_inputs`): the engine rig,
the take (``takes.take_for_bake``: the stored engine take, or the artist's F-curves where they changed it;
the command line hands in its engine take directly), the frame range and rate, the rest meshes of the
rig's parts and the rig's output space.
"""
from __future__ import annotations

import hashlib

from dataclasses import dataclass

import bpy
import numpy as np

from ...faces_hands_addon.anim import bakes
from ...faces_hands_addon.anim.take import Take
from ...faces_hands_addon.core.errors import UserError
from ..adapters import shape_keys
from .jobs import Job
from ..adapters.paths import shape_cache
from ..adapters.rig_store import get_rig, output_to_local, parts
from ..adapters.takes import take_for_bake
from ..adapters.timing import scene_fps

__all__ = ["MODES", "MAX_FRAMES", "BakeInputs", "bake_inputs", "BakeJob", "WeightsBakeJob"]

MODES = ("BASIS", "EXPRESSIONS", "ANIMATION")
MAX_FRAMES = bakes.MAX_CACHE_FRAMES


@dataclass
class BakeInputs:
    """Everything a bake reads, as plain data: the rig, the object the result goes to (by name), and for
    animation bakes the take, its frames, rate and start frame."""
    rig: object
    object_name: str
    take: Take | None = None
    frames: tuple[int, ...] = ()
    fps: float = 24.0
    start_frame: int = 0


def bake_inputs(context, obj, take: tuple[Take, int] | None = None, animated: bool = True) -> BakeInputs:
    """The plain inputs of a bake of ``obj``; for an ``animated`` bake the take: ``take`` = (engine take, its
    start frame) from the command line, else the take the object holds (``takes.take_for_bake``)."""
    rig = get_rig(obj)
    scene = context.scene
    if not animated:
        return BakeInputs(rig, obj.name)
    if take is None:
        take = take_for_bake(obj, scene, rig.control_specs())
    return BakeInputs(rig, obj.name, take[0], tuple(shape_keys.frame_range(scene)), scene_fps(scene), int(take[1]))


class BakeJob(Job):
    """Bake ``inputs.rig`` in ``mode``; ``expressions`` (name -> partial control dict) for EXPRESSIONS, and for
    ANIMATION the targets whose visemes show the take's lip closures."""

    def __init__(self, inputs: BakeInputs, mode: str, expressions: dict | None = None):
        if mode not in MODES:
            raise UserError(f"unknown bake mode {mode!r}; use one of {', '.join(MODES)}")
        self.obj_name, self.mode, self.rig = inputs.object_name, mode, inputs.rig
        if mode == "BASIS":
            self.bake = bakes.ShapesBake(self.rig, None, cache=shape_cache())
        elif mode == "EXPRESSIONS":
            self.bake = bakes.ShapesBake(self.rig, dict(expressions or {}), cache=shape_cache())
        else:
            self.bake = bakes.CacheBake(self.rig, inputs.take, inputs.frames, inputs.fps, inputs.start_frame,
                                        expressions or {})
        self.label, self.total = self.bake.label, self.bake.total

    @property
    def shapes(self):
        return self.bake.shapes

    def step(self) -> float:
        return self.bake.step()

    def cleanup(self) -> None:
        self.bake.close()
        super().cleanup()

    def commit(self, context) -> str:
        obj = bpy.data.objects[self.obj_name]
        if self.mode == "ANIMATION":
            shape_keys.remove_keys(obj, shape_keys.FRAME_PREFIX)
            names = shape_keys.commit_animation(obj, self.shapes)
        else:
            names = shape_keys.commit_shapes(obj, self.shapes, self.rig.control_specs() if self.mode == "BASIS"
                                             else None)
        return f"Baked {len(names)} shape keys on '{obj.name}'"


class WeightsBakeJob(Job):
    """The animation as engine-ready weights (``anim.bakes.WeightsBake``): all targets written once, the
    weights as F-curves on every mesh of the rig."""

    def __init__(self, inputs: BakeInputs, targets: dict, part_rest: dict, to_local: np.ndarray,
                 correctives: bool = True):
        self.obj_name = inputs.object_name
        self.bake = bakes.WeightsBake(inputs.rig, inputs.take, inputs.frames, inputs.fps, inputs.start_frame,
                                      targets, part_rest, to_local, correctives, cache=shape_cache())
        self.label, self.total, self.table = self.bake.label, self.bake.total, self.bake.table

    @classmethod
    def of_object(cls, context, obj, targets: dict, part_roles, correctives: bool = True,
                  take: tuple[Take, int] | None = None) -> "WeightsBakeJob":
        """The job for rig object ``obj`` (its parts of ``part_roles`` get the weights too)."""
        parts_now = parts(obj)
        rest = {role: shape_keys.rest_vertices(parts_now[role]).astype(np.float64)
                for role in part_roles if role in parts_now}
        return cls(bake_inputs(context, obj, take), targets, rest, output_to_local(obj), correctives)

    def step(self) -> float:
        return self.bake.step()

    def cleanup(self) -> None:
        self.bake.close()
        super().cleanup()

    def fit(self):
        return self.bake.fit()

    def targets_key(self) -> str:
        """A digest of the targets this bake writes on the meshes (names and the engine's arrays)."""
        digest = hashlib.sha256()
        for shape in self.bake.shapes:
            digest.update(shape.name.encode("utf-8"))
            for group in (shape.pose.positions, shape.pose.transforms):
                for role in sorted(group):
                    digest.update(role.encode("utf-8"))
                    digest.update(np.ascontiguousarray(group[role]).tobytes())
        return digest.hexdigest()

    def commit(self, context) -> str:
        obj = bpy.data.objects[self.obj_name]
        fit = self.fit()
        shape_keys.remove_keys(obj, shape_keys.FRAME_PREFIX)
        names = shape_keys.commit_shapes(obj, self.bake.shapes)
        shape_keys.commit_weights(obj, names, self.table.frames, fit.weights)
        median, p90, worst = fit.residual_mm()
        return (f"Baked {len(self.table)} frames as weights of {len(names)} targets on '{obj.name}' "
                f"(fit residual median {median:.2f} mm, p90 {p90:.2f} mm, max {worst:.2f} mm)")
