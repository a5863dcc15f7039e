# SPDX-License-Identifier: GPL-3.0-or-later
"""The bakes of any rig, as plain data in and plain data out, a step at a time (a Blender job runs the
steps and commits the result; ``blender -b``, the CLI and tests run the same steps).

* :class:`ShapesBake`: static shapes, the muscle basis (``FH.<control>``) or named expressions, each settled
  from rest (:func:`.baking.basis_shapes`, :func:`.baking.expression_shapes`);
* :class:`CacheBake`: the exact per-frame cache of a :class:`.take.Take` (one pose per frame, lip
  closures driven by :class:`.closure_drive.ClosureDrive`);
* :class:`WeightsBake`: the engine-ready weights of a take: the fixed target set and the rig's correctives
  baked once, every frame simulated and fitted by :class:`.weights.WeightSolver` held near its semantic
  weights (:func:`.bake_inputs.weights_inputs`). Frames of a lip closure keep their semantic weights as they
  are (the closure's viseme alone), with no corrective: fitting lagging poses made the exported mouth trail
  the audio and lose most closures (``bench/lipsync_accuracy.py``).

Nothing here reads Blender: a take comes in as a :class:`.take.Take`, the meshes of a rig's parts as rest
arrays, the rig's output space as a matrix.
"""
from __future__ import annotations

import itertools
from concurrent.futures import ThreadPoolExecutor
from typing import Mapping

import numpy as np

from ..core.errors import UserError
from . import baking, bake_inputs, weights
from .take import Take

__all__ = ["MAX_CACHE_FRAMES", "FRAME_BLOCK", "ShapesBake", "CacheBake", "WeightsBake"]

MAX_CACHE_FRAMES = 5000       # per-frame cache only: one shape key per frame
FRAME_BLOCK = 64              # frames simulated and fitted per step of the weights bake


class _Steps:
    """A generator of shapes run one item per :meth:`step` (progress in [0, 1], 1 when done)."""

    def __init__(self, generator, total: int, label: str):
        self.generator, self.total, self.label = generator, total, label
        self.shapes: list = []

    def step(self) -> float:
        shape = next(self.generator, None)
        if shape is None:
            return 1.0
        self.shapes.append(shape)
        return min(len(self.shapes) / max(self.total, 1), 0.999)

    def close(self) -> None:
        self.generator.close()


class ShapesBake(_Steps):
    """The muscle basis (``expressions=None``) or the named ``expressions`` (name -> partial control dict)."""

    def __init__(self, rig, expressions: Mapping[str, Mapping[str, float]] | None = None, cache=None):
        if expressions is None:
            specs = rig.control_specs()
            super().__init__(baking.basis_shapes(rig, cache=cache), len(specs), "Baking muscle basis")
            return
        expressions = dict(expressions)
        if not expressions:
            raise UserError("no expressions to bake; choose an expression set")
        super().__init__(baking.expression_shapes(rig, expressions, cache=cache), len(expressions),
                         f"Baking {len(expressions)} expressions")


class CacheBake(_Steps):
    """The exact per-frame cache of ``take`` at ``frames`` (``targets``: the expressions whose visemes show
    the take's lip closures)."""

    def __init__(self, rig, take: Take, frames, fps: float, start_frame: float,
                 targets: Mapping[str, Mapping[str, float]]):
        specs = rig.control_specs()
        table = bake_inputs.animated_table(take, specs, frames, fps, start_frame, MAX_CACHE_FRAMES)
        table, self.drive = bake_inputs.cache_inputs(take, specs, targets, table, fps, start_frame)
        super().__init__(baking.animation_poses(rig, table, 1.0 / fps, drive=self.drive), len(table),
                         f"Baking {len(table)} frames")


class WeightsBake:
    """The animation of ``take`` at ``frames`` as engine-ready weights of ``targets`` (name -> expression)
    and, with ``correctives``, the rig's muscle basis. ``part_rest``: role -> rest vertices (float64, the
    object's local space) of the meshes the weights drive; ``to_local``: the rig's output space -> that
    local space (4x4)."""

    def __init__(self, rig, take: Take, frames, fps: float, start_frame: float,
                 targets: Mapping[str, Mapping[str, float]], part_rest: Mapping[str, np.ndarray],
                 to_local: np.ndarray, correctives: bool = True, cache=None):
        if not targets:
            raise UserError("no targets to express the animation with; choose an expression set")
        self.rig = rig
        specs = rig.control_specs()
        self.inputs = bake_inputs.weights_inputs(take, specs, targets, frames, fps, start_frame)
        self.table = self.inputs.table
        self.dt = 1.0 / fps
        self.count = len(targets) + (len(specs) if correctives else 0)
        self.total = self.count + len(self.table)
        self.label = f"Baking {len(self.table)} frames as weights of {self.count} targets"
        shapes = baking.expression_shapes(rig, dict(targets), cache=cache)
        self.targets = itertools.chain(shapes, baking.basis_shapes(rig, cache=cache)) if correctives else shapes
        self.primary, self.shapes = len(targets), []
        self.part_rest = {role: np.asarray(rest, np.float64) for role, rest in part_rest.items()}
        self.to_local = np.asarray(to_local, np.float64)
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
        self.frames = baking.animation_poses(self.rig, self.inputs.sim_table, self.dt)

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
            self._fits.append(self._fitter.submit(self.solver.solve_many, np.stack(block), self.inputs.prior[rows],
                                                  self.inputs.closed[rows]))
            self._submitted += len(block)
        finished = not block or self._submitted >= len(self.table)
        while self._fits and (finished or self._fits[0].done()):
            w, r = self._fits.pop(0).result()
            self.weights.append(w)
            self.residual.append(r)
        done = sum(len(w) for w in self.weights)
        return 1.0 if finished else min((len(self.shapes) + done) / self.total, 0.999)

    def close(self) -> None:
        """Stop the fitting thread (after the commit, or when cancelled: a block under way finishes)."""
        self._fitter.shutdown(wait=True, cancel_futures=True)

    def fit(self) -> weights.WeightFit:
        return weights.WeightFit(self.solver.names, np.concatenate(self.weights), np.concatenate(self.residual))
