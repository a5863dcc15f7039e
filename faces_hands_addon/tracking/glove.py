# SPDX-License-Identifier: GPL-3.0-or-later
"""The marker glove on the (personalised) hand model (thesis 6.3.2, Fig. 6.25 right: "the warped model is then
equipped with markers at the same positions as on the glove").

:func:`glove_layout` places the 18 markers of ``presets/tracking/glove.json`` on a hand rig: each on its bone,
on the back of the hand's skin (the most dorsal skin vertex over the point), rigidly carried by that bone.
:meth:`GloveLayout.positions` gives their places for a root transform and joint angles (forward kinematics of
the rig's skeleton; the wrist's own angles are folded into the root, which the three back-of-hand markers
fix).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import UserError
from ..core.presets import NUMBER, PresetFormat, read_preset, register_format

__all__ = ["GloveLayout", "glove_layout", "GLOVE_FORMAT", "DORSAL", "ULNAR"]

GLOVE_FORMAT = register_format(PresetFormat(
    "faces_hands.pitch_glove", 1, required=("colours", "markers", "back", "assignment"),
    shape={"description": str, "colours": [str], "rgb": {str: [NUMBER]}, "marker_radius": NUMBER, "back": [str],
           "markers": [{"name": str, "bone": str, "along": NUMBER, "lateral": NUMBER}],
           "assignment": {str: str}, "surface": bool}))
DORSAL = np.array([-1.0, 0.0, 0.0])     # the back of the right hand in the rig's asset frame (palm towards +X)
ULNAR = np.array([0.0, 1.0, 0.0])       # towards the little finger


@dataclass
class GloveLayout:
    """``names``, ``bones`` (bone index per marker), ``rest`` (18, 3) marker positions on the rest hand,
    ``colours`` (colour name per marker), ``back`` (indices of the three back-of-hand markers)."""
    names: list[str]
    bones: np.ndarray
    rest: np.ndarray
    colours: list[str]
    back: np.ndarray
    rgb: dict
    radius: float

    def positions(self, skeleton, root: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """World positions (18, 3) for the 4x4 ``root`` (rest hand -> world) and the DOF ``angles``."""
        transforms = skeleton.bone_transforms(angles)
        m = root @ transforms[self.bones]
        return np.einsum("nij,nj->ni", m[:, :3, :3], self.rest) + m[:, :3, 3]


def _dorsal_skin(point: np.ndarray, skin: np.ndarray, reach: float = 0.0035) -> np.ndarray:
    """The most dorsal skin vertex over ``point`` (within ``reach`` of the dorsal line through it, widened
    where the skin is coarse)."""
    lateral = skin - point
    off_axis = np.linalg.norm(lateral - np.outer(lateral @ DORSAL, DORSAL), axis=1)
    above = lateral @ DORSAL > 0.0
    for widen in (1.0, 2.0, 4.0):
        near = skin[(off_axis < reach * widen) & above]
        if len(near):
            return near[int(np.argmax(near @ DORSAL))]
    return point


def glove_layout(skeleton, rest_skin: np.ndarray, document: dict | None = None) -> GloveLayout:
    """The glove of ``presets/tracking/glove.json`` on a hand (its skeleton and rest skin, asset frame)."""
    doc = document or read_preset("tracking/glove.json", GLOVE_FORMAT.name)[0]
    names, bones, rest, colours = [], [], [], []
    for m in doc["markers"]:
        if m["bone"] not in skeleton.index:
            raise UserError(f"glove preset: marker {m['name']!r} is on an unknown bone {m['bone']!r}")
        b = skeleton.index[m["bone"]]
        point = skeleton.position[b] + float(m["along"]) * (skeleton.tail[b] - skeleton.position[b])
        point = point + float(m["lateral"]) * ULNAR
        names.append(m["name"])
        bones.append(b)
        rest.append(_dorsal_skin(point, rest_skin) if doc.get("surface", True) else point)
        colours.append(doc["assignment"].get(m["name"], doc["colours"][len(names) % len(doc["colours"])]))
    unknown = [c for c in colours if c not in doc["colours"]]
    if unknown or len(set(names)) != len(names):
        raise UserError("glove preset: marker names must be unique and colours among 'colours'")
    missing = [n for n in doc["back"] if n not in names]
    if len(doc["back"]) != 3 or missing:
        raise UserError("glove preset: 'back' names the three back-of-hand markers")
    return GloveLayout(names, np.array(bones), np.array(rest), colours,
                       np.array([names.index(n) for n in doc["back"]]), dict(doc.get("rgb", {})),
                       float(doc.get("marker_radius", 0.004)))
