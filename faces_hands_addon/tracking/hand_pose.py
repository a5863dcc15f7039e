# SPDX-License-Identifier: GPL-3.0-or-later
"""Hand poses from labelled glove markers (thesis 6.3.2 "Visualization of the Hand"), with the automatic
labelling the thesis proposed ("assigns the marker labels in each cluster according to the colors of their
neighboring markers"; it labelled by hand).

1. *Root*: every triple of markers with the colours of the three back-of-hand markers and their mutual
   distances (within a few millimetres) is a candidate; Horn's closed-form absolute orientation [Hor87] aligns
   the model's back markers to it.
2. *Fingers*: along each finger's hierarchy, "for each joint, we compute the rotation angle that minimizes
   the distance between the position of the next marker along the hand model's hierarchy and its
   corresponding tracked marker": bounded least squares over that joint's degrees of freedom within Table
   6.4's limits (a rotation coupled to flexion follows it). The next marker's label is the one of its colour
   that the joint can reach best; if none is within reach (hidden finger), the joint keeps its prior angle and
   the following joint is solved together with it from the marker after.
3. The root candidate whose fingers fit best wins; its labels are the labelling.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from .glove import GloveLayout

__all__ = ["horn", "HandPose", "solve_hand", "CHAINS", "couple_rotations"]

CHAINS = {
    "thumb": [("thumb-metacarpal", "thumb_mcp"), ("thumb-phalanx-proximal", "thumb_ip"),
              ("thumb-phalanx-distal", "thumb_nail")],
    **{f: [(f"{f}-finger-phalanx-proximal", f"{f}_pip"), (f"{f}-finger-phalanx-intermediate", f"{f}_dip"),
           (f"{f}-finger-phalanx-distal", f"{f}_nail")] for f in ("index", "middle", "ring", "pinky")},
}
REACH = 0.006          # m: a marker farther than this from where the joint can put it is not that marker
BACK_TOLERANCE = 0.005


def horn(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Horn's closed-form absolute orientation with unit quaternions [Hor87]: the 4x4 rigid transform
    taking ``source`` (N >= 3, 3) onto ``target`` in the least-squares sense."""
    cs, ct = source.mean(axis=0), target.mean(axis=0)
    m = (source - cs).T @ (target - ct)
    sxx, sxy, sxz, syx, syy, syz, szx, szy, szz = m.ravel()
    n = np.array([[sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
                  [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
                  [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
                  [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz]])
    values, vectors = np.linalg.eigh(n)
    w, x, y, z = vectors[:, -1]
    r = np.array([[w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
                  [2 * (y * x + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
                  [2 * (z * x - w * y), 2 * (z * y + w * x), w * w - x * x - y * y + z * z]])
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = r, ct - r @ cs
    return out


@dataclass
class HandPose:
    """One reconstructed hand exposure: ``root`` (4x4, rest hand -> world), ``angles`` (DOF radians),
    ``labels`` (marker name -> index into the cluster's points), ``solved`` (names of the DOFs fitted to a
    marker), ``residual`` (m, mean marker distance)."""
    root: np.ndarray
    angles: np.ndarray
    labels: dict
    solved: list = field(default_factory=list)
    residual: float = 0.0
    missing: list = field(default_factory=list)


def _free_dofs(skeleton, bone: str) -> list[int]:
    b = skeleton.index[bone]
    return [k for k, d in enumerate(skeleton.dofs) if d.bone == b and d.coupled is None]


def couple_rotations(skeleton, angles: np.ndarray) -> np.ndarray:
    """A rotation DOF that follows flexion (6.2.1) set from its joint's flexion."""
    out = angles.copy()
    for k, d in enumerate(skeleton.dofs):
        if d.coupled is not None:
            flexion = skeleton.dof_index[(skeleton.names[d.bone], "flexion")]
            out[k] = np.clip(d.coupled * out[flexion], d.lower, d.upper)
    return out


def _fit_step(skeleton, layout: GloveLayout, root, angles, dofs: list[int], marker: int, target: np.ndarray):
    lower, upper = skeleton.lower[dofs], skeleton.upper[dofs]

    def residual(x):
        trial = angles.copy()
        trial[dofs] = x
        trial = couple_rotations(skeleton, trial)
        return layout.positions(skeleton, root, trial)[marker] - target

    start = np.clip(angles[dofs], lower + 1e-9, upper - 1e-9)
    fit = least_squares(residual, start, bounds=(lower, upper), method="trf", xtol=1e-10, ftol=1e-12)
    out = angles.copy()
    out[dofs] = fit.x
    return couple_rotations(skeleton, out), float(np.linalg.norm(fit.fun))


def _best_marker(skeleton, layout, root, angles, pending, marker, points, colours, used, reach=REACH):
    best = None
    for k in np.flatnonzero(colours == layout.colours[marker]):
        if k in used:
            continue
        trial, error = _fit_step(skeleton, layout, root, angles, pending, marker, points[k])
        if error < reach and (best is None or error < best[2]):
            best = (int(k), trial, error)
    return best


def _chains(skeleton, layout, root, prior, points, colours, used: set, reach: float = REACH):
    """Two passes over the fingers: first each joint from its own next marker only, stopping a finger at its
    first missing marker; then, with the markers nobody claimed, the stopped fingers go on, solving the joint
    before a missing marker together with the next (a finger bending across cannot steal its neighbour's
    markers that way)."""
    angles = prior.copy()
    labels, solved, missing, residuals = {}, [], [], []     # solved: DOFs fixed by their own next marker
    stopped = {}
    for finger, chain in CHAINS.items():
        for step, (bone, name) in enumerate(chain):
            marker = layout.names.index(name)
            best = _best_marker(skeleton, layout, root, angles, _free_dofs(skeleton, bone), marker, points, colours,
                                used, reach)
            if best is None:
                stopped[finger] = step
                break
            k, angles, error = best
            used.add(k)
            labels[name] = k
            solved += [skeleton.dof_names()[d] for d in _free_dofs(skeleton, bone)]
            residuals.append(error)
    for finger, first in stopped.items():
        pending: list[int] = []
        for bone, name in CHAINS[finger][first:]:
            marker = layout.names.index(name)
            pending += _free_dofs(skeleton, bone)
            best = _best_marker(skeleton, layout, root, angles, pending, marker, points, colours, used, reach)
            if best is None:
                missing.append(name)
                continue
            k, angles, error = best
            used.add(k)
            labels[name] = k
            own = _free_dofs(skeleton, bone)
            solved += [skeleton.dof_names()[d] for d in own if len(pending) == len(own)]
            residuals.append(error)
            pending = []
    return angles, labels, solved, missing, residuals


def _roots(layout: GloveLayout, points, colours, tolerance: float = BACK_TOLERANCE) -> list[tuple[np.ndarray, tuple]]:
    back = layout.rest[layout.back]
    wanted = [layout.colours[i] for i in layout.back]
    model = [np.linalg.norm(back[a] - back[b]) for a, b in ((0, 1), (1, 2), (0, 2))]
    options = [np.flatnonzero(colours == c) for c in wanted]
    out = []
    for triple in itertools.product(*options):
        if len(set(triple)) < 3:
            continue
        p = points[list(triple)]
        seen = [np.linalg.norm(p[a] - p[b]) for a, b in ((0, 1), (1, 2), (0, 2))]
        if max(abs(s - m) for s, m in zip(seen, model)) < tolerance:
            out.append((horn(back, p), triple))
    return out


def solve_hand(skeleton, layout: GloveLayout, points: np.ndarray, colour_names: list[str],
               prior: np.ndarray | None = None, reach: float = REACH,
               back_tolerance: float = BACK_TOLERANCE) -> HandPose | None:
    """The hand pose of one cluster of markers (``points`` (N, 3), ``colour_names`` (N,)), or None when the
    three back-of-hand markers are not all there (6.3.2: only then is the root determined). ``reach`` and
    ``back_tolerance`` (metres) say how far a marker may be from where the model can put it."""
    colours = np.array(colour_names, dtype=object)
    prior = np.zeros(skeleton.dof_count) if prior is None else np.asarray(prior, np.float64)
    best = None
    for root, triple in _roots(layout, points, colours, back_tolerance):
        used = set(int(k) for k in triple)
        angles, labels, solved, missing, residuals = _chains(skeleton, layout, root, prior, points, colours, used,
                                                             reach)
        labels.update({layout.names[i]: int(k) for i, k in zip(layout.back, triple)})
        score = float(np.sum(residuals)) + reach * len(missing)
        if best is None or score < best[0]:
            best = (score, HandPose(root, angles, labels, solved, float(np.mean(residuals or [0.0])), missing))
    return None if best is None else best[1]
