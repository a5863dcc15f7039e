# SPDX-License-Identifier: GPL-3.0-or-later
"""The template skin (thesis 3.1.2 "Skin"): the MediaPipe canonical face made animatable.

Stage 1 of the template build ("place landmarks"): the canonical face is one closed disc in which
triangles cover the mouth opening and both eyes (see presets/SOURCES.md), so lips could
never part and lids never open. We remove those triangles, give the lips an inner surface that runs back
into a mouth cavity ("mouth bag", closed at the throat) and give each lid margin a little thickness
towards the eyeball, then refine: long edges are split once (the forehead triangles of the canonical mesh
are ~8x larger than the lid triangles) and Loop subdivision smooths the surface. Everything is kept as a
sparse matrix from the 468 canonical vertices (+ the extruded ones) to the nodes, so the same skin can be
rebuilt from any warped copy of the canonical face, and every node knows which part of the face it
belongs to.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import sparse

from ..core.errors import UserError
from ..core import geometry, refine

__all__ = ["SkinMesh", "build_skin", "eyeball_sphere", "close_rest_lips", "hidden_nodes", "RESOLUTIONS"]

#: resolution name -> (edge length above which base edges are split (m), Loop subdivision levels)
RESOLUTIONS = {"coarse": (0.020, 0), "default": (0.020, 1), "10k": (0.020, 2)}

EYEBALL_RADIUS = 0.012          # m; adult eyeball diameter ~24 mm
LID_GAP = 0.0008                # lid margin rests this far outside the eyeball surface (tear film, lashes)
LID_THICKNESS = 0.0022          # lid margin thickness towards the eyeball
LIP_OVERLAP = 0.0008            # m the canonical lips are closed past contact: Loop smoothing parts them by ~this
UPPER_LIP_SHARE = 0.25          # of the closure the upper lip makes (the lower lip rises the rest of the way)

# node groups (bit flags); "surface" = the visible outer face
GROUPS = {"surface": 1, "lip_inner": 2, "mouth_bag": 4, "lid_back": 8, "upper_lip": 16, "lower_lip": 32,
          "lid_upper_L": 64, "lid_lower_L": 128, "lid_upper_R": 256, "lid_lower_R": 512, "boundary": 1024}


@dataclass
class SkinMesh:
    """Skin nodes and triangles plus the bookkeeping the rest of the template needs.

    ``basis`` maps base vertices (468 canonical + extruded) to nodes: ``vertices = basis @ base``.
    ``canonical_node[i]`` is the node that canonical vertex ``i`` became (its index is kept).
    ``groups`` holds :data:`GROUPS` bit flags per node; ``contours`` named node polylines
    (lip contours inner/outer, eye margins) in the final mesh.
    """
    vertices: np.ndarray
    faces: np.ndarray
    basis: sparse.csr_matrix
    base_vertices: np.ndarray
    base_faces: np.ndarray
    groups: np.ndarray
    contours: dict[str, np.ndarray] = field(default_factory=dict)
    eye_centres: dict[str, np.ndarray] = field(default_factory=dict)
    mouth_centre: np.ndarray | None = None

    def group(self, name: str) -> np.ndarray:
        return (self.groups & GROUPS[name]) != 0

    @property
    def node_count(self) -> int:
        return int(self.vertices.shape[0])


def hidden_nodes(skin) -> np.ndarray:
    """(N,) bool: nodes a camera does not see (inner lips, mouth bag, lid backs); ``skin``: anything with
    ``group(name)`` (:class:`SkinMesh`, the template's skin record). A triangle with none of them is outer skin."""
    return skin.group("lip_inner") | skin.group("mouth_bag") | skin.group("lid_back")


def eyeball_sphere(margin_points: np.ndarray, radius: float = EYEBALL_RADIUS, gap: float = LID_GAP) -> np.ndarray:
    """Centre of an eyeball of ``radius`` behind an eye contour: the point straight behind the contour's
    centroid (+Y is into the head) whose RMS distance to the contour equals ``radius + gap``."""
    centroid = margin_points.mean(axis=0)
    target = radius + gap
    low, high = -0.02, 0.03
    for _ in range(80):
        middle = 0.5 * (low + high)
        centre = centroid + np.array([0.0, middle, 0.0])
        rms = np.sqrt(np.mean(np.sum((margin_points - centre) ** 2, axis=1)))
        # moving back increases the distance
        if rms < target:
            low = middle
        else:
            high = middle
    return centroid + np.array([0.0, 0.5 * (low + high), 0.0])


def _smoothstep(t: np.ndarray) -> np.ndarray:
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def close_rest_lips(vertices: np.ndarray, contours: dict[str, np.ndarray], upper_share: float = UPPER_LIP_SHARE,
                    overlap: float = LIP_OVERLAP) -> np.ndarray:
    """The canonical face with its lips closed (a relaxed closed mouth: the MediaPipe canonical face's lips
    are ~5.5 mm apart; a relaxed neutral keeps them together). Over the mouth's width each vertex above the lip
    line moves down by ``upper_share`` of the inner-lip gap at its x, each vertex below it up by the rest,
    fully within 3 / 4 mm of the inner lip contour and fading out 16 mm above / 26 mm below it (the upper lip
    and philtrum, the lower lip and chin soft tissue stretch); the two inner contours also meet in depth
    (the lower one lies ~2 mm further forward), fading out within 4 mm. ``overlap`` closes past contact by
    the amount the skin's Loop smoothing opens the lips again. Mouth corners do not move."""
    v = np.asarray(vertices, np.float64).copy()
    up, low = np.asarray(contours["lips_inner_upper"]), np.asarray(contours["lips_inner_lower"])
    up, low = up[np.argsort(v[up, 0], kind="stable")], low[np.argsort(v[low, 0], kind="stable")]
    x = v[:, 0]
    centre_x, half = 0.5 * (v[up, 0].max() + v[up, 0].min()), 0.5 * (v[up, 0].max() - v[up, 0].min())
    inside = np.abs(x - centre_x) < half
    z_up, z_low = np.interp(x, v[up, 0], v[up, 2]), np.interp(x, v[low, 0], v[low, 2])
    y_up, y_low = np.interp(x, v[up, 0], v[up, 1]), np.interp(x, v[low, 0], v[low, 1])
    profile = np.sqrt(np.clip(1.0 - ((x - centre_x) / half) ** 2, 0.0, 1.0))
    close = np.where(inside, z_up - z_low + overlap * profile, 0.0)
    ahead = np.where(inside, y_low - y_up, 0.0)          # < 0: the lower lip lies in front of the upper one
    above = v[:, 2] >= 0.5 * (z_up + z_low)
    d_up, d_low = np.maximum(v[:, 2] - z_up, 0.0), np.maximum(z_low - v[:, 2], 0.0)
    w_up = 1.0 - _smoothstep((d_up - 0.003) / 0.013)
    w_low = 1.0 - _smoothstep((d_low - 0.004) / 0.022)
    v[:, 2] += np.where(above, -upper_share * close * w_up, (1.0 - upper_share) * close * w_low)
    v[:, 1] += 0.5 * ahead * np.where(above, 1.0 - _smoothstep(d_up / 0.004), -(1.0 - _smoothstep(d_low / 0.004)))
    return v


def _strip(loop_a: np.ndarray, loop_b: np.ndarray, points: list, closed: bool = True) -> list[list[int]]:
    """Triangles joining ring ``a`` to the parallel ring ``b`` behind it (a's boundary edges run a_i -> a_i+1
    in the existing faces, so the strip uses them reversed). Each quad is cut along its shorter diagonal,
    a choice that mirrors with the geometry (the template stays left/right symmetric)."""
    faces = []
    count = len(loop_a)
    for i in range(count if closed else count - 1):
        j = (i + 1) % count
        a_i, a_j, b_i, b_j = (int(loop_a[i]), int(loop_a[j]), int(loop_b[i]), int(loop_b[j]))
        if np.linalg.norm(points[a_j] - points[b_i]) <= np.linalg.norm(points[a_i] - points[b_j]):
            faces += [[a_j, a_i, b_i], [a_j, b_i, b_j]]
        else:
            faces += [[a_j, a_i, b_j], [a_i, b_i, b_j]]
    return faces


def _open_holes(v: np.ndarray, f: np.ndarray, contours: dict[str, np.ndarray]):
    """The canonical faces without the triangles that cover the mouth and the eyes, and the boundary loops
    this leaves (mouth, eye_L, eye_R, outer)."""
    lips_inner = np.concatenate([contours["lips_inner_upper"], contours["lips_inner_lower"][1:-1]])
    covered = [set(lips_inner.tolist()), set(contours["eye_L"].tolist()), set(contours["eye_R"].tolist())]
    keep = np.array([not any(set(face.tolist()) <= c for c in covered) for face in f])
    faces = [list(map(int, face)) for face in f[keep]]
    by_member = {}
    for loop in refine.boundary_loops(np.array(faces)):
        members = set(loop.tolist())
        if 13 in members:
            by_member["mouth"] = loop
        elif 263 in members:
            by_member["eye_L"] = loop
        elif 33 in members:
            by_member["eye_R"] = loop
        else:
            by_member.setdefault("outer", loop)
    if set(by_member) != {"mouth", "eye_L", "eye_R", "outer"}:
        raise UserError("canonical face: could not find the mouth and eye holes; check the assets")
    return faces, by_member


class _BaseMesh:
    """The base mesh being grown: vertices, their group flags and the triangles."""

    def __init__(self, vertices: np.ndarray, faces: list[list[int]]):
        self.vertices = [p for p in vertices]
        self.groups = [GROUPS["surface"]] * len(vertices)
        self.faces = faces

    def add(self, point, flag) -> int:
        self.vertices.append(np.asarray(point, np.float64))
        self.groups.append(flag)
        return len(self.vertices) - 1


def _add_mouth(mesh: _BaseMesh, v: np.ndarray, mouth: np.ndarray, contours: dict[str, np.ndarray]) -> np.ndarray:
    """Lips: the inner surface, then the mouth bag, closed at the throat. Returns the mouth centre."""
    upper = set(contours["lips_inner_upper"].tolist())
    centre = 0.5 * (v[13] + v[14])
    half_width = 0.5 * abs(v[308, 0] - v[78, 0]) + 1e-9
    is_upper = np.array([i in upper and i not in (78, 308) for i in mouth])
    is_lower = np.array([i not in upper for i in mouth])
    sign = np.where(is_upper, 1.0, np.where(is_lower, -1.0, 0.0))
    ring_specs = [  # (depth behind the lip contour, vertical reach, lateral scale, flags)
        (0.004, 0.0020, 1.00, GROUPS["lip_inner"]),      # inner surface of the lips
        (0.0065, 0.0160, 1.15, GROUPS["mouth_bag"]),     # vestibule in front of the teeth, at the gums
        (0.030, 0.0180, 1.35, GROUPS["mouth_bag"]),      # cheeks, outside the molars
        (0.052, 0.0160, 1.20, GROUPS["mouth_bag"]),      # behind the last molars
    ]
    previous = mouth
    for depth, reach, lateral, flag in ring_specs:
        ring = []
        for k, index in enumerate(mouth):
            p = v[index]
            x = centre[0] + (p[0] - centre[0]) * lateral
            profile = np.sqrt(max(0.0, 1.0 - ((p[0] - centre[0]) / (half_width * 1.05)) ** 2))
            if flag == GROUPS["lip_inner"]:
                z = p[2] + sign[k] * reach
            else:
                z = centre[2] + sign[k] * reach * (0.25 + 0.75 * profile)
            extra = GROUPS["upper_lip"] if sign[k] > 0 else GROUPS["lower_lip"] if sign[k] < 0 else 0
            ring.append(mesh.add([x, p[1] + depth, z], flag | extra))
        mesh.faces += _strip(previous, np.array(ring), mesh.vertices)
        previous = np.array(ring)
    cap = mesh.add(centre + np.array([0.0, 0.064, 0.0]), GROUPS["mouth_bag"])
    for i in range(len(previous)):
        j = (i + 1) % len(previous)
        mesh.faces.append([int(previous[j]), int(previous[i]), cap])
    return centre


def _add_lid_margins(mesh: _BaseMesh, v: np.ndarray, loops: dict, contours: dict[str, np.ndarray]) -> dict:
    """Eyes: a lid margin with thickness towards the eyeball (the ring's far side stays open: the eyeball
    fills it). Returns the eyeball centres."""
    eye_centres = {}
    for side in ("L", "R"):
        loop = loops[f"eye_{side}"]
        centre_eye = eyeball_sphere(v[contours[f"eye_{side}"]])
        eye_centres[side] = centre_eye
        ring = []
        upper_set = set(contours[f"eye_{side}_upper"].tolist())
        for index in loop:
            p = v[index]
            inward = centre_eye - p
            inward /= np.linalg.norm(inward)
            lid = GROUPS[f"lid_upper_{side}"] if index in upper_set else GROUPS[f"lid_lower_{side}"]
            ring.append(mesh.add(p + inward * LID_THICKNESS, GROUPS["lid_back"] | lid))
        mesh.faces += _strip(loop, np.array(ring), mesh.vertices, closed=True)
    return eye_centres


def _refined(base_vertices: np.ndarray, base_faces: np.ndarray, base_groups: np.ndarray, resolution: str):
    """Split long edges once, then Loop subdivision; the refinement as a sparse basis from the base mesh."""
    max_edge, levels = RESOLUTIONS[resolution]
    basis = sparse.identity(len(base_vertices), format="csr")
    current_faces, current_groups = base_faces, base_groups
    for step in range(1 + levels):
        if step == 0:
            matrix, current_faces = refine.split_long_edges(basis @ base_vertices, current_faces, max_edge)
        else:
            matrix, current_faces = refine.loop_subdivision(basis.shape[0], current_faces)
        current_groups = _propagate_groups(matrix, current_groups)
        basis = (matrix @ basis).tocsr()
    basis.eliminate_zeros()
    return basis, current_faces, current_groups


def build_skin(canonical_vertices: np.ndarray, canonical_faces: np.ndarray, contours: dict[str, np.ndarray],
               resolution: str = "default") -> SkinMesh:
    """Stage 1 of the template: the animatable skin from the canonical face (see the module docstring)."""
    if resolution not in RESOLUTIONS:
        raise UserError(f"unknown skin resolution {resolution!r}; use one of {sorted(RESOLUTIONS)}")
    v = np.asarray(canonical_vertices, np.float64)
    faces, loops = _open_holes(v, np.asarray(canonical_faces, np.int64), contours)
    mesh = _BaseMesh(v, faces)
    centre = _add_mouth(mesh, v, loops["mouth"], contours)
    eye_centres = _add_lid_margins(mesh, v, loops, contours)
    base_vertices = np.array(mesh.vertices)
    base_faces = np.array(mesh.faces, np.int64)
    base_groups = np.array(mesh.groups, np.int64)
    for side in ("L", "R"):
        for part in ("upper", "lower"):
            ids = contours[f"eye_{side}_{part}"]
            base_groups[ids] |= GROUPS[f"lid_{part}_{side}"]
    base_groups[contours["lips_inner_upper"]] |= GROUPS["upper_lip"]
    base_groups[contours["lips_inner_lower"]] |= GROUPS["lower_lip"]
    base_groups[loops["outer"]] |= GROUPS["boundary"]
    basis, current_faces, current_groups = _refined(base_vertices, base_faces, base_groups, resolution)
    skin = SkinMesh(vertices=basis @ base_vertices, faces=current_faces, basis=basis, base_vertices=base_vertices,
                    base_faces=base_faces, groups=current_groups, eye_centres=eye_centres, mouth_centre=centre)
    skin.contours = _trace_contours(skin, contours)
    return skin


def _propagate_groups(matrix: sparse.csr_matrix, groups: np.ndarray) -> np.ndarray:
    """Group flags of refined nodes: kept for old vertices; an edge node gets the flags its two parent
    vertices share (found from the two largest weights of its row)."""
    matrix = matrix.tocsr()
    out = np.zeros(matrix.shape[0], np.int64)
    old = matrix.shape[1]
    out[:old] = groups
    for row in range(old, matrix.shape[0]):
        start, end = matrix.indptr[row], matrix.indptr[row + 1]
        cols, weights = matrix.indices[start:end], matrix.data[start:end]
        order = np.argsort(-weights, kind="stable")[:2]
        out[row] = groups[cols[order[0]]] & groups[cols[order[1]]]
    return out


def _trace_contours(skin: SkinMesh, contours: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Node polylines of the canonical contours in the refined mesh: each canonical segment a-b becomes the
    shortest mesh path between the two kept nodes (subdivision keeps canonical indices)."""
    from scipy.sparse.csgraph import dijkstra

    graph = geometry.edge_length_graph(skin.vertices, geometry.unique_edges(skin.faces))
    out = {}
    for name in ("lips_inner_upper", "lips_inner_lower", "lips_outer_upper", "lips_outer_lower",
                 "eye_L_upper", "eye_L_lower", "eye_R_upper", "eye_R_lower", "eyebrow_L_upper",
                 "eyebrow_R_upper", "face_oval"):
        ids = [int(i) for i in contours[name]]
        if name == "face_oval":
            ids = ids + ids[:1]
        path = [ids[0]]
        for a, b in zip(ids[:-1], ids[1:]):
            _, pred = dijkstra(graph, indices=a, return_predecessors=True, limit=0.05)
            segment, node = [], b
            while node != a and node >= 0:
                segment.append(node)
                node = pred[node]
            path += segment[::-1]
        out[name] = np.array(path, np.int64)
    return out
