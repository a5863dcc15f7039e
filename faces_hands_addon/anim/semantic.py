# SPDX-License-Identifier: GPL-3.0-or-later
"""What each frame of an animation *means* in named targets, read from its controls rather than its shape.

Every named target (an ARKit shape, a viseme, an emotion) is a set of control values (``presets/
expressions``), and every frame of a rig's animation is a sum of control layers (``layers``: the artist's
``ctrl``, ``speech``, ``behavior``, ``emotion``). A frame's *semantic* weights are the non-negative weights
of the targets whose control values add up to the frame's (bounded least squares in control space, each
control measured in its range so jaw and lids count alike). The speech layer is the Cohen-Massaro weighted
average of articulation targets (thesis 3.1.3, Eq. 3.1: sum_k D_k T_k / sum_k D_k), so the visemes explain
it; the other layers are explained by the remaining targets (ARKit, emotions). These weights keep the
meaning a retargeted character needs (a /p/ is ``viseme_PP``, never a mix of frowns that happens to look
alike on this one head) and follow the controls on time; ``weights.WeightSolver`` then lets the simulated
shape refine them, held near them by a prior.
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from ..core.controls import ControlSpec, clamp_controls
from .layers import BASE_LAYER, LayerTable
from .weights import bounded_nnls

__all__ = ["SPEECH_LAYER", "is_viseme", "control_matrix", "semantic_weights", "closure_frames", "with_closures",
           "with_closed_controls"]

SPEECH_LAYER = "speech"


def is_viseme(name: str) -> bool:
    return name.startswith("viseme_")


def _spans(controls, specs: Mapping[str, ControlSpec]) -> np.ndarray:
    return np.array([max(specs[c].maximum - specs[c].minimum, 1e-9) for c in controls])


def control_matrix(targets: Mapping[str, Mapping[str, float]], specs: Mapping[str, ControlSpec],
                   controls) -> np.ndarray:
    """(T, C): each target's control offsets from the defaults, in units of each control's range."""
    defaults = np.array([specs[c].default for c in controls])
    rows = []
    for expression in targets.values():
        values = clamp_controls(expression, specs, strict=True)
        rows.append(np.array([values.get(c, specs[c].default) for c in controls]) - defaults)
    return (np.array(rows) if rows else np.zeros((0, len(controls)))) / _spans(controls, specs)


def _layer_offsets(table: LayerTable, specs: Mapping[str, ControlSpec]) -> tuple[np.ndarray, np.ndarray]:
    """(speech, other): per frame, the speech layer and the sum of the other layers minus the defaults, both
    in units of each control's range."""
    spans = _spans(table.controls, specs)
    defaults = np.array([specs[c].default for c in table.controls])
    zero = np.zeros((len(table), len(table.controls)))
    speech = table.values.get(SPEECH_LAYER, zero)
    other = sum((values - (defaults if layer == BASE_LAYER else 0.0)
                 for layer, values in table.values.items() if layer != SPEECH_LAYER), zero)
    return speech / spans, _per_eye_gaze(other / spans, list(table.controls))


#: conjugate gaze -> the per-eye controls the ARKit look keys drive (the face rig adds them, ``eye_gaze``)
CONJUGATE = {"eye_yaw": ("eye_yaw_L", "eye_yaw_R"), "eye_pitch": ("eye_pitch_L", "eye_pitch_R")}


def _per_eye_gaze(offsets: np.ndarray, controls: list[str]) -> np.ndarray:
    """Offsets with the conjugate gaze moved onto each eye's own control (same range), so that one look
    key per eye explains it (eyeLookOutLeft + eyeLookInRight for a glance to the character's left)."""
    out = offsets.copy()
    for both, (left, right) in CONJUGATE.items():
        if both in controls and left in controls and right in controls:
            column = out[:, controls.index(both)].copy()
            out[:, controls.index(left)] += column
            out[:, controls.index(right)] += column
            out[:, controls.index(both)] = 0.0
    return out


def _fit(matrix: np.ndarray, frames: np.ndarray) -> np.ndarray:
    if not len(matrix):
        return np.zeros((len(frames), 0))
    return np.stack([bounded_nnls(matrix.T, row) if np.any(row) else np.zeros(len(matrix)) for row in frames])


def semantic_weights(table: LayerTable, targets: Mapping[str, Mapping[str, float]],
                     specs: Mapping[str, ControlSpec], owned_rows: Mapping[int, frozenset] | None = None
                     ) -> np.ndarray:
    """(F, T) semantic weights in [0, 1] of ``targets`` (name -> control values) for every frame of
    ``table``: visemes from the speech layer, the other targets from the other layers (module docstring).
    Without visemes among the targets, all targets explain all layers.

    ``owned_rows`` (row -> the controls speech owns there: a lip closure or the labiodental contact,
    ``anim.take.Take.owned_rows``): on those rows the other layers are explained by the targets that leave
    every owned control alone, on the controls speech does not own. In an engine the targets add, so an
    emotion target that also opens the jaw (``surprise``) would part the closed lips of a /p/."""
    names = list(targets)
    matrix = control_matrix(targets, specs, table.controls)
    speech, other = _layer_offsets(table, specs)
    visemes = np.array([is_viseme(n) for n in names], bool)
    weights = np.zeros((len(table), len(names)))
    if not (visemes.any() and (~visemes).any()):
        weights[:] = _fit(matrix, speech + other)
        return weights
    weights[:, visemes] = _fit(matrix[visemes], speech)
    weights[:, ~visemes] = _fit(matrix[~visemes], other)
    groups: dict[frozenset, list[int]] = {}
    for row, owned in (owned_rows or {}).items():
        groups.setdefault(frozenset(owned), []).append(int(row))
    for owned, rows in sorted(groups.items(), key=lambda item: sorted(item[0])):
        columns = np.array([c in owned for c in table.controls], bool)
        if not columns.any():
            continue
        rows = np.array(sorted(rows), np.int64)
        free = ~visemes & (np.abs(matrix[:, columns]).max(axis=1) < 1e-9)
        weights[np.ix_(rows, ~visemes)] = 0.0
        weights[np.ix_(rows, free)] = _fit(matrix[free][:, ~columns], other[rows][:, ~columns])
    return weights


def closure_frames(frames: np.ndarray, spans) -> dict[int, str]:
    """Row -> viseme of the frames that must show a lip closure: for every span (start frame, end frame,
    viseme; fractional frames, ``speech.closures``) each frame inside it, or the frame nearest its middle
    when the span falls between two frames (a closure shorter than a frame still gets a closed sample)."""
    frames = np.asarray(frames, np.float64)
    rows: dict[int, str] = {}
    if not len(frames):
        return rows
    for start, end, viseme in spans:
        inside = np.flatnonzero((frames >= start) & (frames <= end))
        if not len(inside):
            middle = (start + end) / 2
            nearest = int(np.argmin(np.abs(frames - middle)))
            if abs(frames[nearest] - middle) > 1.0:
                continue                                   # outside the baked range
            inside = [nearest]
        for row in inside:
            rows[int(row)] = viseme
    return rows


def with_closures(weights: np.ndarray, names, rows: Mapping[int, str]) -> np.ndarray:
    """``weights`` (F, T) with each closure row showing its viseme alone among the visemes (weight 1, the
    other visemes 0): the lips shut whatever the neighbouring phones' tongue and jaw targets add. The other
    targets (ARKit, emotions: the other layers) are kept."""
    out = np.array(weights, np.float64, copy=True)
    names = list(names)
    visemes = np.array([is_viseme(n) for n in names], bool)
    for row, viseme in rows.items():
        if viseme in names:
            out[row, visemes] = 0.0
            out[row, names.index(viseme)] = 1.0
    return out


def with_closed_controls(table: LayerTable, rows: Mapping[int, str], targets: Mapping[str, Mapping[str, float]],
                         specs: Mapping[str, ControlSpec]) -> LayerTable:
    """``table`` with the speech layer of each closure row set to its viseme's articulation (the viseme
    target's offsets from the defaults, every other speech control 0): what a simulation is fed so that its
    lips shut on those frames. Rows whose viseme is not among ``targets`` are left as they are."""
    values = {layer: array.copy() for layer, array in table.values.items()}
    speech = values.setdefault(SPEECH_LAYER, np.zeros((len(table), len(table.controls))))
    for row, viseme in rows.items():
        if viseme not in targets:
            continue
        closed = clamp_controls(targets[viseme], specs, strict=True)
        speech[row] = [closed.get(c, specs[c].default) - specs[c].default for c in table.controls]
    return LayerTable(table.frames, table.controls, values)
