# SPDX-License-Identifier: GPL-3.0-or-later
"""Masses and moments of inertia of the hand's bones (thesis 6.2.2, Eq. 6.8 and "Rotation of Chains of
Bones", Fig. 6.14).

*Masses.* Each segment's mass is bone plus surrounding tissue. Published per-phalanx masses were not
available (presets/SOURCES.md, "Hand masses"), so a segment is a solid cylinder of the skin's own cross
section: its radius is the median distance of the skin nodes it carries from the bone axis, its length the
bone's, and its density that of the hand, 1.148 g/cm^3 (Drillis 1968). The whole hand's mass is reported
next to de Leva's 0.61 % of body mass.

*Single bone* (Eq. 6.8): ``J = m l^2 / 3``, a solid cylinder rotated about an axis through one end.

*Chains* of up to three bones: for joint ``J_i`` with children ``J_{i+1}`` (angle ``beta``) and ``J_{i+2}``
(angle ``alpha``), ``J = J_i + J*_{i+1}[beta] + J*_{i+2}[alpha][beta]``, where a starred term is the mass of
the child bone times the mean squared distance of its (transformed) mesh vertices from the joint's axis.
The starred terms depend only on the children's flexion angles and are tabulated in 5-degree steps
(``TABLE_STEP``) and read by (bi)linear interpolation. The wrist sees a constant moment of inertia of the
whole hand; so does the CMC joint of the ring and little fingers, whose chains are four bones long.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .skeleton import Skeleton, rotation_matrices

__all__ = ["DENSITY", "TABLE_STEP", "GRID", "segment_masses", "cylinder_inertia", "ChainInertia",
           "mean_square_distance"]

DENSITY = 1148.0                       # kg/m^3, the hand (Drillis 1968)
TABLE_STEP = np.radians(5.0)
GRID = np.radians(np.arange(-60.0, 115.0 + 1e-9, 5.0))   # covers every flexion range of Table 6.4
MESH_SAMPLES = 600                      # vertices per bone used for the starred terms


def cylinder_inertia(mass: np.ndarray, length: np.ndarray) -> np.ndarray:
    """Eq. 6.8: ``J = 1/3 m l^2`` (solid cylinder about an axis through one of its ends)."""
    return np.asarray(mass) * np.asarray(length) ** 2 / 3.0


def segment_masses(skeleton: Skeleton, skin_vertices: np.ndarray, skin_weights: np.ndarray) -> np.ndarray:
    """Bone-plus-tissue mass (kg) of every bone (module docstring); the forearm gets 0 (it never moves)."""
    owner = np.argmax(skin_weights, axis=1)
    masses = np.zeros(len(skeleton.names))
    for b in range(1, len(skeleton.names)):
        head, tail = skeleton.position[b], skeleton.tail[b]
        axis = tail - head
        length = float(np.linalg.norm(axis))
        points = skin_vertices[owner == b]
        if len(points) < 3 or length <= 0:
            continue
        t = np.clip((points - head) @ axis / length ** 2, 0.0, 1.0)
        radius = float(np.median(np.linalg.norm(points - (head + t[:, None] * axis), axis=1)))
        masses[b] = DENSITY * np.pi * radius ** 2 * length
    return masses


def mean_square_distance(points: np.ndarray, origin: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Mean squared distance of ``points`` (..., V, 3) from the line through ``origin`` along unit ``axis``."""
    d = points - origin
    along = d @ axis
    return np.mean(np.einsum("...i,...i->...", d, d) - along ** 2, axis=-1)


def _samples(vertices: np.ndarray) -> np.ndarray:
    step = max(1, len(vertices) // MESH_SAMPLES)
    return vertices[::step]


def _flexion_rotation(skeleton: Skeleton, bone: int, angles: np.ndarray) -> np.ndarray:
    """(G, 3, 3) rotations of ``bone``'s flexion by ``angles`` in world axes (rest frames)."""
    axis = skeleton.frame[bone][:, 0]
    return rotation_matrices(np.broadcast_to(axis, (len(angles), 3)), angles)


@dataclass
class _DofInertia:
    own: float                   # J_i of the rotated bone (Eq. 6.8), or the constant of a wrist / CMC chain
    child_dof: int = -1          # DOF index of the child's flexion (beta), -1 if none
    grandchild_dof: int = -1     # DOF index of the grandchild's flexion (alpha), -1 if none
    child_table: np.ndarray | None = None        # J*_{i+1}[beta] over GRID
    grandchild_table: np.ndarray | None = None   # J*_{i+2}[alpha][beta] over GRID x GRID (alpha, beta)


class ChainInertia:
    """Moment of inertia of every dynamic DOF as a function of the pose (module docstring)."""

    def __init__(self, skeleton: Skeleton, masses: np.ndarray, dynamic: np.ndarray):
        self.skeleton, self.masses = skeleton, masses
        self.entries: dict[int, _DofInertia] = {}
        lengths = np.array([skeleton.bone_length(b) for b in range(len(skeleton.names))])
        self.own = cylinder_inertia(masses, lengths)
        for k in np.flatnonzero(dynamic):
            self.entries[int(k)] = self._entry(int(k))
        self._vectorise(skeleton.dof_count)

    # -- tables ----------------------------------------------------------------------------------
    def _flexion_children(self, bone: int) -> list[int]:
        sk = self.skeleton
        chain, b = [], bone
        while True:
            kids = sk.children(b)
            if len(kids) != 1:
                return chain
            b = kids[0]
            chain.append(b)

    def _entry(self, k: int) -> _DofInertia:
        sk = self.skeleton
        dof = sk.dofs[k]
        bone = dof.bone
        axis = sk.frame[bone][:, ("flexion", "abduction", "rotation").index(dof.kind)]
        origin = sk.position[bone]
        chain = self._flexion_children(bone)
        if sk.names[bone] == "wrist" or len(chain) > 2:
            return _DofInertia(self.constant_inertia(bone, axis))
        entry = _DofInertia(float(self.own[bone]))
        if chain:
            c = chain[0]
            entry.child_dof = sk.dof_index.get((sk.names[c], "flexion"), -1)
            entry.child_table = self.starred(c, origin, axis, [c], GRID[:, None])
        if len(chain) == 2:
            g = chain[1]
            entry.grandchild_dof = sk.dof_index.get((sk.names[g], "flexion"), -1)
            alpha, beta = np.meshgrid(GRID, GRID, indexing="ij")
            entry.grandchild_table = self.starred(g, origin, axis, [chain[0], g],
                                                  np.stack([beta.ravel(), alpha.ravel()], axis=1)
                                                  ).reshape(len(GRID), len(GRID))
        return entry

    def starred(self, bone: int, origin: np.ndarray, axis: np.ndarray, rotated: list[int],
                angles: np.ndarray) -> np.ndarray:
        """``J*`` of ``bone`` about the axis (``origin``, ``axis``) with the flexion of every bone in ``rotated``
        (parents first) set to the matching column of ``angles`` (G, len(rotated))."""
        sk = self.skeleton
        samples = _samples(sk.mesh_vertices[sk.names[bone]])
        points = np.broadcast_to(samples, (len(angles),) + samples.shape).copy()
        for column in range(len(rotated) - 1, -1, -1):   # innermost joint first, then its parents
            joint = rotated[column]
            rotation = _flexion_rotation(sk, joint, angles[:, column])
            centre = sk.position[joint]
            points = np.einsum("gij,gvj->gvi", rotation, points - centre) + centre
        return self.masses[bone] * mean_square_distance(points, origin, axis)

    def constant_inertia(self, bone: int, axis: np.ndarray) -> float:
        """Every bone below ``bone`` at rest as point masses on its mesh vertices (the hand at the wrist)."""
        sk = self.skeleton
        total = 0.0
        for b in sk.chain_below(bone):
            points = _samples(sk.mesh_vertices[sk.names[b]])
            total += self.masses[b] * float(mean_square_distance(points, sk.position[bone], axis))
        return total

    # -- look-up ---------------------------------------------------------------------------------
    def _vectorise(self, dof_count: int) -> None:
        keys = sorted(self.entries)
        self.dofs = np.array(keys, np.int64)
        self.base = np.array([self.entries[k].own for k in keys])
        grid = len(GRID)
        self.child_dof = np.array([self.entries[k].child_dof for k in keys], np.int64)
        self.grand_dof = np.array([self.entries[k].grandchild_dof for k in keys], np.int64)
        self.child_tables = np.zeros((len(keys), grid))
        self.grand_tables = np.zeros((len(keys), grid, grid))
        for row, k in enumerate(keys):
            e = self.entries[k]
            if e.child_table is not None:
                self.child_tables[row] = e.child_table
            if e.grandchild_table is not None:
                self.grand_tables[row] = e.grandchild_table

    def __call__(self, angles: np.ndarray) -> np.ndarray:
        """Moments of inertia (kg m^2) of the dynamic DOFs (``self.dofs`` order) at the pose ``angles``."""
        out = self.base.copy()
        rows = np.arange(len(self.dofs))
        beta = np.where(self.child_dof >= 0, angles[np.maximum(self.child_dof, 0)], 0.0)
        alpha = np.where(self.grand_dof >= 0, angles[np.maximum(self.grand_dof, 0)], 0.0)
        fb = np.clip((beta - GRID[0]) / TABLE_STEP, 0.0, len(GRID) - 1.000001)
        fa = np.clip((alpha - GRID[0]) / TABLE_STEP, 0.0, len(GRID) - 1.000001)
        ib, ia = fb.astype(np.int64), fa.astype(np.int64)
        wb, wa = fb - ib, fa - ia
        t1 = self.child_tables
        out += t1[rows, ib] * (1 - wb) + t1[rows, ib + 1] * wb
        t2 = self.grand_tables
        out += ((t2[rows, ia, ib] * (1 - wb) + t2[rows, ia, ib + 1] * wb) * (1 - wa)
                + (t2[rows, ia + 1, ib] * (1 - wb) + t2[rows, ia + 1, ib + 1] * wb) * wa)
        return out

    def direct(self, k: int, angles: np.ndarray) -> float:
        """The same moment of inertia computed directly from the transformed meshes (no tables): for tests."""
        sk = self.skeleton
        dof = sk.dofs[k]
        bone = dof.bone
        entry = self.entries[k]
        axis = sk.frame[bone][:, ("flexion", "abduction", "rotation").index(dof.kind)]
        if entry.child_table is None:
            return entry.own
        chain = self._flexion_children(bone)
        beta = angles[entry.child_dof] if entry.child_dof >= 0 else 0.0
        total = entry.own + float(self.starred(chain[0], sk.position[bone], axis, [chain[0]], np.array([[beta]]))[0])
        if entry.grandchild_table is not None:
            alpha = angles[entry.grandchild_dof] if entry.grandchild_dof >= 0 else 0.0
            total += float(self.starred(chain[1], sk.position[bone], axis, chain[:2], np.array([[beta, alpha]]))[0])
        return total
