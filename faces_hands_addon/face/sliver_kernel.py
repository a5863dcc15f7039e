# SPDX-License-Identifier: GPL-3.0-or-later
"""The sliver ties' placement (:class:`.network.SliverTies`, after the guards of every few substeps of
thesis 3.1.2 "Mass Spring Network") as one compiled loop, for the live preview.

In numpy every batch of ties is four fancy-indexed whole-array operations on a few dozen nodes, repeated
over the batches and the passes: a few hundred calls per guard step whose overhead dwarfs the arithmetic.
Here the batches, concatenated in their order, go in one loop per pass. A batch holds no node twice, so
placing its ties one after another gives what the batch's whole-array assignment gives; the numpy method
stays the reference (same formula, same order of operations).
"""
from __future__ import annotations

__all__ = ["place_apices"]


def place_apices(positions, velocity, apex, start, end, share, offset, passes):  # pragma: no cover - compiled
    """Every tie's apex put on its edge at its rest ``offset`` (3, T) from the point ``share`` along it,
    its velocity the edge point's; ``passes`` sweeps over the ties (positions, velocities (3, N), in place)."""
    for _ in range(passes):
        for t in range(apex.shape[0]):
            k, a, b, s = apex[t], start[t], end[t], share[t]
            for c in range(3):
                positions[c, k] = (1.0 - s) * positions[c, a] + s * positions[c, b] + offset[c, t]
                velocity[c, k] = (1.0 - s) * velocity[c, a] + s * velocity[c, b]
