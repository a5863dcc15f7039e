# SPDX-License-Identifier: GPL-3.0-or-later
"""New hand models from photographs (thesis 6.2.3).

Input: the pixel positions of as many of the 26 feature points of Table 6.5 as are visible in a photo of a
flat hand (at least :data:`.features.MIN_FEATURES`, "we obtained reasonable results using a subset of only 16
feature points") and two clicks on a ruler at a known distance. Then, as in 6.2.3:

1. *Calibration*: ``s = ruler length / pixel distance`` turns the clicks into metres (image rows grow
   downwards, so ``(x, y) = s (u, -v)``).
2. *Fitting plane*: centre of gravity ``c`` of the source points (those with a target) and the eigenvectors
   of ``X X^T / N``: the two largest span the plane, the third is its normal ``n``.
3. The targets, centred, are put into that plane (their centroid at ``c``) and rotated so that their
   largest diameter, index finger tip -> head of the ulna, lies along the source's. (A photo of the palm
   side or of a left hand is a mirror image; it is reflected first, chosen by a least-squares fit, so the
   result is always a right hand; ``--side left`` mirrors the rig.)
4. *Lifting*: each target gets the height of its source point over the plane, scaled by the ratio of the
   largest diameters, so the new hand keeps a thickness proportional to its size.
5. *Warp*: ``f(x) = sum_i c_i ||x - s_i|| + affine part`` (biharmonic RBF, :class:`..physics.RBFWarp`) maps
   every source feature point exactly onto its target; :func:`.template.warped_template` applies it.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..core.errors import UserError
from ..core.presets import parse_preset, read_preset_text
from ..physics import RBFWarp
from .features import CHAINS, FEATURE_NAMES, MIN_FEATURES
from .presets import PHOTO_POINTS
from .skeleton import FINGERS

__all__ = ["read_photo_points", "check_photo", "photo_targets", "photo_warp", "photo_points_document"]

DIAMETER = ("index_tip", "ulna_head")


def photo_points_document(points: dict[str, tuple[float, float]], ruler: tuple, ruler_mm: float,
                          image: str = "") -> dict:
    """The JSON document of a photo input (what :func:`read_photo_points` reads)."""
    return {"format": PHOTO_POINTS.name, "version": PHOTO_POINTS.version, "image": image,
            "points": {k: [float(v[0]), float(v[1])] for k, v in points.items()},
            "ruler": [[float(r[0]), float(r[1])] for r in ruler], "ruler_mm": float(ruler_mm)}


def read_photo_points(path: str | Path) -> dict:
    """Read and check a feature-point file (format ``faces_hands.hand_photo_points``)."""
    doc = parse_preset(read_preset_text(path), str(path), PHOTO_POINTS.name)
    return check_photo(doc, str(path))


def _wrist_reference(points: dict[str, np.ndarray]) -> np.ndarray | None:
    if "wrist_radial" in points and "wrist_ulnar" in points:
        return 0.5 * (points["wrist_radial"] + points["wrist_ulnar"])
    return points.get("ulna_head")


def _check_order(points: dict[str, np.ndarray], source: str) -> None:
    """Refuse clicks in an impossible order: along every finger the joints must lie ever farther from the
    wrist, and the fingers must follow each other thumb -> little finger across the hand."""
    wrist = _wrist_reference(points)
    if wrist is None:
        raise UserError(f"{source}: click the wrist (wrist_radial and wrist_ulnar) or the head of the ulna; "
                        "the hand's orientation is measured from there")
    for finger, chain in CHAINS.items():
        present = [name for name in chain if name in points]
        distance = [float(np.linalg.norm(points[name] - wrist)) for name in present]
        for (a, da), (b, db) in zip(zip(present, distance), zip(present[1:], distance[1:])):
            if db <= da:
                raise UserError(f"{source}: feature points in an impossible order: {b} is not farther from the "
                                f"wrist than {a}; check those clicks")
    axis = None
    if "middle_mcp" in points:
        axis = points["middle_mcp"] - wrist
    elif "middle_tip" in points:
        axis = points["middle_tip"] - wrist
    if axis is None or np.linalg.norm(axis) == 0:
        return
    lateral = np.array([-axis[1], axis[0]]) / np.linalg.norm(axis)
    for part in ("mcp", "tip"):
        row = [(f, float((points[f"{f}_{part}"] - wrist) @ lateral)) for f in FINGERS if f"{f}_{part}" in points]
        steps = np.sign(np.diff([v for _, v in row]))
        if len(steps) >= 2 and not (np.all(steps > 0) or np.all(steps < 0)):
            order = ", ".join(f for f, _ in sorted(row, key=lambda item: item[1]))
            raise UserError(f"{source}: feature points in an impossible order: the finger {part}s lie across the "
                            f"hand as {order}; they must run thumb, index, middle, ring, pinky")


def check_photo(doc: dict, source: str = "photo points") -> dict:
    """The checked photo input: known names, at least 16 points, a ruler of non-zero length, a possible
    order. Returns a plain dict ``{"points", "ruler", "ruler_mm", "image"}`` (JSON-able, kept in the rig)."""
    points = doc.get("points", {})
    unknown = sorted(set(points) - set(FEATURE_NAMES))
    if unknown:
        raise UserError(f"{source}: unknown feature point {unknown[0]!r}; the names are {', '.join(FEATURE_NAMES)}")
    if len(points) < MIN_FEATURES:
        raise UserError(f"{source}: only {len(points)} feature points; click at least {MIN_FEATURES} of the 26 "
                        "(Table 6.5)")
    for name, value in points.items():
        if len(value) != 2:
            raise UserError(f"{source}: feature point {name} needs two pixel coordinates [x, y]")
    for name in DIAMETER:
        if name not in points:
            raise UserError(f"{source}: the {name.replace('_', ' ')} is needed (it fixes the hand's orientation)")
    ruler = np.asarray(doc.get("ruler", []), np.float64)
    if ruler.shape != (2, 2):
        raise UserError(f"{source}: the ruler needs two points [[x0, y0], [x1, y1]] at a known distance")
    pixels = float(np.linalg.norm(ruler[1] - ruler[0]))
    if pixels < 1.0:
        raise UserError(f"{source}: the two ruler marks are {pixels:.2g} pixels apart; click two marks at a known "
                        "distance (e.g. 0 cm and 20 cm)")
    ruler_mm = float(doc.get("ruler_mm", 200.0))
    if not ruler_mm > 0:
        raise UserError(f"{source}: ruler_mm must be the positive distance between the two ruler marks")
    flat = {name: np.array([float(v[0]), -float(v[1])]) for name, v in points.items()}
    _check_order(flat, source)
    return {"points": {k: [float(v[0]), float(v[1])] for k, v in sorted(points.items())},
            "ruler": ruler.tolist(), "ruler_mm": ruler_mm, "image": str(doc.get("image", ""))}


def photo_targets(source_points: dict[str, np.ndarray], photo: dict) -> tuple[list[str], np.ndarray, np.ndarray]:
    """(names, source (K, 3), target (K, 3)) of the warp (module docstring, steps 1-4)."""
    photo = check_photo(photo)
    names = [n for n in FEATURE_NAMES if n in photo["points"]]
    ruler = np.asarray(photo["ruler"])
    scale = photo["ruler_mm"] / 1000.0 / float(np.linalg.norm(ruler[1] - ruler[0]))
    flat = np.array([[photo["points"][n][0], -photo["points"][n][1]] for n in names]) * scale
    source = np.array([source_points[n] for n in names])
    centre = source.mean(axis=0)
    x = source - centre
    values, vectors = np.linalg.eigh(x.T @ x / len(names))
    e1, e2, normal = vectors[:, 2], vectors[:, 1], vectors[:, 0]
    plane = np.column_stack([x @ e1, x @ e2])
    target = flat - flat.mean(axis=0)
    if _reflection_fits_better(plane, target):
        target[:, 0] *= -1.0
    i, u = names.index(DIAMETER[0]), names.index(DIAMETER[1])
    a, b = plane[i] - plane[u], target[i] - target[u]
    angle = np.arctan2(a[1], a[0]) - np.arctan2(b[1], b[0])
    rotation = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    target = target @ rotation.T
    heights = (x @ normal) * (np.linalg.norm(b) / np.linalg.norm(a))
    lifted = centre + target[:, :1] * e1 + target[:, 1:] * e2 + heights[:, None] * normal
    return names, source, lifted


def _reflection_fits_better(source: np.ndarray, target: np.ndarray) -> bool:
    """Does a mirror image of ``target`` fit ``source`` better than ``target`` itself (2D Procrustes)?"""
    def residual(t):
        u, _, vt = np.linalg.svd(t.T @ source)
        r = u @ vt
        if np.linalg.det(r) < 0:
            u[:, -1] *= -1
            r = u @ vt
        scale = np.trace((t @ r).T @ source) / max(np.trace(t.T @ t), 1e-18)
        return float(np.sum((scale * t @ r - source) ** 2))
    mirrored = target * np.array([-1.0, 1.0])
    return residual(mirrored) < residual(target)


def photo_warp(source_points: dict[str, np.ndarray], photo: dict) -> RBFWarp:
    """The RBF warp taking the reference hand to the hand of the photo (step 5)."""
    _, source, target = photo_targets(source_points, photo)
    return RBFWarp(source, target, kernel="linear")


def dump_photo_points(document: dict) -> str:
    return json.dumps(document, indent=1, sort_keys=True)
