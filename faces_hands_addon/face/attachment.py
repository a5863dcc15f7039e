# SPDX-License-Identifier: GPL-3.0-or-later
"""How the skin is attached to what lies under it (thesis 3.1.2 "Mass Spring Network", Fig. 3.4: "Springs
connect the skin surface to skull and muscles; attachments are mirrored outwards").

Every skin node has one attachment pair: a zero-rest-length spring to its *attachment target* and a mirrored
spring pulling outwards, both anchored ``anchor_offset`` away from the target (the node -> bone vector at
rest), so the pair holds the node at its target and the outward twin keeps it off the bone. The target is
the node's rest position carried by its bone (the jaw carries the lower face by ``jaw_weight``) plus the
pull of the muscles the node is attached to ("attaching the skin nodes in the muscle's zone of influence to
the closest points on the muscle"), spread over the skin layer by a few smoothing passes.

:class:`AttachmentMap` holds all of it per node; :func:`attach_to_bones` and :func:`attach_to_muscles` build
it for a template head, :meth:`AttachmentMap.transferred` carries it onto an artist's mesh (:mod:`.fitted`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import dijkstra

from ..core import geometry
from ..physics import anchor_kernel, kernel
from . import attachment_kernel
from .skin import SkinMesh

__all__ = ["AttachmentMap", "BoneSurface", "signed_bone_distance", "attach_to_bones", "attach_to_muscles", "smoothing_operator", "SKULL", "JAW",
           "MAX_MUSCLES_PER_NODE", "MOUTH_REACH"]

SKULL, JAW = 0, 1
MAX_MUSCLES_PER_NODE = 3
MOUTH_REACH = 0.022          # m over the skin from the inner lip contours: where the lips decide the bone
LIP_JAW_FALLOFF = 0.010      # m over the skin from the lip margins: where the lips' jaw weights meet the face's
LIP_CORNER_CARRY = 0.35       # of the jaw's motion that carries the mouth corners
LIP_OPENING_POWER = 1.0      # shape of the opening along the lips (0.5: an ellipse; larger: pointed corners)


@dataclass
class AttachmentMap:
    """Fig. 3.4 per skin node (module docstring). ``muscle_matrix`` (N, P) maps muscle control-point
    displacements to attachment displacements (weight x barycentric coordinate of the closest point on each
    attached muscle); ``smoothing`` (N, N) is one pass of the skin layer's spreading, applied
    ``smoothing_passes`` times (0 when ``muscle_matrix`` already includes it)."""
    node_bone: np.ndarray            # (N,) SKULL or JAW
    jaw_weight: np.ndarray           # (N,) how far the jaw carries the node
    bone_point: np.ndarray           # (N, 3) closest point on the node's bone
    bone_normal: np.ndarray          # (N, 3) the bone's outward normal there
    bone_depth: np.ndarray           # (N,) signed skin thickness over the bone
    muscle_matrix: sparse.csr_matrix
    smoothing: sparse.csr_matrix | None = None
    smoothing_passes: int = 0
    _spread: sparse.csr_matrix | None = field(default=None, init=False, repr=False, compare=False)

    def muscle_displacement(self, point_displacement: np.ndarray) -> np.ndarray:
        """Attachment displacements (N, 3) for muscle control-point displacements (P, 3): the sum of weight x
        closest muscle point, spread smoothly by the skin layer's passes -- one product with the spread
        matrix, folded once (:meth:`spread_muscle_matrix`), so a frame costs the same however many passes
        the resolution needs (10 at the 10k head: 4.7-5.4 ms a frame pass by pass, 1.4-2.3 ms folded)."""
        if self._spread is None:
            self._spread = self.spread_muscle_matrix()
        return self._spread @ point_displacement

    def jaw_frame_correction(self, muscle_rest: np.ndarray, muscle_carry: np.ndarray, jaw: np.ndarray) -> np.ndarray:
        """Muscle displacements are measured from each control point's rest position carried by the jaw as
        far as *its* carry (``muscle_carry``, :attr:`.muscles.MuscleSystem.jaw_carry`), but the node adds them to its own rest position
        carried by *its* jaw weight. Where the two differ (the mouth corners, carried half way) the node would
        count the jaw twice or not at all; this term (N, 3) makes the node's muscle pull relative to the
        muscle points carried with the node's own jaw weight, so a node attached to a muscle goes where the
        muscle goes (Fig. 3.4)."""
        moved = muscle_rest @ jaw[:3, :3].T + jaw[:3, 3] - muscle_rest
        if not np.any(moved):
            return np.zeros((len(self.jaw_weight), 3))
        own = self.muscle_displacement(moved * muscle_carry[:, None])
        return own - self.jaw_weight[:, None] * self.muscle_displacement(moved)

    def add_muscle_pull(self, displacement: np.ndarray, muscle_rest: np.ndarray, muscle_carry: np.ndarray,
                        jaw: np.ndarray, target: np.ndarray) -> None:
        """``target`` (N, 3) += :meth:`muscle_displacement` of the muscle points' ``displacement`` +
        :meth:`jaw_frame_correction` (in place): the pull of the muscles the nodes are attached to (Fig. 3.4).
        Wherever the kernel is usable, one compiled pass (:mod:`.attachment_kernel`)."""
        if (pull := kernel.compiled(attachment_kernel.add_muscle_pull)) is not None:
            spread, tables = self.jaw_pull_tables(muscle_rest, muscle_carry)
            pull(spread.indptr, spread.indices, spread.data, np.ascontiguousarray(displacement, np.float64),
                 *tables, np.ascontiguousarray(jaw[:3, :3], np.float64), np.ascontiguousarray(jaw[:3, 3], np.float64),
                 self.jaw_weight.astype(np.float64, copy=False), target)
            return
        target += self.muscle_displacement(displacement)
        target += self.jaw_frame_correction(muscle_rest, muscle_carry, jaw)

    def jaw_pull_tables(self, muscle_rest: np.ndarray, muscle_carry: np.ndarray):
        """The spread matrix S (CSR) and, taken once per muscle layout, S r, S 1, S (c r), S c for the muscle
        points' rest positions r and jaw carry c: :meth:`jaw_frame_correction` is linear in the jaw pose, so
        the compiled pull (:mod:`.attachment_kernel`) needs no product with S for it per frame."""
        if self._spread is None:
            self._spread = self.spread_muscle_matrix()
        cached = getattr(self, "_jaw_tables", None)
        if cached is None or cached[0] is not muscle_rest or cached[1] is not muscle_carry:
            spread, carry = self._spread, np.asarray(muscle_carry, np.float64)
            rest = np.asarray(muscle_rest, np.float64)
            tables = tuple(np.ascontiguousarray(spread @ value, np.float64)
                           for value in (rest, np.ones(len(rest)), carry[:, None] * rest, carry))
            cached = self._jaw_tables = (muscle_rest, muscle_carry, tables)
        return self._spread, cached[2]

    def spread_muscle_matrix(self) -> sparse.csr_matrix:
        """``muscle_matrix`` with the smoothing passes folded in (N, P)."""
        spread = self.muscle_matrix
        for _ in range(self.smoothing_passes):
            spread = self.smoothing @ spread
        return sparse.csr_matrix(spread)

    def carried(self, rest: np.ndarray, jaw: np.ndarray) -> np.ndarray:
        """Rest positions carried by the bones: the jaw pose ``jaw`` (4x4) moves each node by its weight.
        Wherever the kernel is usable, one compiled pass (:func:`.attachment_kernel.carry_rest`)."""
        if (carry := kernel.compiled(attachment_kernel.carry_rest)) is not None:
            out = np.empty((len(rest), 3))
            carry(np.ascontiguousarray(rest, np.float64), np.ascontiguousarray(jaw[:3, :3], np.float64),
                  np.ascontiguousarray(jaw[:3, 3], np.float64), self.jaw_weight.astype(np.float64, copy=False), out)
            return out
        moved = rest @ jaw[:3, :3].T + jaw[:3, 3]
        return rest + self.jaw_weight[:, None] * (moved - rest)

    def anchor_offsets(self, nodes: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """The node -> bone vector of each attachment pair at rest (N, 3); nodes with no bone underneath
        (lids, the mouth bag) get a short inward offset so their mirrored spring still has a direction."""
        offset = self.bone_point - nodes
        depth = np.linalg.norm(offset, axis=1)
        inward = -normals * 0.004
        return np.where((depth > 1e-4)[:, None] & (self.bone_depth > 0)[:, None], offset, inward)

    def posed_offsets(self, offsets: np.ndarray, jaw: np.ndarray) -> np.ndarray:
        """Anchor offsets turned with the jaw for the nodes it carries (more than half). Wherever the kernel
        is usable, one compiled pass (:func:`.attachment_kernel.turn_offsets`)."""
        if (turn := kernel.compiled(attachment_kernel.turn_offsets)) is not None:
            out = np.empty((len(offsets), 3))
            turn(np.ascontiguousarray(offsets, np.float64), np.ascontiguousarray(jaw[:3, :3], np.float64),
                 self.jaw_weight.astype(np.float64, copy=False), out)
            return out
        out = offsets.copy()
        on_jaw = self.jaw_weight > 0.5
        out[on_jaw] = out[on_jaw] @ jaw[:3, :3].T
        return out

    def transferred(self, interpolation: sparse.csr_matrix, weight: np.ndarray, node_bone: np.ndarray,
                    jaw_weight: np.ndarray, bone_contact: tuple[np.ndarray, np.ndarray, np.ndarray]
                    ) -> "AttachmentMap":
        """The map on another mesh whose nodes lie on this template's skin (``interpolation`` (n, N):
        barycentric rows): the spread muscle field interpolated and faded by ``weight`` (0 off the face);
        the bone attachment as decided on that mesh (``bone_contact`` = point, normal, depth)."""
        muscles = (sparse.diags(weight) @ interpolation @ self.spread_muscle_matrix()).tocsr()
        muscles.eliminate_zeros()
        point, normal, depth = bone_contact
        return AttachmentMap(node_bone, jaw_weight, point, normal, depth, muscles, None, 0)


class BoneSurface:
    """A bone mesh prepared for closest-point queries with smoothly interpolated outward normals."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray) -> None:
        self.vertices, self.faces = vertices, faces
        self.normals = geometry.vertex_normals(vertices, faces)
        self._tree = None
        self._packed = None              # float64 / int64 copies for the compiled candidate pass

    def closest(self, points: np.ndarray):
        """Closest points (K, 3), unit normals there (K, 3) and distances (K,). The centroid tree is built
        on the first query and kept (the skin guard asks every frame)."""
        if self._tree is None:
            self._tree = geometry.centroid_tree(self.vertices, self.faces)
        compiled = kernel.compiled(anchor_kernel.closest_on_candidates, anchor_kernel._ratio)
        if compiled is None:
            point, face, bary, dist = geometry.closest_points(self.vertices, self.faces, points, tree=self._tree)
        else:                                      # the same answer, the candidates in one compiled pass
            point, face, bary, dist = self._closest_compiled(compiled, np.asarray(points, np.float64))
        normal = np.einsum("ij,ijk->ik", bary, self.normals[self.faces[face]])
        return point, normal / np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12), dist

    def _closest_compiled(self, compiled, points: np.ndarray):
        """:func:`..core.geometry.closest_points` (same candidates from the same tree, same arithmetic) with
        the candidate triangles evaluated by :func:`..physics.anchor_kernel.closest_on_candidates`."""
        if self._packed is None:
            self._packed = (np.ascontiguousarray(self.vertices, np.float64), np.ascontiguousarray(self.faces, np.int64))
        vertices, faces = self._packed
        k = min(geometry.CLOSEST_CANDIDATES, len(faces))
        _, candidates = self._tree.query(points, k=k)
        candidates = np.ascontiguousarray(np.asarray(candidates, np.int64).reshape(len(points), k))
        point, bary = np.empty((len(points), 3)), np.empty((len(points), 3))
        face, dist = np.empty(len(points), np.int64), np.empty(len(points))
        compiled(vertices, faces, np.ascontiguousarray(points), candidates, point, face, bary, dist)
        return point, face, bary, dist


def signed_bone_distance(nodes: np.ndarray, verts: np.ndarray, faces: np.ndarray):
    """Closest point, outward normal, signed distance (negative inside) and distance of ``nodes`` over the
    bone mesh (``verts``, ``faces``)."""
    point, n, dist = BoneSurface(verts, faces).closest(nodes)
    outside = np.einsum("ij,ij->i", nodes - point, n) >= 0
    return point, n, np.where(outside, dist, -dist), dist


def _smooth_on_mesh(values: np.ndarray, faces: np.ndarray, iterations: int) -> np.ndarray:
    edges = geometry.unique_edges(faces)
    n = len(values)
    degree = np.bincount(edges.ravel(), minlength=n).astype(float)
    out = values.astype(float).copy()
    for _ in range(iterations):
        total = np.bincount(edges[:, 0], out[edges[:, 1]], n) + np.bincount(edges[:, 1], out[edges[:, 0]], n)
        out = 0.5 * out + 0.5 * total / np.maximum(degree, 1)
    return out


def _mouth_bone_override(skin: SkinMesh, node_bone: np.ndarray, reach: float = MOUTH_REACH):
    """Around the mouth the nearest bone is ambiguous (the upper teeth lie right behind the lower lip), so
    there a node belongs to the jaw if it is closer, over the skin, to the lower lip's inner contour than to
    the upper one (geodesic distances along the mesh edges). Also returns the mouth region and the distance
    over the skin to the nearest lip margin."""
    graph = geometry.edge_length_graph(skin.vertices, geometry.unique_edges(skin.faces))
    upper = skin.contours["lips_inner_upper"][1:-1]
    lower = skin.contours["lips_inner_lower"][1:-1]
    d_up = dijkstra(graph, indices=upper, min_only=True, limit=2 * reach)
    d_low = dijkstra(graph, indices=lower, min_only=True, limit=2 * reach)
    out = node_bone.copy()
    near = np.minimum(d_up, d_low) < reach
    out[near] = np.where(d_low[near] < d_up[near], JAW, SKULL)
    out[skin.group("upper_lip")] = SKULL
    out[skin.group("lower_lip")] = JAW
    return out, near, np.minimum(d_up, d_low), (d_up, d_low)


def lip_jaw_weight(x: np.ndarray, lower: np.ndarray, distance: np.ndarray, far: np.ndarray,
                   corners: tuple[float, float], falloff: float = LIP_JAW_FALLOFF) -> np.ndarray:
    """How far the jaw carries points of the lips (skin nodes and the orbicularis oris): at the lip margins
    the lower lip goes with the jaw and the upper lip stays, except towards the mouth corners, where both
    lips go half way with it (the commissure moves about half as far as the lower lip when the mouth
    opens), so the opening is a lens with closed corners instead of a box whose corners are torn down with
    the jaw. At the margin (``distance`` 0) the lower lip carries ``(1 + e) / 2``, the upper lip
    ``(1 - e) / 2`` of the jaw's motion, ``e = (1 - (x / half width)^2)^LIP_OPENING_POWER`` (``corners``: the
    x of the two mouth corners); away from the margin the weight fades into ``far`` (the bone weight the
    point would have otherwise) over ``falloff`` metres."""
    lo, hi = corners
    e = np.clip(1.0 - ((x - 0.5 * (lo + hi)) / (0.5 * (hi - lo))) ** 2, 0.0, 1.0) ** LIP_OPENING_POWER
    margin = np.where(lower, LIP_CORNER_CARRY + (1.0 - LIP_CORNER_CARRY) * e, LIP_CORNER_CARRY * (1.0 - e))
    t = np.clip(distance / falloff, 0.0, 1.0)
    fade = t * t * (3.0 - 2.0 * t)
    return np.clip((1.0 - fade) * margin + fade * far, 0.0, 1.0)


def lip_corners(skin: SkinMesh) -> tuple[float, float]:
    """x of the mouth corners (the ends of the inner lip contours)."""
    inner = np.concatenate([skin.contours["lips_inner_upper"], skin.contours["lips_inner_lower"]])
    return float(skin.vertices[inner, 0].min()), float(skin.vertices[inner, 0].max())


def attach_to_bones(skin: SkinMesh, bones, node_mirror: np.ndarray | None):
    """Stage 2 of the template: every node is attached to the bone whose surface is nearest ("the lower part
    of the face is attached to the mandible"), with the lips deciding around the mouth; a left/right
    symmetric skin (``node_mirror`` given) gets mirror-symmetric attachments (the character's right side
    decides). Returns the bone part of an :class:`AttachmentMap` as a dict, the mouth region and the lip
    distance over the skin."""
    nodes = skin.vertices
    sp, sn, sd, sdist = signed_bone_distance(nodes, bones.skull_vertices, bones.skull_faces)
    jp, jn, jd, jdist = signed_bone_distance(nodes, bones.jaw_vertices, bones.jaw_faces)
    node_bone = np.where(jdist < sdist, JAW, SKULL)
    node_bone, mouth_region, lip_distance, lip_distances = _mouth_bone_override(skin, node_bone)
    symmetric = node_mirror is not None
    if symmetric:
        left = nodes[:, 0] > 1e-9
        node_bone[left] = node_bone[node_mirror[left]]
    on_jaw = node_bone == JAW
    bone_point = np.where(on_jaw[:, None], jp, sp)
    bone_normal = np.where(on_jaw[:, None], jn, sn)
    bone_depth = np.where(on_jaw, jd, sd)
    if symmetric:      # the skin guard then acts the same on both sides too
        flip = np.array([-1.0, 1.0, 1.0])
        bone_point[left] = bone_point[node_mirror[left]] * flip
        bone_normal[left] = bone_normal[node_mirror[left]] * flip
        bone_depth[left] = bone_depth[node_mirror[left]]
    jaw_weight = np.clip(_smooth_on_mesh(on_jaw.astype(float), skin.faces, 6), 0.0, 1.0)
    if symmetric:
        jaw_weight = 0.5 * (jaw_weight + jaw_weight[node_mirror])
    jaw_weight[skin.group("upper_lip")] = np.minimum(jaw_weight[skin.group("upper_lip")], 0.0)
    jaw_weight[skin.group("lower_lip")] = 1.0
    d_up, d_low = lip_distances
    jaw_weight = lip_jaw_weight(nodes[:, 0], d_low < d_up, np.minimum(d_up, d_low), jaw_weight, lip_corners(skin))
    if symmetric:
        jaw_weight = 0.5 * (jaw_weight + jaw_weight[node_mirror])
    bone_part = dict(node_bone=node_bone, jaw_weight=jaw_weight, bone_point=bone_point, bone_normal=bone_normal,
                     bone_depth=bone_depth)
    return bone_part, mouth_region, lip_distance


def attach_to_muscles(system, placed, skin: SkinMesh, node_bone: np.ndarray) -> sparse.csr_matrix:
    """Stage 3 of the template: each node follows up to ``MAX_MUSCLES_PER_NODE`` muscles whose zone of
    influence contains it, at the closest point on each, with a weight that is 1 over the muscle and fades to
    0 at ``influence`` beyond its edge. Returns the (N, P) muscle matrix of :class:`AttachmentMap`."""
    nodes = skin.vertices
    n, k = len(nodes), MAX_MUSCLES_PER_NODE
    eligible = ~skin.group("mouth_bag")
    candidates = []
    for index, m in enumerate(placed):
        cells = np.flatnonzero(system.cell_muscle == index)
        tri = system.cells[cells]
        point, face, bary, dist = geometry.closest_points(system.rest, tri, nodes, candidates=8)
        normal = np.einsum("ij,ijk->ik", bary, system.normal[tri[face]])
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
        offset = nodes - point
        along = np.einsum("ij,ij->i", offset, normal)
        lateral = np.linalg.norm(offset - along[:, None] * normal, axis=1)   # 0 right over the sheet
        depth = np.linalg.norm(m.points - m.skin_points, axis=2).max()
        t = np.clip(1.0 - lateral / m.spec.influence, 0.0, 1.0)
        over = (along > -0.002) & (along < depth + 0.004)                 # on the skin side, not far
        if m.spec.group == "oris":
            # each half of the orbicularis oris moves its own lip only (upper: skull, lower: jaw)
            over &= node_bone == int(np.round(m.row_bone.mean()))
        weight = np.where(eligible & over, t * t * (3 - 2 * t), 0.0)
        candidates.append((weight, cells[face], bary, dist))
    weights = np.stack([c[0] for c in candidates], 1)              # (N, M)
    # strongest influence first; among equals, the muscle closest to the node
    score = weights - 1e-3 * np.minimum(np.stack([c[3] for c in candidates], 1), 0.5)
    order = np.argsort(-score, axis=1, kind="stable")[:, :k]
    rows = np.arange(n)[:, None]
    attach_weight = weights[rows, order]
    attach_cell = np.stack([c[1] for c in candidates], 1)[rows, order]
    attach_bary = np.stack([c[2] for c in candidates], 1)[rows, order]
    attach_cell = np.where(attach_weight > 0, attach_cell, -1)
    corner = system.cells[np.maximum(attach_cell, 0)]                       # (N, K, 3)
    data = (attach_weight[:, :, None] * attach_bary).ravel()
    matrix = sparse.csr_matrix((data, (np.repeat(np.arange(n), k * 3), corner.ravel())),
                               shape=(n, len(system.rest)))
    matrix.eliminate_zeros()
    return matrix


def smoothing_operator(skin: SkinMesh, reference_edge: float = 0.0037):
    """One pass ``0.5 x + 0.5 mean(neighbours)`` over the skin edges, as a sparse matrix, and how many
    passes cover the same physical distance at this resolution (~3 passes at 3.7 mm edges). The lip
    margins and the inner lip surface keep their own value, so closing lips still meet exactly."""
    edges = geometry.unique_edges(skin.faces)
    n = skin.node_count
    adjacency = sparse.csr_matrix((np.ones(2 * len(edges)), (np.r_[edges[:, 0], edges[:, 1]],
                                                             np.r_[edges[:, 1], edges[:, 0]])), shape=(n, n))
    degree = np.asarray(adjacency.sum(axis=1)).ravel()
    keep = np.zeros(n, bool)
    for name in ("lips_inner_upper", "lips_inner_lower"):
        keep[skin.contours[name]] = True
    keep |= skin.group("lip_inner")
    mix = np.where(keep, 0.0, 0.5)
    operator = sparse.diags(1.0 - mix) + sparse.diags(mix / np.maximum(degree, 1)) @ adjacency
    length = geometry.median_edge_length(skin.vertices, edges)
    passes = int(max(1, round(3 * (reference_edge / length) ** 2)))
    return operator.tocsr(), passes
