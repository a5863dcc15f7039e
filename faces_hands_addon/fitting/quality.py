# SPDX-License-Identifier: GPL-3.0-or-later
"""Is the located face a face? A gate between landmark location and the rig (thesis 3.1.2 "Creating New
Animatable Head Models from the Template": the feature points must sit "at corresponding locations on the
target skin mesh"; a rig built on landmarks that are on the back of the skull or on a monkey's muzzle is
worse than a refusal).

The landmarks are taken into *head space* by the least-squares similarity onto the canonical face (Umeyama
1991; face along -Y, top along +Z, metres) and measured there, on the target's own surface points:

* **landmark residual**: RMS distance of the similarity-mapped landmarks to the canonical face, in face
  widths (a human face differs from the canonical one by its proportions, ~2-6 %);
* **nose in front**: the nose tip (landmark 1) ahead of the face's outline ring (``face_oval``), in face widths;
* **eyes in their sockets**: each eye contour behind the nose tip and not in front of its brow
  (``eyebrow_*_upper``): the eyes sit in the orbits, under the brow ridge (Farkas 1994 orbital region);
* **mouth between nose and chin**: the stomion (13/14) below the subnasale (2) and above the menton (152),
  at the fraction of that height faces have (subnasale-stomion ~1/3 of subnasale-menton, Farkas 1994);
* **symmetry**: the target surface around the landmarks mirrored about the face's mid-plane lands on the
  surface again (median gap in face widths), so the face found is bilaterally symmetric about the plane the
  landmarks say it is.

Each check has a figure, a limit and a sentence; :func:`check_fit` returns them all and
:func:`refusal` the message naming every failed one.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import UserError
from ..core.geometry import similarity_transform
from .surface import TargetSurface
from .template import face_template

__all__ = ["Check", "check_fit", "refusal", "head_frame", "LIMITS", "FitRefused"]

NOSE_TIP, SUBNASALE, UPPER_LIP, LOWER_LIP, MENTON = 1, 2, 13, 14, 152

# Limits, in face widths (tragus to tragus) unless said otherwise; the canonical face's own values and the
# measured ones of good and nonsense fits (procedural test heads of .testdata, Blender's Suzanne) beside.
LIMITS = {
    "landmark_residual": 0.10,     # at most (canonical 0, test heads 0.03-0.04, Suzanne 0.18)
    "nose_protrusion": 0.20,       # at least (canonical 0.43, test heads 0.44-0.51, Suzanne 0.06)
    "eye_depth": 0.12,             # eye contour at least this far behind the nose tip (canonical 0.25,
                                   # test heads 0.26-0.32, Suzanne 0.02-0.07)
    "eye_under_brow": 0.0,         # eye contour at least this far behind the brow (canonical 0.042,
                                   # test heads 0.03-0.055, Suzanne -0.007-0.0)
    "mouth_fraction_low": 0.15,    # subnasale-stomion / subnasale-menton in [low, high] (canonical 0.30,
    "mouth_fraction_high": 0.55,   # test heads 0.28-0.29)
    "symmetry": 0.02,              # median mirrored-surface gap, at most (test heads 0.001, Suzanne: no
                                   # surface where its landmarks put the face)
}


@dataclass(frozen=True)
class Check:
    name: str
    value: float
    limit: float
    ok: bool
    text: str           # what was measured, in words, with the figure and the limit

    def as_dict(self) -> dict:
        return {"name": self.name, "value": float(self.value), "limit": float(self.limit), "ok": bool(self.ok)}


def head_frame(landmarks: np.ndarray) -> tuple[np.ndarray, float]:
    """(4x4 similarity target -> canonical face, residual RMS in face widths), Umeyama 1991."""
    canonical = face_template().vertices
    matrix = similarity_transform(landmarks, canonical)
    mapped = landmarks @ matrix[:3, :3].T + matrix[:3, 3]
    residual = float(np.sqrt(np.mean(np.sum((mapped - canonical) ** 2, axis=1))) / face_template().width)
    return matrix, residual


def _surface_symmetry(vertices, faces, landmarks, to_head, rng) -> float:
    """Median gap between the mirrored target surface near the face and the target surface, face widths."""
    width = face_template().width
    head = vertices @ to_head[:3, :3].T + to_head[:3, 3]
    canonical = face_template().vertices
    low, high = canonical.min(0) - 0.05 * width, canonical.max(0) + 0.05 * width
    low[1], high[1] = low[1] - 0.1 * width, high[1]         # the face's front, not the back of a full head
    inside = ((head >= low) & (head <= high)).all(axis=1)
    triangles = np.flatnonzero(inside[faces].any(axis=1))
    if len(triangles) < 8:
        return 1.0              # (almost) no surface where the landmarks say the face is
    corners = head[faces[triangles]]
    areas = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    if not areas.sum() > 0:
        return 1.0
    count = 1500
    pick = rng.choice(len(triangles), size=count, p=areas / areas.sum())
    r1, r2 = rng.random(count), rng.random(count)
    root = np.sqrt(r1)
    bary = np.stack([1 - root, root * (1 - r2), root * r2], axis=1)
    points = (bary[:, :, None] * corners[pick]).sum(axis=1)
    surface = TargetSurface(head, faces, triangles)
    hit = surface.closest(points * (-1.0, 1.0, 1.0))
    return float(np.median(hit.distances) / width)


def check_fit(positions, vertices, faces, *, seed: int = 0) -> list[Check]:
    """All checks of the module docstring for landmarks ``positions`` on the mesh (its coordinates)."""
    positions = np.asarray(positions, np.float64)
    template = face_template()
    contours = template.contours
    to_head, residual = head_frame(positions)
    p = positions @ to_head[:3, :3].T + to_head[:3, 3]
    w = template.width
    checks = [Check("landmark_residual", residual, LIMITS["landmark_residual"], residual <= LIMITS["landmark_residual"],
                    f"landmark residual {100 * residual:.1f} % of the face width (limit "
                    f"{100 * LIMITS['landmark_residual']:.0f} %)")]
    oval_y = float(p[contours["face_oval"], 1].mean())
    nose = (oval_y - p[NOSE_TIP, 1]) / w
    checks.append(Check("nose_protrusion", nose, LIMITS["nose_protrusion"], nose >= LIMITS["nose_protrusion"],
                        f"nose tip {100 * nose:.0f} % of the face width in front of the face outline (need "
                        f"{100 * LIMITS['nose_protrusion']:.0f} %)"))
    for side in ("L", "R"):
        eye_y = float(p[contours[f"eye_{side}"], 1].mean())
        depth = (eye_y - p[NOSE_TIP, 1]) / w
        under = (eye_y - float(p[contours[f"eyebrow_{side}_upper"], 1].mean())) / w
        word = "left" if side == "L" else "right"
        checks.append(Check(f"eye_depth_{side}", depth, LIMITS["eye_depth"], depth >= LIMITS["eye_depth"],
                            f"{word} eye {100 * depth:.0f} % of the face width behind the nose tip (need "
                            f"{100 * LIMITS['eye_depth']:.0f} %)"))
        checks.append(Check(f"eye_under_brow_{side}", under, LIMITS["eye_under_brow"],
                            under >= LIMITS["eye_under_brow"],
                            f"{word} eye {100 * under:.0f} % of the face width behind its brow (need at least "
                            f"{100 * LIMITS['eye_under_brow']:.0f} %: in front of the brow it is not in a socket)"))
    mouth_z = 0.5 * (p[UPPER_LIP, 2] + p[LOWER_LIP, 2])
    span = p[SUBNASALE, 2] - p[MENTON, 2]
    fraction = float((p[SUBNASALE, 2] - mouth_z) / span) if span > 0 else float("nan")
    low, high = LIMITS["mouth_fraction_low"], LIMITS["mouth_fraction_high"]
    ok = bool(np.isfinite(fraction) and low <= fraction <= high)
    checks.append(Check("mouth_between_nose_and_chin", fraction, low if fraction < low else high, ok,
                        f"mouth at {100 * fraction:.0f} % of the way from nose to chin (need "
                        f"{100 * low:.0f}-{100 * high:.0f} %)" if np.isfinite(fraction) else
                        "the chin is not below the nose"))
    symmetry = _surface_symmetry(np.asarray(vertices, np.float64), np.asarray(faces, np.int64), positions, to_head,
                                 np.random.default_rng(seed))
    checks.append(Check("symmetry", symmetry, LIMITS["symmetry"], symmetry <= LIMITS["symmetry"],
                        f"surface mirrored about the face's mid-plane is {100 * symmetry:.1f} % of the face width "
                        f"off itself (limit {100 * LIMITS['symmetry']:.0f} %)"))
    return checks


def refusal(checks: list[Check], orientation: str = "") -> str | None:
    """The refusal message naming every failed check, or None when all passed."""
    failed = [c for c in checks if not c.ok]
    if not failed:
        return None
    where = f" (face looking {orientation})" if orientation else ""
    return ("this does not look like a human face" + where + ": " + "; ".join(c.text for c in failed)
            + ". Check that the mesh is a human head or face mask; give its axes with --forward/--up, or place "
            "the landmarks by hand")


class FitRefused(UserError):
    """A fit that ran but does not look like a face: the message names the failed checks; ``preview()``
    renders where the fitter thought the face was (:func:`.preview.preview_image`)."""

    def __init__(self, message: str, vertices, faces, positions, rotation, checks=(),
                 orientation: dict | None = None):
        super().__init__(message)
        self.vertices, self.faces, self.positions = vertices, faces, positions
        self.rotation = np.asarray(rotation, np.float64)     # mesh axes -> the face's (as found)
        self.checks = list(checks)
        self.orientation = dict(orientation or {})

    def preview(self) -> np.ndarray:
        from .preview import preview_image
        return preview_image(self.vertices, self.faces, self.positions, self.rotation)
