# SPDX-License-Identifier: GPL-3.0-or-later
"""The MEDUSA mass-spring network (thesis 3.1.2 "Mass Spring Network", Fig. 3.4).

Nodes with point masses are joined by Hookean springs. Skin-edge springs are *biphasic*: soft up to a
strain threshold, stiff beyond it (the stress-strain curve of real skin). Every dynamic node may also carry
an *attachment*: a spring to a point on bone or muscle (connective tissue, "rather low" stiffness) and a
second spring to that point mirrored outward through the node, which models the internal pressure of the
skin and keeps it off the bone (Fig. 3.4). Attachment points are kinematic: the rig moves them with the
jaw and the muscles, and the skin follows through the springs.

Layout for speed (see presets/SOURCES.md, "Speed and export facts"): coordinates are stored as ``(3, N)`` so one
flattened ``np.bincount`` scatters the forces of all springs onto all three axes at once, and every
temporary lives in a buffer allocated once.

Sign convention. The thesis writes the force a spring exerts on its end node as
``F = c (l - l0)/l (x_e - x_s)`` and then sums "ends in" minus "starts in". The physically restoring force
on the end node is ``-c (l - l0)/l (x_e - x_s)`` (a stretched spring pulls its ends together); that is what
:meth:`SpringNetwork.forces` returns, and what makes the rest state a stable equilibrium.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.errors import UserError

__all__ = ["SpringSet", "Attachments", "SpringNetwork", "biphasic_force"]


def biphasic_force(stretch: np.ndarray, rest: np.ndarray, k_soft: np.ndarray, k_stiff: np.ndarray,
                   strain_threshold: np.ndarray, k_compress: np.ndarray | None = None) -> np.ndarray:
    """Spring force magnitude for an elongation ``stretch = l - l0`` (3.1.2: "biphasic" skin stiffness).

    ``k_soft * dl + (k_stiff - k_soft) * max(dl - e * l0, 0)``: soft below the strain threshold ``e``,
    stiff above it, continuous at the threshold and free of branches (so it is fast and gives the same
    rounding in every implementation). Compression uses ``k_compress`` (default: the soft constant) via
    ``+ (k_compress - k_soft) * min(dl, 0)``, still continuous: skin gives way under compression.
    """
    force = k_soft * stretch + (k_stiff - k_soft) * np.maximum(stretch - strain_threshold * rest, 0.0)
    if k_compress is not None:
        force = force + (k_compress - k_soft) * np.minimum(stretch, 0.0)
    return force


@dataclass
class SpringSet:
    """Springs between network nodes (3.1.2): ``start``/``end`` node indices, rest lengths ``rest`` (m),
    soft and stiff constants (N/m) and the strain at which the stiff branch starts (biphasic law)."""
    start: np.ndarray
    end: np.ndarray
    rest: np.ndarray
    k_soft: np.ndarray
    k_stiff: np.ndarray
    strain_threshold: np.ndarray
    k_compress: np.ndarray | None = None      # compression constant (None: the soft one)

    def __post_init__(self) -> None:
        self.start = np.ascontiguousarray(self.start, dtype=np.int64)
        self.end = np.ascontiguousarray(self.end, dtype=np.int64)
        count = self.start.shape[0]
        if self.end.shape != (count,):
            raise UserError("spring start and end index arrays differ in length; pass one index per spring")
        if self.k_compress is None:
            self.k_compress = self.k_soft
        for name in ("rest", "k_soft", "k_stiff", "strain_threshold", "k_compress"):
            value = np.broadcast_to(np.asarray(getattr(self, name), dtype=np.float64), (count,))
            setattr(self, name, np.ascontiguousarray(value))
        if count and np.any(self.k_compress < 0):
            raise UserError("spring compression stiffness must be >= 0")
        if count and (np.any(self.k_soft < 0) or np.any(self.k_stiff < self.k_soft)):
            raise UserError("spring stiffness must satisfy 0 <= soft <= stiff; check the skin stiffness settings")
        if count and (np.any(self.rest < 0) or np.any(self.strain_threshold < 0)):
            raise UserError("spring rest lengths and strain thresholds must be >= 0")

    @property
    def count(self) -> int:
        return int(self.start.shape[0])

    @property
    def max_stiffness(self) -> np.ndarray:
        """Largest tangent stiffness of each spring: the stiff branch (used by the stability guard)."""
        return np.maximum(np.maximum(self.k_stiff, self.k_soft), self.k_compress)


@dataclass
class Attachments:
    """Connective-tissue springs from dynamic nodes to kinematic points (3.1.2, Fig. 3.4).

    ``node[i]`` is attached to ``anchor[:, i]`` on bone or muscle and, for volume preservation, to
    ``mirror[:, i]``: the anchor reflected outward through the node's rest position, carried along with
    the anchor. Both springs share ``stiffness[i]`` and ``rest[i]``. With ``rest = 0`` (the default the
    face uses) the pair is pre-tensioned like a string between anchor and mirror: it holds the node at
    the midpoint with equal normal and tangential stiffness ``2 * stiffness``, so the skin follows a
    muscle that slides under it while the outward spring keeps it off the bone.
    """
    node: np.ndarray
    stiffness: np.ndarray
    rest: np.ndarray
    anchor: np.ndarray
    mirror: np.ndarray

    def __post_init__(self) -> None:
        self.node = np.ascontiguousarray(self.node, dtype=np.int64)
        count = self.node.shape[0]
        self.stiffness = np.ascontiguousarray(np.broadcast_to(np.asarray(self.stiffness, np.float64), (count,)))
        self.rest = np.ascontiguousarray(np.broadcast_to(np.asarray(self.rest, np.float64), (count,)))
        self.anchor = np.ascontiguousarray(np.asarray(self.anchor, np.float64).reshape(3, count))
        self.mirror = np.ascontiguousarray(np.asarray(self.mirror, np.float64).reshape(3, count))
        if count and (np.any(self.stiffness < 0) or np.any(self.rest < 0)):
            raise UserError("attachment stiffness and rest lengths must be >= 0")
        if len(np.unique(self.node)) != count:
            raise UserError("a node can carry only one attachment pair; merge duplicate attachments")

    @property
    def count(self) -> int:
        return int(self.node.shape[0])


def _materials(k_soft: np.ndarray, k_extra: np.ndarray, k_yield: np.ndarray, threshold: np.ndarray,
               ratio: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The springs' constants as the fused kernel reads them: each spring's material (S,) and the table of
    distinct materials (M, 5): soft constant, stiff extra, compression change, strain threshold, shortest-length
    ratio (rows equal bit for bit; a table of at most four rows is padded to four, the kernel's fast case)."""
    columns = np.ascontiguousarray(np.stack([k_soft, k_extra, k_yield, threshold, ratio], axis=1), np.float64)
    bits, material = np.unique(columns.view(np.int64), axis=0, return_inverse=True)
    table = bits.view(np.float64).reshape(-1, 5)
    if len(table) < 4:
        table = np.concatenate([table, np.zeros((4 - len(table), 5))])
    return material.reshape(-1).astype(np.uint8 if len(table) <= 256 else np.int32), np.ascontiguousarray(table)


class SpringNetwork:
    """Nodes, masses, springs and attachments; computes the total spring force on every node.

    Built from ``(N, 3)`` positions; stored internally as ``self.positions`` of shape ``(3, N)`` float64.
    ``kinematic`` marks pinned/driven nodes: they feel forces but do not integrate them; the caller moves
    them (3.1.2: "static mass points" on bone and muscle). ``kernel_materials``: the springs' constants as
    the fused kernel reads them (:func:`_materials`)."""

    def __init__(self, positions: np.ndarray, masses: np.ndarray, springs: SpringSet,
                 attachments: Attachments | None = None, kinematic: np.ndarray | None = None) -> None:
        positions = np.asarray(positions, dtype=np.float64)
        if positions.ndim != 2 or positions.shape[1] != 3:
            raise UserError("node positions must be an (N, 3) array")
        positions = positions.T
        self.positions = np.ascontiguousarray(positions)
        count = self.positions.shape[1]
        self.masses = np.ascontiguousarray(np.broadcast_to(np.asarray(masses, np.float64), (count,)))
        if np.any(~np.isfinite(self.positions)):
            raise UserError("node positions contain NaN or infinity; fix the input mesh")
        if np.any(self.masses <= 0):
            raise UserError("node masses must be > 0")
        self.springs = springs
        if springs.count and (springs.start.max() >= count or springs.end.max() >= count
                              or min(springs.start.min(), springs.end.min()) < 0):
            raise UserError("a spring refers to a node that does not exist")
        self.attachments = attachments if attachments is not None else Attachments(
            np.zeros(0, np.int64), np.zeros(0), np.zeros(0), np.zeros((3, 0)), np.zeros((3, 0)))
        if self.attachments.count and (self.attachments.node.max() >= count or self.attachments.node.min() < 0):
            raise UserError("an attachment refers to a node that does not exist")
        self.kinematic = np.zeros(count, bool) if kinematic is None else np.asarray(kinematic, bool).copy()
        self._allocate_buffers()

    @property
    def node_count(self) -> int:
        return int(self.positions.shape[1])

    # -- buffers ---------------------------------------------------------------------------------
    def _allocate_buffers(self) -> None:
        count, springs = self.node_count, self.springs
        s = springs.count
        both = np.concatenate([springs.end, springs.start])
        # one flattened scatter for all three axes: row c of the (3, 2S) weights goes to c*N + node
        self._scatter_index = (np.arange(3, dtype=np.int64)[:, None] * count + both[None, :]).ravel()
        self._delta = np.empty((3, s))
        self._gather = np.empty((3, s))
        self._length = np.empty(s)
        self._scale = np.empty(s)
        self._tmp = np.empty(s)
        self._weights = np.empty((3, 2 * s))
        # |f / l| <= k_stiff needs l >= l0 k_soft / (k_soft + k_stiff) under compression (guarded divisor)
        denominator = springs.k_compress + springs.max_stiffness
        ratio = np.divide(springs.k_compress, denominator, out=np.zeros(s), where=denominator > 0)
        self._min_length = np.maximum(springs.rest * ratio, 1e-12)
        self._knee = springs.strain_threshold * springs.rest
        self._k_extra = springs.k_stiff - springs.k_soft
        self._k_yield = springs.k_compress - springs.k_soft
        self._has_yield = bool(s and np.any(self._k_yield != 0))
        self.kernel_materials = _materials(springs.k_soft, self._k_extra, self._k_yield, springs.strain_threshold,
                                           ratio)
        a = self.attachments.count
        self._att_delta = np.empty((3, a))
        self._att_pos = np.empty((3, a))
        self._att_len = np.empty(a)
        self._att_scale = np.empty(a)
        self._att_total = np.empty((3, a))
        self._att_min_length = np.maximum(0.5 * self.attachments.rest, 1e-12)
        self._att_has_rest = bool(a and np.any(self.attachments.rest > 0))
        self._att_identity = bool(a == count and np.array_equal(self.attachments.node, np.arange(count)))
        self._att_two_c = 2.0 * self.attachments.stiffness
        #: zero-rest pairs pull with c (anchor + mirror) - 2 c x: the first term, kept up to date
        self.attachment_pull = np.empty((3, a))
        self._refresh_pull()
        self.force = np.zeros((3, count))

    @property
    def zero_rest_attachments(self) -> bool:
        return not self._att_has_rest

    def _refresh_pull(self) -> None:
        att = self.attachments
        np.add(att.anchor, att.mirror, out=self.attachment_pull)
        self.attachment_pull *= att.stiffness

    def set_attachment_targets(self, anchor: np.ndarray, mirror: np.ndarray) -> None:
        """Move the attachment points (3, A) and their mirrored twins (kinematic, e.g. with a muscle)."""
        self.attachments.anchor[...] = anchor
        self.attachments.mirror[...] = mirror
        self._refresh_pull()

    # -- forces ----------------------------------------------------------------------------------
    def forces(self, positions: np.ndarray | None = None) -> np.ndarray:
        """Total spring force on every node, ``(3, N)`` (3.1.2: sum over springs ending minus starting).

        Returns an internal buffer that the next call overwrites.
        """
        x = self.positions if positions is None else positions
        springs = self.springs
        force = self.force
        if springs.count:
            delta, length, scale = self._delta, self._length, self._scale
            np.take(x, springs.end, axis=1, out=delta)
            np.take(x, springs.start, axis=1, out=self._gather)
            np.subtract(delta, self._gather, out=delta)                    # x_e - x_s
            np.multiply(delta, delta, out=self._gather)
            np.sum(self._gather, axis=0, out=length)
            np.sqrt(length, out=length)
            np.subtract(length, springs.rest, out=scale)                   # dl = l - l0
            np.subtract(scale, self._knee, out=self._tmp)
            np.maximum(self._tmp, 0.0, out=self._tmp)
            np.multiply(self._tmp, self._k_extra, out=self._tmp)
            if self._has_yield:                                            # softer under compression
                np.add(self._tmp, np.minimum(scale, 0.0) * self._k_yield, out=self._tmp)
            np.multiply(scale, springs.k_soft, out=scale)
            np.add(scale, self._tmp, out=scale)                            # biphasic magnitude
            np.maximum(length, self._min_length, out=length)
            np.divide(scale, length, out=scale)                            # f / l
            s = springs.count
            weights = self._weights
            np.multiply(delta, scale, out=weights[:, s:])                  # pulls the start towards the end
            np.negative(weights[:, s:], out=weights[:, :s])                # and the end towards the start
            force[...] = np.bincount(self._scatter_index, weights.ravel(),
                                     minlength=3 * self.node_count).reshape(3, -1)
        else:
            force.fill(0.0)
        self._add_attachment_forces(x, force)
        return force

    def _add_attachment_forces(self, x: np.ndarray, force: np.ndarray) -> None:
        att = self.attachments
        if not att.count:
            return
        if not self._att_has_rest:
            # rest length 0: c (anchor - x) + c (mirror - x) = pull - 2 c x, linear and gather-free
            if self._att_identity:
                np.multiply(x, self._att_two_c, out=self._att_total)
                force += self.attachment_pull
                force -= self._att_total
            else:
                np.take(x, att.node, axis=1, out=self._att_pos)
                np.multiply(self._att_pos, self._att_two_c, out=self._att_total)
                force[:, att.node] += self.attachment_pull - self._att_total
            return
        np.take(x, att.node, axis=1, out=self._att_pos)
        total = self._att_total
        total.fill(0.0)
        delta = self._att_delta
        for target in (att.anchor, att.mirror):
            np.subtract(target, self._att_pos, out=delta)                  # node -> anchor (or mirror)
            if self._att_has_rest:
                length, scale = self._att_len, self._att_scale
                np.sqrt(np.einsum("ij,ij->j", delta, delta), out=length)
                np.subtract(length, att.rest, out=scale)
                np.maximum(length, self._att_min_length, out=length)
                np.divide(scale, length, out=scale)
                np.multiply(scale, att.stiffness, out=scale)
                np.multiply(delta, scale, out=delta)
            else:
                np.multiply(delta, att.stiffness, out=delta)
            np.add(total, delta, out=total)
        force[:, att.node] += total

    # -- energy (tests, diagnostics) -------------------------------------------------------------
    def potential_energy(self, positions: np.ndarray | None = None) -> float:
        """Elastic energy of all springs (integral of the biphasic force law)."""
        x = self.positions if positions is None else positions
        sp = self.springs
        energy = 0.0
        if sp.count:
            length = np.linalg.norm(x[:, sp.end] - x[:, sp.start], axis=0)
            dl = length - sp.rest
            over = np.maximum(dl - self._knee, 0.0)
            under = np.minimum(dl, 0.0)
            energy += float(np.sum(0.5 * sp.k_soft * dl * dl + 0.5 * self._k_extra * over * over
                                   + 0.5 * self._k_yield * under * under))
        att = self.attachments
        if att.count:
            pos = x[:, att.node]
            for target in (att.anchor, att.mirror):
                dl = np.linalg.norm(target - pos, axis=0) - att.rest
                energy += float(np.sum(0.5 * att.stiffness * dl * dl))
        return energy
