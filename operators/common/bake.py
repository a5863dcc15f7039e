# SPDX-License-Identifier: GPL-3.0-or-later
"""The bake of any rig as a :class:`.jobs.Job`: the engine's generators (``anim.baking``) compute shapes
step by step without touching the scene, ``commit`` writes them as shape keys (``shape_keys``). Cancelling
(ESC, an error) before the commit leaves the scene exactly as it was.

Animation bakes first sample the control layers of the frame range into a table (``controls.
sample_layers``), so the simulation never calls back into Blender.
"""
from __future__ import annotations

import itertools
import json
from concurrent.futures import ThreadPoolExecutor

import bpy
import numpy as np

from ...faces_hands_addon.anim import baking, closure_drive, semantic, weights
from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.physics import kernel
from . import controls, shape_keys
from .jobs import Job
from .paths import shape_cache
from .rig_store import get_rig, output_to_local, parts
from .timing import frame_duration

__all__ = ["MODES", "MAX_FRAMES", "BakeJob", "WeightsBakeJob", "animated_table"]

MODES = ("BASIS", "EXPRESSIONS", "ANIMATION")
MAX_FRAMES = 5000            # per-frame cache only: one shape key per frame
#: object property of a speech take's lip closures (JSON [[start frame, end frame, viseme], ...])
CLOSURES_PROPERTY = "fh_lip_closures"
PHYSICS_LEAD_S = 0.030        # animation bakes feed the simulation this far ahead: it trails its targets
CLOSURE_RAMP_S = 0.067        # the cache closes the lips at least this long before a closure starts (2 frames at 30 fps)
CLOSURE_MAX_LEAD_S = 0.2      # ... and at most this long, when the lips are far apart (anim.closure_drive)
FRAME_BLOCK = 64            # frames simulated and fitted per step of the weights bake


def closure_spans(obj) -> list[tuple[float, float, str]]:
    """The lip closures the last speech take stored on ``obj`` (start frame, end frame, viseme), or []."""
    text = obj.get(CLOSURES_PROPERTY)
    if not isinstance(text, str):
        return []
    try:
        spans = json.loads(text)
        return [(float(a), float(b), str(v)) for a, b, v in spans]
    except (ValueError, TypeError):
        return []                      # a hand-edited property: bake without the guarantee


def animated_table(obj, scene, specs, max_frames: int | None = None):
    """The layer table of the scene's frame range, or a UserError when nothing in it is animated (a bake of
    a still face would write a take of nothing) or when it has more than ``max_frames`` frames (the per-frame
    cache writes one shape key per frame; the weights bake streams its frames and has no limit)."""
    frames = shape_keys.frame_range(scene)
    if max_frames is not None and len(frames) > max_frames:
        raise UserError(f"{len(frames)} frames is more than the {max_frames} a per-frame cache bakes (one shape "
                        "key per frame); bake the animation as weights (the default), which has no frame limit, "
                        "or bake the frame range in parts")
    table = controls.sample_layers(obj, scene, specs, frames)
    if not any(np.ptp(values, axis=0).max(initial=0.0) > 0 for values in table.values.values()):
        raise UserError(f"nothing is animated between frames {frames[0]} and {frames[-1]}: key some controls "
                        "(or put a speech take on the rig) before baking the animation")
    return table


def cache_table(obj, scene, specs, table, targets, dt: float):
    """What the per-frame cache simulates: the layers ``PHYSICS_LEAD_S`` ahead (the simulation trails its
    targets by about that much) and, for the take's lip closures (on the frames shown during them), an
    ``anim.closure_drive.ClosureDrive`` that feeds each closure's viseme articulation
    (``semantic.with_closed_controls``) from ``CLOSURE_RAMP_S`` before it, or earlier (up to ``CLOSURE_MAX_LEAD_S``) where simulating ahead finds the lips still apart
    when it starts. Returns (table, drive or None). On Festival's 121 bilabials (``bench/lipsync_accuracy.py
    --cache``: 14 sentences, one cache each, played by three.js): the fixed 2-frame lead alone closed 93.4 %
    (lag -15 ms; the 8 missed stayed 1.0-3.2 mm open, 7 of them short /b p/ after an open vowel), the drive
    100 % (lag -10 ms)."""
    shifted = controls.sample_layers(obj, scene, specs, table.frames, lead=PHYSICS_LEAD_S / dt)
    frames = np.asarray(table.frames, np.float64)      # closures are checked where they are shown
    max_lead = int(np.ceil(CLOSURE_MAX_LEAD_S / dt))
    spans, rows = [], {}
    for start, end, viseme in closure_spans(obj):
        must = semantic.closure_frames(frames, [(start, end, viseme)]) if viseme in targets else {}
        if not must:
            continue
        first, last = min(must), max(must)
        always = min(int(np.searchsorted(frames, start - CLOSURE_RAMP_S / dt)), first)
        spans.append((always, first, last))
        rows.update({row: viseme for row in range(max(first - max_lead, 0), last + 1)})
    if not spans:
        return shifted, None
    closed = semantic.with_closed_controls(shifted, rows, targets, specs)
    return shifted, closure_drive.ClosureDrive(closed, sorted(spans), max_lead)


class BakeJob(Job):
    """Bake ``obj``'s rig in ``mode``; ``expressions`` (name -> partial control dict) for EXPRESSIONS, and for
    ANIMATION the targets whose visemes show the take's lip closures (``cache_table``)."""

    def __init__(self, context, obj, mode: str, expressions: dict | None = None):
        if mode not in MODES:
            raise UserError(f"unknown bake mode {mode!r}; use one of {', '.join(MODES)}")
        self.obj_name, self.mode = obj.name, mode
        self.rig = get_rig(obj)
        self.shapes = []
        specs = self.rig.control_specs()
        if mode == "BASIS":
            self.total, self.label = len(specs), "Baking muscle basis"
            self.generator = baking.basis_shapes(self.rig, cache=shape_cache())
        elif mode == "EXPRESSIONS":
            expressions = dict(expressions or {})
            if not expressions:
                raise UserError("no expressions to bake; choose an expression set")
            self.total, self.label = len(expressions), f"Baking {len(expressions)} expressions"
            self.generator = baking.expression_shapes(self.rig, expressions, cache=shape_cache())
        else:
            table = animated_table(obj, context.scene, specs, MAX_FRAMES)
            self.total, self.label = len(table), f"Baking {len(table)} frames"
            kernel.expect_frames(len(table))
            dt = frame_duration(context.scene)
            table, self.drive = cache_table(obj, context.scene, specs, table, expressions or {}, dt)
            self.generator = baking.animation_poses(self.rig, table, dt, drive=self.drive)

    def step(self) -> float:
        shape = next(self.generator, None)
        if shape is None:
            return 1.0
        self.shapes.append(shape)
        return min(len(self.shapes) / max(self.total, 1), 0.999)

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
    """The animation as engine-ready weights (``anim.weights``): bake the fixed target set (name ->
    expression) and the rig's corrective targets (its muscle basis, ``FH.<control>``), simulate the frame
    range, and write all targets once and the weights as F-curves on every mesh of the rig.

    Each frame's simulated pose is fitted by the named targets held near its semantic weights
    (``anim.semantic``: the coarticulated controls of that frame), then by the correctives. The simulation
    is fed ``PHYSICS_LEAD_S`` ahead, since it trails its targets; frames of a lip closure of the take take
    their semantic weights as they are, the closure's viseme alone (``semantic.with_closures``), with no
    corrective. Fitting lagging poses without these made the exported mouth trail the audio and lose most
    closures (``bench/lipsync_accuracy.py``)."""

    def __init__(self, context, obj, targets: dict, part_roles, correctives: bool = True):
        self.obj_name = obj.name
        self.rig = get_rig(obj)
        specs = self.rig.control_specs()
        self.table = animated_table(obj, context.scene, specs)
        if not targets:
            raise UserError("no targets to express the animation with; choose an expression set")
        self.dt = frame_duration(context.scene)
        self.count = len(targets) + (len(specs) if correctives else 0)
        self.total = self.count + len(self.table)
        self.label = f"Baking {len(self.table)} frames as weights of {self.count} targets"
        kernel.expect_frames(len(self.table))
        cache = shape_cache()
        shapes = baking.expression_shapes(self.rig, targets, cache=cache)
        self.targets = itertools.chain(shapes, baking.basis_shapes(self.rig, cache=shape_cache())) if correctives else shapes
        self.primary, self.shapes = len(targets), []
        parts_now = parts(obj)
        self.part_rest = {role: shape_keys.rest_vertices(parts_now[role]).astype(np.float64)
                          for role in part_roles if role in parts_now}
        self.to_local = output_to_local(obj)
        prior = semantic.semantic_weights(self.table, targets, specs)   # what each frame means
        closed = semantic.closure_frames(self.table.frames, closure_spans(obj))
        self.prior = semantic.with_closures(prior, list(targets), closed)
        self.closed = np.zeros(len(self.table), bool)
        self.closed[list(closed)] = True
        # the simulation fed ahead, so the correctives it leaves over are on time too
        self.sim_table = controls.sample_layers(obj, context.scene, specs, self.table.frames,
                                                lead=PHYSICS_LEAD_S / self.dt)
        self.solver = self.frames = None
        self.weights, self.residual = [], []
        # the fit of a block runs on a second thread while the next block is simulated (the compiled fit
        # releases the GIL); one worker, so the blocks are fitted in order (the fit starts each frame where
        # the last one ended: same order, same bytes)
        self._fitter = ThreadPoolExecutor(1, thread_name_prefix="fh-fit")
        self._fits, self._submitted = [], 0

    def _local_stack(self, pose) -> np.ndarray:
        skin = pose.positions["skin"].astype(np.float64) @ self.to_local[:3, :3].T + self.to_local[:3, 3]
        return weights.stack_pose(skin, self.part_rest, pose.transforms)

    def _start_frames(self) -> None:
        rest = self._local_stack(self.rig.rest_pose())
        sets = [self.shapes[:self.primary], self.shapes[self.primary:]]
        bases = [weights.TargetBasis(tuple(s.name for s in shapes),
                                     np.stack([self._local_stack(s.pose) - rest for s in shapes]))
                 for shapes in sets if shapes]
        self.solver, self.rest = weights.WeightSolver(*bases), rest
        self.frames = baking.animation_poses(self.rig, self.sim_table, self.dt)

    def step(self) -> float:
        if self.frames is None:
            shape = next(self.targets, None)
            if shape is None:
                self._start_frames()
            else:
                self.shapes.append(shape)
            return min(len(self.shapes) / self.total, 0.999)
        block = [self._local_stack(shape.pose) - self.rest for shape in
                 (next(self.frames, None) for _ in range(FRAME_BLOCK)) if shape is not None]
        if block:
            rows = slice(self._submitted, self._submitted + len(block))
            self._fits.append(self._fitter.submit(self.solver.solve_many, np.stack(block), self.prior[rows],
                                                  self.closed[rows]))
            self._submitted += len(block)
        finished = not block or self._submitted >= len(self.table)
        while self._fits and (finished or self._fits[0].done()):
            w, r = self._fits.pop(0).result()
            self.weights.append(w)
            self.residual.append(r)
        done = sum(len(w) for w in self.weights)
        return 1.0 if finished else min((len(self.shapes) + done) / self.total, 0.999)

    def cleanup(self) -> None:
        """Stop the fitting thread (after the commit, or when cancelled: a block under way finishes)."""
        self._fitter.shutdown(wait=True, cancel_futures=True)
        super().cleanup()

    def fit(self) -> weights.WeightFit:
        return weights.WeightFit(self.solver.names, np.concatenate(self.weights), np.concatenate(self.residual))

    def commit(self, context) -> str:
        obj = bpy.data.objects[self.obj_name]
        fit = self.fit()
        shape_keys.remove_keys(obj, shape_keys.FRAME_PREFIX)
        names = shape_keys.commit_shapes(obj, self.shapes)
        shape_keys.commit_weights(obj, names, self.table.frames, fit.weights)
        median, p90, worst = fit.residual_mm()
        return (f"Baked {len(self.table)} frames as weights of {len(names)} targets on '{obj.name}' "
                f"(fit residual median {median:.2f} mm, p90 {p90:.2f} mm, max {worst:.2f} mm)")
