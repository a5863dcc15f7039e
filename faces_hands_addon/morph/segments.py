# SPDX-License-Identifier: GPL-3.0-or-later
"""Segments (5.1.2, Table 5.1) and the smooth blend of a segment-restricted edit (3.2.2, [BA83]).

The face is a shallow hierarchy: ``face`` -> features (forehead, eyes, cheeks, ears, nose, mouth, chin, rest)
-> sub-segments (eyebrows, orbits, eyes; root, bridge, wings, base, tip; upper lip, lower lip, peripheral oral
region; tip, jaw). A leaf is a vertex mask; a parent is the union of its children; any combination may be
selected. For models on the MediaPipe topology the leaves come from ``presets/morph/segments.json``: every
vertex belongs to the leaf whose seed vertices are nearest over the surface (a geodesic Voronoi partition).

:class:`SegmentBlender` restricts an edit (a displacement ``d`` of every vertex) to a selection with a
multi-resolution blend in the spirit of Burt and Adelson's multiresolution spline [BA83], on the mesh: the
displacement is split into frequency bands by repeated neighbourhood averaging (``G_0 = d``,
``G_l = S^(2^(l-1)) G_(l-1)``), and each band is blended with a mask smoothed to the same scale
(``M_0 = m``, ``M_l = max(m, S^(2^(l-1)) M_(l-1))``): ``result = M_0 G_0 + sum_l (M_l - M_(l-1)) G_l``, the
telescoped form of ``sum_l M_l (G_l - G_(l+1)) + M_L G_L``. Low frequencies blend over a wide zone, high
frequencies over a narrow one. The masks are 1 on the whole selection, so the selected segments get the
edit in full (bit for bit: every ``M_l - M_(l-1)`` is exactly 0 there), and exactly 0 farther than
``2^L - 1`` edge rings outside it, where nothing changes.
"""
from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import dijkstra

from ..core.errors import UserError
from ..core.geometry import edge_length_graph, median_edge_length, unique_edges
from ..core.presets import NUMBER, PresetFormat, read_preset, register_format

__all__ = ["SEGMENTS_FORMAT", "ROOT", "load_segment_preset", "segment_masks", "hierarchy_order",
           "selection_mask", "SegmentBlender"]

ROOT = "face"
SEGMENTS_FORMAT = register_format(PresetFormat(
    "faces_hands.morph_segments", 1,
    shape={"hierarchy": {str: [str]}, "seeds": {str: [NUMBER]}, "blend_width_m": NUMBER, "colours": {str: [NUMBER]}},
    required=("hierarchy", "seeds")))


def load_segment_preset() -> tuple[dict, str]:
    return read_preset("morph/segments.json", SEGMENTS_FORMAT.name)


def hierarchy_order(parents: dict[str, str]) -> list[str]:
    """Segment names depth first from the root (the order the panel lists them in)."""
    children: dict[str, list[str]] = {}
    for child, parent in parents.items():
        children.setdefault(parent, []).append(child)
    out: list[str] = []

    def visit(name: str) -> None:
        out.append(name)
        for child in children.get(name, []):
            visit(child)

    visit(ROOT)
    return out


def segment_masks(vertices: np.ndarray, triangles: np.ndarray, preset: dict | None = None,
                  source: str = "segments preset") -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """Leaf masks by geodesic Voronoi regions of the preset's seed vertices, parents as unions
    (Table 5.1). Returns (name -> bool mask, child -> parent)."""
    if preset is None:
        preset, source = load_segment_preset()
    n = len(vertices)
    hierarchy = preset["hierarchy"]
    parents = {child: parent for parent, kids in hierarchy.items() for child in kids}
    leaves = [name for name in parents if name not in hierarchy]
    seeded = [name for name in leaves if preset["seeds"].get(name)]
    seeds, owner = [], []
    for index, name in enumerate(seeded):
        ids = [int(i) for i in preset["seeds"][name]]
        if min(ids) < 0 or max(ids) >= n:
            raise UserError(f"{source}: seeds of {name!r} index vertices outside 0..{n - 1}")
        seeds += ids
        owner += [index] * len(ids)
    if not seeds:
        raise UserError(f"{source}: no segment has seed vertices")
    graph = edge_length_graph(np.asarray(vertices, np.float64), unique_edges(triangles))
    _, _, sources = dijkstra(graph, directed=False, indices=np.asarray(seeds), min_only=True,
                             return_predecessors=True)
    seed_owner = dict(zip(seeds, owner))
    label = np.array([seed_owner.get(int(s), -1) for s in sources])
    masks = {name: label == i for i, name in enumerate(seeded)}
    for name in leaves:
        masks.setdefault(name, np.zeros(n, bool))         # e.g. ears: the template has none
    for name in reversed(hierarchy_order(parents)):
        if name in hierarchy:
            union = np.zeros(n, bool)
            for child in hierarchy[name]:
                union |= masks[child]
            masks[name] = union
    masks[ROOT] = np.ones(n, bool)
    return masks, parents


def selection_mask(segments: dict[str, np.ndarray], names, vertex_count: int) -> np.ndarray | None:
    """The union of the named segments (None: the whole face, i.e. no restriction)."""
    names = [n for n in (names or ()) if n]
    if not names or ROOT in names:
        return None
    mask = np.zeros(vertex_count, bool)
    for name in names:
        if name not in segments:
            raise UserError(f"unknown segment {name!r}; known: {', '.join(segments)}")
        mask |= segments[name]
    return mask


class SegmentBlender:
    """Blend segment-restricted edits smoothly across segment borders (module docstring)."""

    def __init__(self, vertices: np.ndarray, triangles: np.ndarray, width: float = 0.02, levels: int | None = None):
        n = len(vertices)
        edges = unique_edges(triangles)
        rows = np.r_[edges[:, 0], edges[:, 1], np.arange(n)]
        cols = np.r_[edges[:, 1], edges[:, 0], np.arange(n)]
        self.adjacency = sparse.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
        self.degree = np.asarray(self.adjacency.sum(axis=1)).ravel()
        if levels is None:
            spacing = median_edge_length(vertices, edges)
            rings = max(width / max(spacing, 1e-12), 1.0)
            levels = int(np.clip(np.ceil(np.log2(rings + 1.0)), 1, 6))
        self.levels = levels
        self.rings = 2 ** levels - 1

    def smooth(self, values: np.ndarray, times: int) -> np.ndarray:
        """``times`` rounds of averaging over each vertex and its neighbours (S); constant fields stay
        exactly constant (a sum of equal numbers divided by their count)."""
        out = values
        for _ in range(times):
            out = (self.adjacency @ out) / (self.degree if out.ndim == 1 else self.degree[:, None])
        return out

    def weights(self, mask: np.ndarray) -> list[np.ndarray]:
        """The band masks M_0..M_L of a selection (1 on it, 0 beyond ``rings`` rings)."""
        base = np.asarray(mask, np.float64)
        out = [base]
        for level in range(1, self.levels + 1):
            out.append(np.maximum(base, self.smooth(out[-1], 2 ** (level - 1))))
        return out

    def blend(self, displacement: np.ndarray, mask: np.ndarray | None) -> np.ndarray:
        """The displacement (n, 3) restricted to ``mask`` and blended across its border."""
        if mask is None:
            return displacement
        masks = self.weights(mask)
        band = displacement
        out = masks[0][:, None] * displacement
        for level in range(1, self.levels + 1):
            band = self.smooth(band, 2 ** (level - 1))
            out = out + (masks[level] - masks[level - 1])[:, None] * band
        return out

    def zone(self, mask: np.ndarray) -> np.ndarray:
        """Vertices a restricted edit may change: the selection and its ``rings``-ring neighbourhood."""
        reach = np.asarray(mask, np.float64)
        for _ in range(self.rings):
            reach = self.adjacency @ reach
        return reach > 0
