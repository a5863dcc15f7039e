# SPDX-License-Identifier: GPL-3.0-or-later
"""Folded skin triangles mended after a settle (thesis 3.1.2 "Mass Spring Network").

The thesis' skin is a spring mesh of the template's resolution; on an artist's mesh every vertex is a node
(:mod:`.transfer`), and on a dense head the triangles at the mouth corners, on the lower lip and at the lid
margins are 0.4-1.5 mm across. A muscle's pull or the lips' contact that varies over a few millimetres then
moves neighbouring nodes by more than their spacing and turns single triangles over (the shape audit's
``inverted``: a normal more than 90 degrees from its rest normal). A spring mesh has no term that forbids it.

The mend works on the displacement from rest, not on the positions: the skin's rest shape (the artist's
sculpt) is kept and only the way it moves is made smooth where it folded. Round every turned-over visible
triangle, the displacement of the free nodes is replaced by the *harmonic* one: the solution of the discrete
Laplace equation (uniform weights over the mesh's edges) with the displacement of the nodes round the region
held. A harmonic field has no interior extremum, so a region moves as a smooth blend of how its rim moves,
and a fine triangle inside it turns with its neighbours instead of over them. If a fold is left, the region
grows by ``GROW`` rings and is solved again, up to ``ROUNDS`` times.

What never moves (the region's rim holds it): nodes the camera does not see (inner lips, mouth bag, lid
backs: the lips' and lids' contact lives there), the lid and inner-lip margins, and nodes the simulation
does not move (``fixed``). The displacement is mended in place on the network's (3, N) positions, so a
bake's next frame, the audit and the baked targets all see the same mended skin.
"""
from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import splu
from scipy.spatial import cKDTree

from ..core import geometry

__all__ = ["FoldMender", "touching", "ROUNDS", "GROW"]

ROUNDS = 6      # solves at most; each grows the region round the folds that are left
GROW = 2        # rings added round the remaining folds per round (the first region: their nodes + 1 ring)
REGULAR = 1e-6  # diagonal added to the Laplacian (its diagonal is a node's edge count, 3-12)


def touching(positions: np.ndarray, upper: np.ndarray, lower: np.ndarray, reach: float) -> np.ndarray:
    """Nodes of the two margins ``upper`` and ``lower`` (node ids) within ``reach`` of the other margin
    (the lips' contact, 3.1.3 closures); empty where a margin is (a mesh whose contour was not traced)."""
    if len(upper) == 0 or len(lower) == 0:
        return np.zeros(0, np.int64)
    tree = cKDTree(positions[lower])
    near_upper = upper[tree.query(positions[upper], distance_upper_bound=reach)[0] < reach]
    tree = cKDTree(positions[upper])
    near_lower = lower[tree.query(positions[lower], distance_upper_bound=reach)[0] < reach]
    return np.concatenate([near_upper, near_lower])


class FoldMender:
    """Mends folds of one skin (its rest vertices, triangles and the nodes allowed to move)."""

    def __init__(self, rest: np.ndarray, faces: np.ndarray, movable: np.ndarray, visible: np.ndarray) -> None:
        """``rest`` (N, 3) rest positions, ``faces`` (M, 3), ``movable`` (N,) nodes the mend may move,
        ``visible`` (M,) triangles whose folds count (the outer skin)."""
        self.rest = np.asarray(rest, np.float64)
        self.faces = np.asarray(faces, np.int64)
        self.movable = np.asarray(movable, bool)
        self.visible = np.asarray(visible, bool)
        self.rest_normals = geometry.face_normals(self.rest, self.faces)
        n = len(self.rest)
        edges = geometry.unique_edges(self.faces)
        rows, cols = np.r_[edges[:, 0], edges[:, 1]], np.r_[edges[:, 1], edges[:, 0]]
        self.adjacency = sparse.csr_matrix((np.ones(len(rows)), (rows, cols)), (n, n))
        self.laplacian = (sparse.diags(np.asarray(self.adjacency.sum(axis=1)).ravel()) - self.adjacency).tocsr()
        self.mended = 0           # folds mended by the last call (for benches and tests)

    def folded(self, positions: np.ndarray) -> np.ndarray:
        """Indices of visible triangles turned more than 90 degrees from rest; ``positions`` (N, 3)."""
        normals = geometry.face_normals(positions, self.faces)
        flipped = np.einsum("ij,ij->i", normals, self.rest_normals) < 0.0
        return np.flatnonzero(flipped & self.visible)

    def _ring(self, mask: np.ndarray, rings: int) -> np.ndarray:
        for _ in range(rings):
            mask = mask | (np.asarray(self.adjacency @ mask.astype(np.float64)).ravel() > 0)
        return mask

    def mend(self, positions: np.ndarray, movable: np.ndarray | None = None,
             folds: np.ndarray | None = None) -> int:
        """Mend ``positions`` (N, 3) float64, in place (``movable``: this pose's movable nodes, default the
        mender's; ``folds``: :meth:`folded` of ``positions`` if the caller has it); returns how many visible
        folds are left (0 if all mended or none were there). Each connected piece of the region is kept only where it leaves fewer
        folds than the skin had there, so a fold that cannot be mended is left as the settle made it.
        Deterministic: the same positions give the same bytes."""
        folds = self.folded(positions) if folds is None else folds
        self.mended = 0
        if len(folds) == 0:
            return 0
        first = len(folds)
        movable = self.movable if movable is None else movable
        original = positions                 # read only until the end: every trial starts from it
        best, best_folds = positions.copy(), folds
        region = np.zeros(len(self.rest), bool)
        for round_ in range(ROUNDS):
            seed = np.zeros(len(self.rest), bool)
            seed[self.faces[best_folds].ravel()] = True
            grown = self._ring(region | seed, 1 if round_ == 0 else GROW) & movable
            if not grown.any() or np.array_equal(grown, region):
                break
            region = grown
            trial = original.copy()
            self._solve(trial, region)
            self._keep_better(best, best_folds, trial, self.folded(trial), region)
            best_folds = self.folded(best)
            if len(best_folds) == 0:
                break
        positions[...] = best
        self.mended = first - len(best_folds)
        return len(best_folds)

    def _keep_better(self, best, best_folds, trial, trial_folds, region) -> None:
        """Per connected piece of ``region``: ``trial``'s positions go into ``best`` where they leave fewer
        folds on the triangles touching that piece (pieces share no triangle: a triangle's corners are
        joined by edges)."""
        free = np.flatnonzero(region)
        sub = self.adjacency[free][:, free]
        count, label = connected_components(sub, directed=False)
        piece = np.full(len(self.rest), -1)
        piece[free] = label

        def per_piece(folds):
            owners = piece[self.faces[folds]].max(axis=1)         # -1: touches no free node
            return np.bincount(owners[owners >= 0], minlength=count)

        better = per_piece(trial_folds) < per_piece(best_folds)
        take = free[better[label]]
        best[take] = trial[take]

    def _solve(self, positions: np.ndarray, region: np.ndarray) -> None:
        """The harmonic displacement over ``region`` with every other node's displacement held."""
        free = np.flatnonzero(region)
        held = np.flatnonzero(~region)
        lap = self.laplacian
        lap_free = lap[free]
        # + REGULAR * I: a piece of skin wholly inside the region (no held node round it) keeps its mean
        # displacement instead of making the system singular; elsewhere the change is below 1e-6 of a move
        system = (lap_free[:, free] + REGULAR * sparse.identity(len(free))).tocsc()
        displacement = positions - self.rest
        rhs = REGULAR * displacement[free] - lap_free[:, held] @ displacement[held]
        positions[free] = self.rest[free] + splu(system).solve(rhs)
