# SPDX-License-Identifier: GPL-3.0-or-later
"""What an animation bake simulates and fits, from a :class:`.take.Take` (plain data, never Blender).

* :func:`weights_inputs`: the engine-ready weights bake (``weights.WeightSolver``): the take's layer table at
  the scene's frames, the same table ``PHYSICS_LEAD_S`` ahead for the simulation (it trails its targets),
  each frame's semantic weights (``semantic``, with speech owning the lips on the rows of a closure or the
  labiodental contact) and the lip closures' rows, whose semantic weights are kept as they are.
* :func:`cache_inputs`: the exact per-frame cache: the table fed ahead, and for the take's lip closures an
  ``closure_drive.ClosureDrive`` that feeds each closure's viseme articulation early enough that the
  simulated lips have met when it starts (``CLOSURE_RAMP_S`` before it at least, ``CLOSURE_MAX_LEAD_S`` at
  most). On Festival's 121 bilabials (``bench/lipsync_accuracy.py --cache``) the fixed 2-frame lead alone
  closed 93.4 %, the drive 100 %.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ..core.controls import ControlSpec
from ..core.errors import UserError
from . import closure_drive, semantic
from .layers import LayerTable
from .take import Take

__all__ = ["PHYSICS_LEAD_S", "CLOSURE_RAMP_S", "CLOSURE_MAX_LEAD_S", "WeightsInputs", "weights_inputs",
           "cache_inputs", "animated_table"]

PHYSICS_LEAD_S = 0.030        # animation bakes feed the simulation this far ahead: it trails its targets
CLOSURE_RAMP_S = 0.067        # the cache closes the lips at least this long before a closure starts (2 frames at 30 fps)
CLOSURE_MAX_LEAD_S = 0.2      # ... and at most this long, when the lips are far apart (closure_drive)


def animated_table(take: Take, specs: Mapping[str, ControlSpec], frames, fps: float, start_frame: float,
                   max_frames: int | None = None) -> LayerTable:
    """The take's layer table at ``frames``, or a UserError when nothing in it changes (a bake of a still
    face would write a take of nothing) or when it has more than ``max_frames`` frames (the per-frame cache
    writes one shape key per frame; the weights bake streams its frames and has no limit)."""
    frames = np.asarray(list(frames), np.int64)
    if not len(frames):
        raise UserError("the frame range is empty: set the scene's start and end frames")
    if max_frames is not None and len(frames) > max_frames:
        raise UserError(f"{len(frames)} frames is more than the {max_frames} a per-frame cache bakes (one shape "
                        "key per frame); bake the animation as weights (the default), which has no frame limit, "
                        "or bake the frame range in parts")
    table = take.table(specs, frames, fps, start_frame)
    if not any(np.ptp(values, axis=0).max(initial=0.0) > 0 for values in table.values.values()):
        raise UserError(f"nothing is animated between frames {frames[0]} and {frames[-1]}: key some controls "
                        "(or put a speech take on the rig) before baking the animation")
    return table


@dataclass
class WeightsInputs:
    """The weights bake's inputs: ``table`` (what each frame means), ``sim_table`` (what the simulation is
    fed), ``prior`` (F, T) semantic weights, ``closed`` (F,) rows of a lip closure."""
    table: LayerTable
    sim_table: LayerTable
    prior: np.ndarray
    closed: np.ndarray


def weights_inputs(take: Take, specs: Mapping[str, ControlSpec], targets: Mapping[str, Mapping[str, float]],
                   frames, fps: float, start_frame: float) -> WeightsInputs:
    """The inputs of the engine-ready weights bake of ``take`` at ``frames`` (module docstring)."""
    table = animated_table(take, specs, frames, fps, start_frame)
    closed_rows = semantic.closure_frames(table.frames, take.closure_frames(fps, start_frame))
    owned = take.owned_rows(table.frames, fps, start_frame)
    prior = semantic.semantic_weights(table, targets, specs, owned)
    prior = semantic.with_closures(prior, list(targets), closed_rows)
    closed = np.zeros(len(table), bool)
    closed[list(closed_rows)] = True
    sim_table = take.table(specs, table.frames, fps, start_frame, lead=PHYSICS_LEAD_S * fps)
    return WeightsInputs(table, sim_table, prior, closed)


def cache_inputs(take: Take, specs: Mapping[str, ControlSpec], targets: Mapping[str, Mapping[str, float]],
                 table: LayerTable, fps: float, start_frame: float):
    """What the per-frame cache simulates for ``table`` (the take's table at the bake's frames): the layers
    ``PHYSICS_LEAD_S`` ahead and, for the take's lip closures on the frames shown during them, a
    :class:`.closure_drive.ClosureDrive` (module docstring). Returns (table, drive or None)."""
    shifted = take.table(specs, table.frames, fps, start_frame, lead=PHYSICS_LEAD_S * fps)
    frames = np.asarray(table.frames, np.float64)      # closures are checked where they are shown
    max_lead = int(np.ceil(CLOSURE_MAX_LEAD_S * fps))
    spans, rows = [], {}
    for start, end, viseme in take.closure_frames(fps, start_frame):
        must = semantic.closure_frames(frames, [(start, end, viseme)]) if viseme in targets else {}
        if not must:
            continue
        first, last = min(must), max(must)
        always = min(int(np.searchsorted(frames, start - CLOSURE_RAMP_S * fps)), first)
        spans.append((always, first, last))
        rows.update({row: viseme for row in range(max(first - max_lead, 0), last + 1)})
    if not spans:
        return shifted, None
    closed = semantic.with_closed_controls(shifted, rows, targets, specs)
    return shifted, closure_drive.ClosureDrive(closed, sorted(spans), max_lead)
