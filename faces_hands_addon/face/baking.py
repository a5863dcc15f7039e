# SPDX-License-Identifier: GPL-3.0-or-later
"""What a bake computes, as generators the operators can step through (progress bar, ESC to cancel).

Three modes (issue 3, item 8), all from the simulated face (3.1.2), never from a linear guess:

* **basis** -- one shape per control at its full value (``FH.<control>``), everything else at rest;
* **expressions** -- one shape per named expression (ARKit blendshapes, Meta visemes, emotions);
* **animation** -- the simulation stepped through the animated controls, one pose per frame.

Each shape is simulated from the rest state until the skin settles, so shapes do not depend on the
order in which they are baked; the same rig and inputs give byte-identical shapes.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterator

import numpy as np

from .expressions import expression_controls

BASIS_PREFIX = "FH."


@dataclass
class BakedShape:
    """One shape key to be: its name, absolute skin positions (N, 3) float32, the rigid transforms (4x4)
    of jaw, eyes, teeth and tongue in that pose, and for basis shapes the control that drives it with the
    control's range (for the shape key's slider range)."""

    name: str
    positions: np.ndarray
    transforms: dict[str, np.ndarray]
    control: str | None = None
    value_range: tuple[float, float] = (0.0, 1.0)


def reset_to_rest(rig) -> None:
    """Put the rig back into its rest state: controls at their defaults, skin, velocities, attachments
    and guards at rest (``FaceRig.reset_state``)."""
    rig.reset_controls()
    rig.reset_state()


def settled_shape(rig, controls: dict[str, float], settle_time: float = 1.5
                  ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Skin positions and rigid transforms after settling from rest with ``controls`` (others at their
    defaults)."""
    reset_to_rest(rig)
    rig.set_controls(controls)
    positions = np.array(rig.settle(max_time=settle_time), dtype=np.float32, copy=True)
    return positions, rig.rigid_transforms()


def basis_shapes(rig, settle_time: float = 1.5) -> Iterator[BakedShape]:
    """One shape per control at its full value (the maximum of its range), 3.1.2."""
    for name, spec in rig.control_specs().items():
        full = spec.maximum if abs(spec.maximum) >= abs(spec.minimum) else spec.minimum
        positions, transforms = settled_shape(rig, {name: full}, settle_time)
        yield BakedShape(BASIS_PREFIX + name, positions, transforms, control=name,
                         value_range=(spec.minimum / full if full else 0.0, spec.maximum / full if full else 1.0))
    reset_to_rest(rig)


def expression_shapes(rig, expressions: dict[str, dict[str, float]], settle_time: float = 1.5
                      ) -> Iterator[BakedShape]:
    """One shape per named expression (a partial control dict), settled from rest."""
    specs = rig.control_specs()
    for name, expression in expressions.items():
        yield BakedShape(name, *settled_shape(rig, expression_controls(expression, specs), settle_time))
    reset_to_rest(rig)


def animation_frames(rig, controls_at: Callable[[int], dict[str, float]], frames: list[int], dt: float,
                     settle_time: float = 1.0) -> Iterator[tuple[int, np.ndarray]]:
    """Simulate through ``frames``: settle at the first frame's controls, then one ``dt`` step per frame.

    ``controls_at(frame)`` returns the control values at that frame (the operator reads them from the
    animated properties). Yields a :class:`BakedShape` per frame, named ``FH.frame_<frame>``."""
    reset_to_rest(rig)
    if not frames:
        return
    rig.set_controls(controls_at(frames[0]))
    rig.settle(max_time=settle_time, dt=dt)
    yield BakedShape(frame_key_name(frames[0]), np.array(rig.positions, dtype=np.float32, copy=True),
                     rig.rigid_transforms())
    for frame in frames[1:]:
        rig.set_controls(controls_at(frame))
        positions = np.array(rig.step_frame(dt), dtype=np.float32, copy=True)
        yield BakedShape(frame_key_name(frame), positions, rig.rigid_transforms())


def frame_key_name(frame: int) -> str:
    return f"{BASIS_PREFIX}frame_{frame:05d}"
