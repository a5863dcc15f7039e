# SPDX-License-Identifier: GPL-3.0-or-later
"""Air in the mouth (ARKit cheekPuff: a buccinator and a cheek-puff pressure term). The thesis'
muscles only pull; puffed cheeks are pushed out from inside. With the lips sealed, the pressure of the air
in the oral vestibule moves the cheek wall outwards along its normal, most over the middle of the buccal
region (lateral to and a little behind and above each mouth corner, where only the buccinator and the
buccal fat lie between the air and the skin) and fading out towards the lips, the zygoma and the jaw line.
A contracting buccinator stiffens the cheek wall against it: the bulge on a side shrinks with that side's
buccinator contraction. Per node the field is a displacement (N, 3) at full pressure, added to the
attachment targets (3.1.2 "Mass Spring Network": the skin follows its targets).
"""
from __future__ import annotations

import numpy as np

__all__ = ["CheekPressure", "PUFF_MM"]

PUFF_MM = 5.0                       # outward bulge at the middle of each cheek at full pressure
OFFSET = np.array([0.020, 0.012, 0.006])   # m from a mouth corner to the middle of its cheek (out, back, up)
RADIUS = 0.024                      # m from that middle where the bulge fades out


class CheekPressure:
    """Per side ("L", "R"): the displacement field (N, 3) of the skin at full pressure."""

    def __init__(self, fields: dict[str, np.ndarray]) -> None:
        self.fields = fields

    @classmethod
    def build(cls, skin, normals: np.ndarray) -> "CheekPressure | None":
        """From the skin's inner lip contours (the mouth corners), outer-surface nodes and normals; None
        without lip contours."""
        contours = skin.contours
        if "lips_inner_upper" not in contours:
            return None
        nodes = np.asarray(skin.vertices, np.float64)
        margin = nodes[np.asarray(contours["lips_inner_upper"])]
        surface = skin.group("surface") & ~skin.group("lip_inner") & ~skin.group("mouth_bag")
        for name in ("lid_upper_L", "lid_lower_L", "lid_upper_R", "lid_lower_R"):
            surface &= ~skin.group(name)
        fields = {}
        for side, corner in (("L", margin[np.argmax(margin[:, 0])]), ("R", margin[np.argmin(margin[:, 0])])):
            sign = 1.0 if side == "L" else -1.0
            centre = corner + OFFSET * np.array([sign, 1.0, 1.0])
            t = np.clip(np.linalg.norm(nodes - centre, axis=1) / RADIUS, 0.0, 1.0)
            weight = np.where(surface & (sign * (nodes[:, 0] - corner[0]) > -0.004), 1.0 - t * t * (3 - 2 * t), 0.0)
            fields[side] = normals * (weight * PUFF_MM / 1000.0)[:, None]
        return cls(fields)

    def displacement(self, pressure: float, buccinator: dict[str, float]) -> np.ndarray | None:
        """The skin's displacement (N, 3) for ``pressure`` (0..1) and each side's buccinator contraction;
        None at no pressure."""
        if pressure <= 0.0:
            return None
        return sum(field * pressure * (1.0 - float(np.clip(buccinator.get(side, 0.0), 0.0, 1.0)))
                   for side, field in self.fields.items())
