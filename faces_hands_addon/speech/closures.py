# SPDX-License-Identifier: GPL-3.0-or-later
"""The lip closures of a take: when the lips must be shut, in seconds, from its phones.

Thesis 3.1.3 splits /p b/ into a closure and a release (``closure_fraction`` of the segment closed, from
the articulation preset's ``phases``) and treats /m/ as one closure. Those intervals are what a viewer
checks first: a /p b m/ whose lips never meet reads as a mistake. The coarticulated curves close them
(high closure magnitudes), but an exported animation is sampled once per frame and a simulation trails
its targets, so the bakes (``anim.semantic.with_closures``) use these intervals to guarantee a closed
sample for every bilabial: every frame inside a closure, or the frame nearest its middle when none is.

A run of bilabials ("bumpy": m p) is one closure from the first phone's start to the last closure's end.
"""
from __future__ import annotations

from dataclasses import dataclass

from .articulation import load_articulation
from .phonemes import viseme_of

__all__ = ["LipClosure", "BILABIAL_VISEME", "lip_closures"]

BILABIAL_VISEME = "viseme_PP"


@dataclass(frozen=True)
class LipClosure:
    """Lips shut from ``start`` to ``end`` (seconds), showing ``viseme``."""
    start: float
    end: float
    viseme: str = BILABIAL_VISEME


def lip_closures(phones, articulation=None) -> list[LipClosure]:
    """The closures of ``phones`` (:class:`.utterance.Phone`): bilabials only (``viseme_PP``); phones the
    articulation preset (``articulation``, default the muscle preset) gives a closure and a release are
    closed for their first ``closure_fraction``, the others throughout."""
    articulation = articulation if articulation is not None else load_articulation()
    closure_fraction = articulation.closure_fraction
    spans: list[list[float]] = []
    previous_end = None
    for phone in phones:
        if viseme_of(phone.phone) != BILABIAL_VISEME:
            previous_end = None
            continue
        start, end = float(phone.start), float(phone.start + phone.duration)
        closed_end = start + closure_fraction * (end - start) if articulation.phase(phone.phone) == "closure_release" \
            else end
        if previous_end is not None and spans and abs(start - previous_end) < 1e-6:
            spans[-1][1] = max(spans[-1][1], closed_end)
        else:
            spans.append([start, closed_end])
        previous_end = end
    return [LipClosure(a, b) for a, b in spans if b > a]
