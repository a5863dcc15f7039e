# SPDX-License-Identifier: GPL-3.0-or-later
"""Lip closures in the exact per-frame simulation: each /p b m/ is fed early enough that the simulated
lips have met when its closure starts, checked by simulating ahead.

Thesis 3.1.3 closes the lips for the closure phase of /p b/ and for /m/; the mass-spring face of 3.1.2
reaches a target only after its own closing time, which depends on how far apart the lips are and how
fast they are moving: from a nearly closed /u/ one frame is enough, from an opening /a/ before a 50-ms
/b/ it takes three or four frames at 30 fps. A fixed lead either misses those closures (the lips stay
1-3 mm apart) or closes every other one too early. So each closure gets the shortest lead that works:

* the closure's viseme articulation is fed from ``min`` rows before its first closed row (the fixed lead
  every closure gets), the simulation runs to that row, and the rig's lip gap (``rig.lip_gap()``) is read;
* when the lips are not shut there (gap above ``CLOSED_GAP_M``), the simulation goes back to the state it
  had before the lead (a snapshot of the rig) and runs again with one row more, up to ``max_lead`` rows.

Only the accepted run's poses are yielded, so the result is the same as a plain simulation fed that table
(byte for byte: a retry continues on an exact copy of the rig made before the lead). After a retry the
simulation goes on in that copy, not in the rig handed in. Rigs without ``lip_gap`` get the fixed lead.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Iterator, Sequence

from .layers import LayerTable

__all__ = ["ClosureDrive", "CLOSED_GAP_M"]

#: the lips count as met at this midline gap (the accuracy bench's closed aperture, 1 mm, with margin)
CLOSED_GAP_M = 0.0005


def _copy(rig):
    """An exact copy of ``rig`` and its simulation state; the (large, never changed) template is shared."""
    template = getattr(rig, "template", None)
    return copy.deepcopy(rig, {id(template): template} if template is not None else {})


@dataclass
class ClosureDrive:
    """The closures of a bake and the table that shows them.

    ``closed`` is the bake's table with each closure's articulation on every row it may be fed (from
    ``max_lead`` rows before the closure to its end). ``spans`` are the closures, sorted, as (always, first,
    last) rows: ``first..last`` must show the lips closed (``anim.semantic.closure_frames``) and are always
    fed the closure, like the rows from ``always`` (the fixed minimum lead); earlier rows, at most
    ``max_lead`` before ``first``, only when the simulation says the lips need them."""
    closed: LayerTable
    spans: Sequence[tuple[int, int, int]]
    max_lead: int = 6
    leads: list[int] = field(default_factory=list)     # rows of lead each closure got
    retries: int = 0                                    # runs simulated again with a longer lead

    def poses(self, rig, table: LayerTable, dt: float, settle_time: float) -> Iterator:
        """The rig's pose per row of ``table`` (the row of ``closed`` where a closure is fed)."""
        fed = [False] * len(table)
        for always, first, last in self.spans:
            for row in range(max(always, 0), min(last + 1, len(table))):
                fed[row] = True

        def step(rig, row: int):
            values = self.closed.at(row) if fed[row] else table.at(row)
            return rig.settled(values, settle_time, dt) if row == 0 else rig.step(values, dt)

        checks = hasattr(rig, "lip_gap")
        row = 0
        for always, first, last in self.spans:
            if first < row:                         # shut already with the closure before it
                continue
            earliest = max(row, first - self.max_lead, 0)
            while row < earliest:
                yield step(rig, row)
                row += 1
            start = max(min(always, first), earliest)
            saved = _copy(rig) if checks and start > earliest else None
            while True:
                buffered = [step(rig, r) for r in range(row, first + 1)]
                if saved is None or rig.lip_gap() <= CLOSED_GAP_M or start <= earliest:
                    break
                start -= 1                          # one more row of lead, from the state before it
                fed[start] = True
                self.retries += 1
                rig = _copy(saved)
            self.leads.append(first - start)
            yield from buffered
            row = first + 1
        while row < len(table):
            yield step(rig, row)
            row += 1
