# SPDX-License-Identifier: GPL-3.0-or-later
"""What a bake computes, for any rig of the protocol (:class:`..core.rig.Rig`), as generators the operators
step through (progress bar, ESC to cancel). They never call back into Blender: everything a bake needs
(control values, sampled layer tables) is handed in as plain data.

Three modes, all from the simulation (thesis 3.1.2 for the face), never from a linear guess:

* **basis** -- one shape per control at its full value (``FH.<control>``), everything else at rest;
* **expressions** -- one shape per named expression (ARKit blendshapes, Meta visemes, emotions);
* **animation** -- the simulation stepped through a :class:`.layers.LayerTable`, one pose per frame.

Each static shape is settled from the rest state, so shapes do not depend on the order in which they are
baked; the same rig and inputs give byte-identical shapes.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator, Mapping

from ..core.controls import clamp_controls
from ..core.rig import Pose, Rig
from .closure_drive import ClosureDrive
from .layers import BASE_LAYER, LayerTable
from .shape_cache import ShapeCache

SETTLE_DT = 1 / 24          # the step ``Rig.settled`` uses by default

__all__ = ["BASIS_PREFIX", "BakedShape", "basis_shapes", "expression_shapes", "animation_poses",
           "frame_key_name"]

BASIS_PREFIX = "FH."


@dataclass
class BakedShape:
    """One shape key to be: its name, the rig's pose in that shape, and for basis shapes the control that
    drives it with the key's slider range (the control's range over its full value)."""
    name: str
    pose: Pose
    control: str | None = None
    value_range: tuple[float, float] = (0.0, 1.0)


def _settled(rig: Rig, values: dict, settle_time: float, cache: ShapeCache | None) -> Pose:
    layer_values = {BASE_LAYER: values}
    if cache is None:
        return rig.settled(layer_values, settle_time)
    return cache.settled(rig, layer_values, settle_time, SETTLE_DT, lambda: rig.settled(layer_values, settle_time))


def basis_shapes(rig: Rig, settle_time: float = 1.5, cache: ShapeCache | None = None) -> Iterator[BakedShape]:
    """One shape per control at its full value (the range end farthest from 0); ``cache`` keeps settled
    shapes across bakes (``shape_cache``)."""
    for name, spec in rig.control_specs().items():
        full = spec.full_value
        pose = _settled(rig, {name: full}, settle_time, cache)
        yield BakedShape(BASIS_PREFIX + name, pose, control=name,
                         value_range=(spec.minimum / full if full else 0.0, spec.maximum / full if full else 1.0))
    rig.reset()


def expression_shapes(rig: Rig, expressions: Mapping[str, Mapping[str, float]], settle_time: float = 1.5,
                      cache: ShapeCache | None = None) -> Iterator[BakedShape]:
    """One shape per named expression (a partial control dict; unknown control names are refused)."""
    specs = rig.control_specs()
    for name, expression in expressions.items():
        values = clamp_controls(expression, specs, strict=True)
        yield BakedShape(name, _settled(rig, values, settle_time, cache))
    rig.reset()


def animation_poses(rig: Rig, table: LayerTable, dt: float, settle_time: float = 1.0,
                    drive: ClosureDrive | None = None) -> Iterator[BakedShape]:
    """Simulate through the frames of ``table``: settle at the first frame's values, then one ``dt`` step per
    frame. Yields a :class:`BakedShape` per frame, named ``FH.frame_<frame>``. With a ``drive``
    (:mod:`.closure_drive`), the lip closures it holds are fed early enough to be shut in time."""
    if not len(table):
        rig.reset()
        return
    if drive is not None:
        poses = drive.poses(rig, table, dt, settle_time)
    else:
        poses = (rig.settled(table.at(0), settle_time, dt) if index == 0 else rig.step(table.at(index), dt)
                 for index in range(len(table)))
    for index, pose in enumerate(poses):
        yield BakedShape(frame_key_name(int(table.frames[index])), pose)


def frame_key_name(frame: int) -> str:
    return f"{BASIS_PREFIX}frame_{frame:05d}"
