# SPDX-License-Identifier: GPL-3.0-or-later
"""While the lips articulate, speech owns the muscles that would undo the articulation.

Thesis 4.3.5 sums the speech-related and the emotional contractions; thesis 2.1 cites Bui, Heylen and
Nijholt [BHN04] for combining the channels of a talking head "according to priority, taking into account
conflicts at the muscle level". Summing fails exactly where the channels conflict: a joyful face's jaw
(joy opens it by 0.1, ``presets/emotion/basic_expressions.json``) keeps every /p b m/ 4-5 mm apart, and a
broad smile cannot round the lips for /u w/. This module applies the priority rule at the muscle level and
leaves the layering of 4.3.5 everywhere else:

* an **articulation** (``presets/performance/speech_priority.json``) is a set of speech classes of the
  articulation preset (lip closure: /p b m/; the labiodental contact: /f v/; lip rounding: /u w o/ ...) and
  the controls it **owns**: those that move the lips away from that articulation (the preset names them
  and gives the measurement that chose them);
* while a segment of such a class is spoken, the other layers (behaviour, emotion) lose their owned
  controls: ``value * (1 - share * o(t))``, with ``o(t) = 1`` inside the segment, rising from 0 over the
  articulation's ``lead_s`` before it and falling back to 0 over its ``lag_s`` after it (a smoothstep: no
  jump in value or slope). The face is a mass-spring network (3.1.2) that reaches a target only after its
  own closing time, so the emotion must leave the lips before the closure, not at it: the per-frame bake
  measured that the simulated lips need up to 0.2 s to close from an open vowel (``anim.closure_drive``),
  and a jaw that snaps back within a frame after each /v/ never lets them meet;
* every control an articulation does not own keeps the emotion (a smile stays on the cheeks and the mouth
  corners during /m/), and between articulations the layers sum as before;
* an **exclusive** articulation (the jaw while speaking, the closures, the labiodental contact) also holds
  in the exported weights: over its span (ramps included, which also covers an aligner placing a phone a
  frame or two off) the other layers are shown only by targets that leave its controls alone
  (``anim.semantic.semantic_weights``), since in an engine targets add: the named ``smile`` carries a
  little jaw, ``surprise`` a lot, and either would part a /p/.

The speech layer itself is never changed; neither is the artist's ``ctrl`` layer.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Mapping, Sequence

import numpy as np

from ..anim.tracks import Track, TrackSet
from ..core.errors import UserError
from ..core.presets import NUMBER, PresetFormat, read_preset, register_format
from ..emotion import face_specs
from ..speech.articulation import load_articulation
from ..speech.coarticulation import expand_segments
from ..speech.takes import SpeechTake

__all__ = ["FORMAT", "Articulation", "load_priority", "ownership", "with_speech_priority", "owned_controls",
           "LAYERS_UNDER_SPEECH"]

FORMAT = register_format(PresetFormat(
    "faces_hands.speech_priority", 1, required=("articulations",),
    shape={"about": str, "articulations": {str: {"about": str, "classes": [str], "lead_s": NUMBER,
                                                 "lag_s": NUMBER, "exclusive": bool, "owns": {str: NUMBER}}}}))
PRESET = "performance/speech_priority.json"
#: the layers whose owned controls give way to speech (the artist's ``ctrl`` layer is never touched)
LAYERS_UNDER_SPEECH = ("behavior", "emotion")
_SIDES = ("_L", "_R")


@dataclass(frozen=True)
class Articulation:
    """Speech ``classes`` (articulation preset class names), how long before and after their segments the
    ownership ramps (``lead_s``, ``lag_s``), and the controls it owns (name -> share in [0, 1] of the other
    layers' value that gives way)."""
    name: str
    classes: tuple[str, ...]
    lead_s: float
    lag_s: float
    owns: Mapping[str, float]
    exclusive: bool = False     # in an exported take no target that moves an owned control shows the other layers


def _expanded(owns: Mapping[str, float], known: set[str], source: str, name: str) -> dict[str, float]:
    """``{"mentalis": 1}`` -> ``{"mentalis_L": 1, "mentalis_R": 1}`` where the control is sided."""
    out = {}
    for control, share in owns.items():
        if not 0.0 <= float(share) <= 1.0:
            raise UserError(f"{source}: {name}: the share of {control!r} must be in [0, 1], not {share}")
        sided = [control + side for side in _SIDES if control + side in known]
        names = sided or ([control] if control in known else [])
        if not names:
            raise UserError(f"{source}: {name}: unknown control {control!r}")
        out.update({n: float(share) for n in names})
    return out


def load_priority(known_controls: Sequence[str] | None = None) -> tuple[Articulation, ...]:
    """The articulations of ``presets/performance/speech_priority.json`` (the artist's copy first), checked
    against the articulation preset's classes and the face controls."""
    doc, source = read_preset(PRESET, FORMAT.name)
    speech = load_articulation()
    known = set(known_controls) if known_controls is not None else set(face_specs())
    out = []
    for name, entry in doc["articulations"].items():
        unknown = [c for c in entry["classes"] if c not in speech.class_names]
        if unknown:
            raise UserError(f"{source}: {name}: unknown speech class {unknown[0]!r}; the classes are those of "
                            "presets/speech/articulation.json")
        lead, lag = float(entry.get("lead_s", 0.1)), float(entry.get("lag_s", 0.1))
        if not (0.0 <= lead <= 1.0 and 0.0 <= lag <= 1.0):
            raise UserError(f"{source}: {name}: lead_s and lag_s must be in [0, 1] s")
        out.append(Articulation(str(name), tuple(entry["classes"]), lead, lag,
                                _expanded(entry["owns"], known, source, name), bool(entry.get("exclusive", False))))
    return tuple(out)


def _ramp(distance: np.ndarray, width: float) -> np.ndarray:
    """1 at distance 0 falling to 0 at ``width`` (smoothstep), 0 beyond; a step when ``width`` is 0."""
    if width <= 0:
        return (distance <= 0).astype(np.float64)
    u = np.clip(1.0 - distance / width, 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


def ownership(utterance, articulations: Sequence[Articulation], times: np.ndarray,
              articulation_preset=None) -> dict[str, np.ndarray]:
    """Control -> the share (T,) of the other layers' value that speech owns at ``times``: for every
    articulation, 1 inside its segments and the ramps before and after them (module docstring), times the
    control's share; the largest over the articulations."""
    targets = articulation_preset if articulation_preset is not None else load_articulation()
    segments = [s for s in expand_segments(utterance, targets) if s.phase != "release" and s.duration > 0]
    times = np.asarray(times, np.float64)
    out: dict[str, np.ndarray] = {}
    for articulation in articulations:
        presence = np.zeros(len(times))
        for segment in segments:
            if targets.class_of.get(segment.phone) not in articulation.classes:
                continue
            before = np.clip(segment.start - times, 0.0, None)
            after = np.clip(times - segment.end, 0.0, None)
            presence = np.maximum(presence, np.minimum(_ramp(before, articulation.lead_s),
                                                       _ramp(after, articulation.lag_s)))
        for control, share in articulation.owns.items():
            owned = share * presence
            out[control] = np.maximum(out[control], owned) if control in out else owned
    return out


def owned_controls(articulations: Sequence[Articulation], name: str) -> frozenset[str]:
    """The controls articulation ``name`` owns fully or in part."""
    return frozenset(c for a in articulations if a.name == name for c, share in a.owns.items() if share > 0)


def with_speech_priority(take: SpeechTake, articulations: Sequence[Articulation] | None = None) -> SpeechTake:
    """``take`` with the owned controls of its behaviour and emotion layers giving way to speech (module
    docstring). The changed tracks are sampled where they were and at the speech layer's key times (the
    frames plus the closures' key frames, 3.1.3), so the give-way follows the lips frame by frame."""
    if take.target != "muscles" or not any(layer in take.layers for layer in LAYERS_UNDER_SPEECH):
        return take
    articulations = load_priority() if articulations is None else articulations
    layers = dict(take.layers)
    under = [layers[name] for name in LAYERS_UNDER_SPEECH if name in layers]
    grid = np.unique(np.concatenate([t.times for tracks in (take.tracks, *under) for t in tracks]))
    owned = ownership(take.utterance, articulations, grid)
    for name in LAYERS_UNDER_SPEECH:
        if name not in layers:
            continue
        given = TrackSet()
        for track in layers[name]:
            share = owned.get(track.name)
            if share is None or not share.any():
                given.add(track)
                continue
            inside = (grid >= track.start) & (grid <= max(track.end, take.duration))
            given.add(Track(track.name, grid[inside], track.sample(grid[inside]) * (1.0 - share[inside])))
        layers[name] = given
    return replace(take, layers=layers)
