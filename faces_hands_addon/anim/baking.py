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

import os
import queue
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import Iterable, Iterator, Mapping

from ..core.controls import clamp_controls
from ..core.rig import Pose, Rig
from .closure_drive import ClosureDrive
from .layers import BASE_LAYER, LayerTable
from .shape_cache import ShapeCache

SETTLE_DT = 1 / 24          # the step ``Rig.settled`` uses by default
#: static shapes settle on this many threads (at most one per core) when the rig offers ``worker_copy``;
#: the compiled substeps release the GIL, so the second core settles the next shape meanwhile
SETTLE_THREADS = 2

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


def _settled_in_order(rig: Rig, value_list: Iterable[dict], settle_time: float,
                      cache: ShapeCache | None) -> Iterator[Pose]:
    """The settled pose of each control dict of ``value_list``, in order. A control dict met again is settled
    once (a settle starts from rest: equal dicts settle to equal bytes) and handed out as its own copy."""
    values = list(value_list)
    keys = [tuple(sorted(controls.items())) for controls in values]
    first = {}                                      # key -> the position it first occurs at
    for position, key in enumerate(keys):
        first.setdefault(key, position)
    repeated = {key for position, key in enumerate(keys) if first[key] != position}
    distinct = _settled_each(rig, [controls for position, controls in enumerate(values)
                                   if first[keys[position]] == position], settle_time, cache)
    kept: dict[tuple, Pose] = {}
    try:
        for position, key in enumerate(keys):
            if first[key] != position:
                yield _copied(kept[key])
                continue
            pose = next(distinct)
            if key in repeated:
                kept[key] = _copied(pose)
            yield pose
    finally:
        distinct.close()


def _settled_each(rig: Rig, value_list: list[dict], settle_time: float,
                  cache: ShapeCache | None) -> Iterator[Pose]:
    """The settled pose of each control dict of ``value_list``, in order. A rig with ``worker_copy()``
    settles the shapes the cache does not hold on :data:`SETTLE_THREADS` threads, each on its own copy
    (the rig itself stays free for the caller); a settle starts from rest, so each shape is byte-identical
    to the one settled alone. Closing the generator early waits for the settles under way."""
    threads = min(SETTLE_THREADS, os.cpu_count() or 1) if hasattr(rig, "worker_copy") else 1
    if threads <= 1:
        for values in value_list:
            yield _settled(rig, values, settle_time, cache)
        return
    copies: queue.SimpleQueue = queue.SimpleQueue()
    for _ in range(threads):
        copies.put(rig.worker_copy())

    def settle(values: dict) -> Pose:
        worker = copies.get()
        try:
            return worker.settled({BASE_LAYER: values}, settle_time)
        finally:
            copies.put(worker)

    pending: deque = deque()
    with ThreadPoolExecutor(threads, thread_name_prefix="fh-settle") as pool:
        try:
            for values in value_list:
                place, pose = cache.lookup(rig, {BASE_LAYER: values}, settle_time, SETTLE_DT) if cache else (None, None)
                if pose is None:
                    future = pool.submit(settle, values)
                else:
                    future = Future()
                    future.set_result(pose)
                pending.append((place, pose is None, future))
                while len(pending) > 2 * threads:
                    yield _collect(pending.popleft(), cache)
            while pending:
                yield _collect(pending.popleft(), cache)
        finally:
            pool.shutdown(wait=True, cancel_futures=True)


def _collect(entry, cache: ShapeCache | None) -> Pose:
    place, computed, future = entry
    pose = future.result()
    if computed and cache is not None:
        cache.store(place, pose)
    return pose


def _copied(pose: Pose) -> Pose:
    return Pose({role: array.copy() for role, array in pose.positions.items()},
                {role: matrix.copy() for role, matrix in pose.transforms.items()})


def basis_shapes(rig: Rig, settle_time: float = 1.5, cache: ShapeCache | None = None) -> Iterator[BakedShape]:
    """One shape per control at its full value (the range end farthest from 0); ``cache`` keeps settled
    shapes across bakes (``shape_cache``)."""
    specs = list(rig.control_specs().items())
    poses = _settled_in_order(rig, ({name: spec.full_value} for name, spec in specs), settle_time, cache)
    for index, pose in enumerate(poses):
        name, spec = specs[index]
        full = spec.full_value
        yield BakedShape(BASIS_PREFIX + name, pose, control=name,
                         value_range=(spec.minimum / full if full else 0.0, spec.maximum / full if full else 1.0))
    rig.reset()


def expression_shapes(rig: Rig, expressions: Mapping[str, Mapping[str, float]], settle_time: float = 1.5,
                      cache: ShapeCache | None = None) -> Iterator[BakedShape]:
    """One shape per named expression (a partial control dict; unknown control names are refused)."""
    specs = rig.control_specs()
    checked = {name: clamp_controls(expression, specs, strict=True) for name, expression in expressions.items()}
    names = list(checked)
    for index, pose in enumerate(_settled_in_order(rig, checked.values(), settle_time, cache)):
        yield BakedShape(names[index], pose)
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
