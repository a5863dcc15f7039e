# SPDX-License-Identifier: GPL-3.0-or-later
"""Which way does the head look? The 24 axis-aligned orientations, scored by face likelihood.

Thesis 3.1.2 "Creating New Animatable Head Models from the Template" places the template's feature points
"at corresponding locations on the target skin mesh"; that needs the face found first, whatever axes the
artist's file uses. Every proper rotation that maps the world axes onto the canonical ones (face along -Y,
top along +Z) is tried: 6 directions for the face x 4 for the top = 24 hypotheses (the rotation group of
the cube). Each is scored with the depth-image template match of :mod:`.align` (masked squared depth
difference to the canonical face's relief, Lewis 1995; ~0.1 a face, ~1 no face-like relief). The best few
are searched again at face resolution and, when not conclusive, all 24 at full resolution and the best
three with pitch/yaw/roll tilts of 10-30 degrees composed onto them (those of :data:`.align.FACINGS` and
+-30), so heads tilted between the axes are found too (the scaled rigid ICP that follows removes what is
left). A mesh mirrored front to back is a proper rotation of its own
mirror image (a head is near-symmetric), so it is found like any other.

``forward``/``up`` (e.g. ``"-Y"``, ``"+Z"``) override the search: only that orientation and its tilts.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import UserError
from .align import (COARSE_SAMPLES, COARSE_SCALES, FACINGS, DepthMatch, Facing, tilted_front, refine_search,
                    search_orientations, surface_samples)

__all__ = ["AXES", "AXIS_VECTORS", "axis_facing", "ORIENTATIONS", "OrientationChoice", "choose_orientation",
           "orientation_name"]

AXIS_VECTORS = {"+X": (1, 0, 0), "-X": (-1, 0, 0), "+Y": (0, 1, 0), "-Y": (0, -1, 0),
                "+Z": (0, 0, 1), "-Z": (0, 0, -1)}
AXES = tuple(AXIS_VECTORS)
_FACE_SCORE_LIMIT = 0.6     # depth-search score above which no face-like relief was found (as before)
_CONCLUSIVE = 0.3           # a refined score below this, beating every rival, ends the search
_REFINED = 3                # the best coarse orientations searched again at face resolution
_SCREEN_PIXELS = 40         # depth-image resolution of that screen (the full search: 64)
_SCREENED = 6               # orientations kept from the quick screen (every other scale) for the full ladder


def orientation_name(forward, up) -> str:
    """``"forward -Y, up +Z"`` for axis vectors (or the nearest axis names of tilted vectors)."""
    def name(vector):
        vector = np.asarray(vector, float)
        k = int(np.argmax(np.abs(vector)))
        return ("+" if vector[k] > 0 else "-") + "XYZ"[k]
    return f"forward {name(forward)}, up {name(up)}"


def axis_facing(forward: str, up: str) -> Facing:
    """The orientation whose face looks along axis ``forward`` and whose top points along ``up``."""
    for label, value in (("forward", forward), ("up", up)):
        if value not in AXIS_VECTORS:
            raise UserError(f"{label} axis {value!r} must be one of {', '.join(AXES)}")
    f, u = np.asarray(AXIS_VECTORS[forward], float), np.asarray(AXIS_VECTORS[up], float)
    if abs(float(f @ u)) > 0.5:
        raise UserError(f"forward {forward} and up {up} must be perpendicular axes (e.g. forward -Y, up +Z)")
    return Facing(orientation_name(f, u), tuple(f), tuple(u), "", front=True)


ORIENTATIONS = tuple(axis_facing(f, u) for f in AXES for u in AXES if abs(np.dot(AXIS_VECTORS[f], AXIS_VECTORS[u])) < 0.5)
# -Y / Z-up pitched, yawed (+-15, +-30 degrees) and rolled (+-10, +-30): with the rigid ICP after it, this
# reaches heads up to ~45 degrees between two axis orientations
_TILTS = tuple(f for f in FACINGS if f.front and f.name != "-Y") + tuple(
    tilted_front(f"-Y {kind} {angle:+d}", axis, angle) for kind, axis in (("pitch", 0), ("yaw", 2), ("roll", 1))
    for angle in (-30, 30))
_TILTED = 3                 # coarse winners the tilts are tried on
_AUX_SEED = 0x0F17          # the random stream of the rivals' refinements and the tilts (deterministic)


def _tilted(base: Facing, tilt: Facing) -> Facing:
    """``tilt`` (given for the canonical -Y / Z-up frame) applied on top of ``base``."""
    to_world = base.rotation().T
    forward = to_world @ np.asarray(tilt.forward, float)
    up = to_world @ np.asarray(tilt.up, float)
    return Facing(f"{base.name} ({tilt.name[3:]})", tuple(forward), tuple(up), "", front=True)


@dataclass(frozen=True)
class OrientationChoice:
    """The chosen orientation and how clearly it won.

    ``ranking`` lists (orientation name, coarse score) of all hypotheses tried, best first; ``margin`` is
    the runner-up's refined score over the winner's (a different face direction or a different top; 1.0
    when only one orientation was tried), so > 1.3 is a clear choice and ~1 an ambiguous one."""
    match: DepthMatch
    ranking: tuple
    margin: float
    forced: bool
    runners_up: tuple = ()        # refined matches of other orientations that still look like a face, best first

    @property
    def name(self) -> str:
        return orientation_name(self.match.facing.forward, self.match.facing.up)

    def report(self) -> dict:
        return {"orientation": self.name, "score": float(self.match.score), "margin": float(self.margin),
                "forced": self.forced, "ranking": [list(r) for r in self.ranking[:6]]}


def _distinct(a: Facing, b: Facing) -> bool:
    """Two hypotheses are rivals unless they share (nearly) both the face direction and the top."""
    return (float(np.dot(a.forward, b.forward)) < 0.9) or (float(np.dot(a.up, b.up)) < 0.9)


def choose_orientation(vertices, faces, areas, template, rng, *, forward: str | None = None,
                       up: str | None = None) -> OrientationChoice:
    """Search the face in the 24 orientations (or only in ``forward``/``up``; module docstring).

    Raises :class:`UserError` when no orientation shows a face-like relief."""
    if (forward is None) != (up is None):
        raise UserError("give both the forward and the up axis of the head (e.g. forward -Y, up +Z), or neither")
    forced = forward is not None
    candidates = (axis_facing(forward, up),) if forced else ORIENTATIONS
    # One draw of surface samples for every coarse search, and ``rng`` used further only for the winner's
    # refinement (the rivals' and the tilts' use ``aux``): the caller's random stream, hence the fit after
    # this, does not depend on how many hypotheses were tried (an upright head is fitted as before).
    samples = surface_samples(vertices, faces, areas, COARSE_SAMPLES, rng)
    aux = np.random.default_rng(_AUX_SEED)
    screened_out = ()
    if len(candidates) > _SCREENED:       # quick screen on every other scale, then the full ladder
        screen = sorted(search_orientations(vertices, faces, areas, template, rng, candidates, COARSE_SCALES[::2],
                                            pixels=_SCREEN_PIXELS, samples=samples), key=lambda m: m.score)
        candidates = tuple(m.facing for m in screen[:_SCREENED])
        screened_out = tuple(m.facing for m in screen[_SCREENED:])
    coarse = sorted(search_orientations(vertices, faces, areas, template, rng, candidates, samples=samples),
                    key=lambda m: m.score)
    if not coarse:
        raise UserError("could not find a face on the mesh: in no orientation does it cover enough area to "
                        "hold a face; check that it is a head or a face mask")
    refined = [refine_search(vertices, faces, areas, template, m, rng if i == 0 else aux)
               for i, m in enumerate(coarse[:_REFINED])]
    refined.sort(key=lambda m: m.score)
    best = refined[0]
    rivals = [m for m in refined[1:] if _distinct(m.facing, best.facing)]
    if best.score > _CONCLUSIVE or (rivals and rivals[0].score < 1.3 * best.score):
        # not conclusive (a head between the axes, or no face): every orientation at the full ladder, then
        # tilts of up to 30 degrees about each axis on the best few and on -Y / Z up (the depth match is
        # sharp: a face pitched 25 degrees scores ~0.6 untilted, ~0.15 with the tilt that undoes it)
        coarse = sorted(coarse + search_orientations(vertices, faces, areas, template, aux, screened_out,
                                                     samples=samples), key=lambda m: m.score)
        bases = [m.facing for m in coarse[:_TILTED]]
        default = axis_facing("-Y", "+Z") if not forced else axis_facing(forward, up)
        if all(_distinct(b, default) for b in bases):
            bases.append(default)          # Blender's front view: a head tilted from it is the common case
        tilted = tuple(_tilted(b, t) for b in bases for t in _TILTS)
        more = search_orientations(vertices, faces, areas, template, aux, tilted, samples=samples)
        more = [refine_search(vertices, faces, areas, template, m, aux)
                for m in sorted(more, key=lambda m: m.score)[:_REFINED]]
        refined = sorted(refined + more, key=lambda m: m.score)
        best = refined[0]
        rivals = [m for m in refined[1:] if _distinct(m.facing, best.facing)]
    ranking = tuple((orientation_name(m.facing.forward, m.facing.up), round(float(m.score), 4)) for m in coarse)
    if best.score > _FACE_SCORE_LIMIT:
        where = f"with forward {forward}, up {up}" if forced else "in any of the 24 axis orientations"
        raise UserError(f"could not find a face on the mesh: no nose/eyes/mouth relief {where} (face-match "
                        f"score {best.score:.2f}, limit {_FACE_SCORE_LIMIT}); the mesh must be a human head or "
                        "face mask" + ("" if forced else "; if it is, give its axes with --forward/--up"))
    others = rivals + [m for m in coarse if _distinct(m.facing, best.facing)]
    margin = float(min(m.score for m in others) / best.score) if others else 1.0
    return OrientationChoice(best, ranking, margin, forced, _runners_up(best, rivals))


def _runners_up(best: DepthMatch, rivals: list) -> tuple:
    """The refined rivals that still show a face-like relief, one per orientation, best first: what the fit
    tries next when the winner's fit does not look like a face (a near tie, ``margin`` ~1)."""
    kept, seen = [], {orientation_name(best.facing.forward, best.facing.up)}
    for match in sorted(rivals, key=lambda m: m.score):
        name = orientation_name(match.facing.forward, match.facing.up)      # a tilt counts as its nearest axes
        if match.score <= _FACE_SCORE_LIMIT and name not in seen:
            kept.append(match)
            seen.add(name)
    return tuple(kept)
