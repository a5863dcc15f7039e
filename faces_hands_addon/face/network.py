# SPDX-License-Identifier: GPL-3.0-or-later
"""The head's spring network (thesis 3.1.2 "Mass Spring Network": "The spring mesh is set up automatically
from the geometry. Nodes and edges of the skin mesh are converted into mass points and springs ... The
stiffness constant of the skin springs is biphasic ... On bones and muscles, static mass points are inserted
and connected to the skin nodes. The stiffness value of the connective springs is rather low").

Choosing the constants so that few substeps suffice. The muscles move the attachment points kinematically,
so only *ratios* shape the rest state and only the time scales shape the motion. We set them from three
physical-feeling knobs that do not depend on the mesh resolution:

* ``spread_mm`` -- how far a displaced attachment drags the surrounding skin: with skin-edge stiffness ``k``
  and attachment stiffness ``kappa`` per unit area, ``spread^2 = k / kappa``;
* ``response_hz`` -- the natural frequency of a node on its attachment pair, ``omega^2 = kappa / rho``, which
  fixes the areal mass ``rho`` (the skin reaches a new expression in about ``1 / response_hz`` seconds);
* ``damping_ratio`` -- of that motion (1 = critical).

The explicit step is limited by the stiffest, lightest node; the canonical face's lid and lip triangles are
~8x smaller than its forehead triangles, so nodes whose own limit lies far above the typical node's get
extra mass (mass scaling: same equilibrium, a little slower locally). This keeps the guard's substep count
near ``2 pi response_hz spread / h`` per second of simulated time for a typical edge length ``h``.

Two further choices: skin springs are 4x softer under compression than in tension (skin gives way and
folds; a mass-spring membrane has no bending stiffness and would otherwise buckle at the mesh scale),
and the lids, the red of the lips and the mouth lining have no stiff branch (they stretch far when lids
close and lips meet). Attachments are firmer where targets must be met exactly: lid margins, lip margins.
Guards: skin outside the mouth is kept outside skull and jaw, lips in front of the teeth, lids off the
eyeballs (:mod:`..physics.collision`).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from functools import cached_property

import numpy as np

from ..core.errors import UserError
from ..physics import (Attachments, BoneHalfSpaceGuard, CapBulge, LeapfrogIntegrator, SphereGuard,
                       SpringNetwork, SpringSet)
from ..core import geometry
from ..physics import kernel
from . import sliver_kernel
from .attachment import BoneSurface
from .organs import CORNEA_BULGE, CORNEA_DEG
from .template import HeadTemplate

__all__ = ["SkinMaterial", "MATERIAL_RANGES", "FaceNetwork", "SliverTies", "build_network"]

SKIN_EDGE_STIFFNESS = 1.0     # N/m; the scale is free (muscles move anchors kinematically)
COMPRESSION_SOFTNESS = 0.25   # skin yields under compression (a membrane without bending would buckle)
TEMPLATE_EDGE = 0.0041        # m: the default head's median skin edge, where COMPRESSION_SOFTNESS was set
CORNER_RADIUS, CORNER_GAIN = 0.0035, 40.0    # m around each mouth corner (the modiolus' knot); its attachment gain
CANTHUS_GAIN = 40.0          # attachment gain on a canthus (the canthal tendons tie it to the orbit), as CORNER_GAIN
OVER_BONE = 0.3             # fitted heads: the skull guard holds skin whose bone normal faces its own this much
LEDGE_DOWN = 0.9             # fitted heads: a bone normal this far down is the underside of a ledge (orbit roof)
SLIVER_HEIGHT = 0.0003       # m: a triangle corner this close to its opposite edge follows that edge (SliverTies)
SLIVER_FRACTION = 0.15       # ... and closer than this fraction of the mesh's median edge (a dense mesh's are small)

#: documented UI ranges of the material knobs (values outside are clamped)
MATERIAL_RANGES = {
    "spread_mm": (1.0, 30.0),
    "stiff_ratio": (1.0, 50.0),
    "strain_threshold": (0.02, 1.0),
    "response_hz": (0.5, 40.0),
    "damping_ratio": (0.0, 4.0),
}


@dataclass(frozen=True)
class SkinMaterial:
    """Skin and connective tissue (module docstring). Ranges: :data:`MATERIAL_RANGES`."""
    spread_mm: float = 6.0
    stiff_ratio: float = 4.0            # biphasic: stiff/soft spring constant
    strain_threshold: float = 0.15      # biphasic: strain where the stiff branch starts
    response_hz: float = 5.0
    damping_ratio: float = 0.9

    def clamped(self) -> "SkinMaterial":
        values = {}
        for f in fields(self):
            low, high = MATERIAL_RANGES[f.name]
            value = float(getattr(self, f.name))
            if not np.isfinite(value):
                raise UserError(f"skin material {f.name} must be a number")
            values[f.name] = float(np.clip(value, low, high))
        return SkinMaterial(**values)

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class SliverTies:
    """Sliver triangles of an artist's mesh keep their shape. A spring network of the skin's edges (3.1.2)
    has no say in how a triangle with a corner within ``SLIVER_HEIGHT`` of its opposite edge is oriented (two
    vertices 0.2 mm apart, or a flat cap, at SOMA's inner canthus): a sub-millimetre difference in how its
    nodes are pulled turns it over. In each such triangle the nearest corner (the *apex*) follows its edge,
    at its rest offset from the point of the edge next to it, like welded vertices. An apex may be tied in
    several slivers and be another's edge end: the ties are placed in ``PASSES`` sweeps over batches in which
    no node occurs twice (as position constraints are relaxed one after another). Only ``free`` apices are
    tied: not kinematic nodes, nor the lips' (upper, lower and inner lip), whose lip contact and teeth guard
    place them; the rest of the mouth region is tied (a sliver at MakeHuman neutral's commissure turned over
    in mouthFrown).

    Thin is relative to the mesh: a corner must lie within ``SLIVER_HEIGHT`` of its edge *and* within
    ``SLIVER_FRACTION`` of the mesh's median edge length. On the default and 10k heads and the fitted heads of
    2.5-3k nodes (median edge 2.0-4.4 mm) the second bound is above 0.3 mm and changes nothing; on a dense
    mesh, whose ordinary triangles are 0.3 mm high, it keeps the ties to the thinnest. (The 10k head
    subdivided once, 45k nodes, median edge 1.0 mm, had 10,914 ties on 6,027 apices, 13 % of its nodes, in
    chains with cycles that no sweep of placements satisfies: in jawOpen 214 nodes at the mouth corner
    jumped 1.2 mm at every guard call, a flicker of 0.3 mm from frame to frame that never settled. Now 546.)
    """
    batches: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]
    PASSES = 2

    @classmethod
    def build(cls, vertices: np.ndarray, faces: np.ndarray, free: np.ndarray,
              height: float | None = None) -> "SliverTies":
        """The ties of the mesh ``vertices``/``faces`` on its ``free`` apices; ``height`` (m) overrides the
        thinness bound (default: the smaller of ``SLIVER_HEIGHT`` and ``SLIVER_FRACTION`` x median edge)."""
        vertices, faces = np.asarray(vertices, np.float64), np.asarray(faces, np.int64)
        if height is None:
            edges = geometry.unique_edges(faces)
            height = min(SLIVER_HEIGHT, SLIVER_FRACTION * geometry.median_edge_length(vertices, edges)) \
                if len(edges) else SLIVER_HEIGHT
        distance, share = np.full((len(faces), 3), np.inf), np.zeros((len(faces), 3))
        for k in range(3):
            apex, start, end = faces[:, k], faces[:, (k + 1) % 3], faces[:, (k + 2) % 3]
            edge = vertices[end] - vertices[start]
            along = np.einsum("ij,ij->i", vertices[apex] - vertices[start], edge)
            share[:, k] = np.clip(along / np.maximum(np.einsum("ij,ij->i", edge, edge), 1e-30), 0.0, 1.0)
            distance[:, k] = np.linalg.norm(vertices[apex] - vertices[start] - share[:, k, None] * edge, axis=1)
        corner = np.argmin(distance, axis=1)
        rows = np.arange(len(faces))
        picked = np.flatnonzero((distance[rows, corner] < height) & free[faces[rows, corner]])
        picked = picked[np.argsort(distance[picked, corner[picked]], kind="stable")]
        batches, used = [], []
        for face in picked:
            k = corner[face]
            tie = (faces[face, k], faces[face, (k + 1) % 3], faces[face, (k + 2) % 3], share[face, k])
            slot = next((i for i, nodes in enumerate(used) if not nodes.intersection(tie[:3])), len(used))
            if slot == len(used):
                used.append(set())
                batches.append([])
            used[slot].update(int(n) for n in tie[:3])
            batches[slot].append(tie)
        out = []
        for batch in batches:
            apex, start, end = (np.array([t[j] for t in batch], np.int64) for j in range(3))
            s = np.array([t[3] for t in batch], np.float64)
            point = (1.0 - s)[:, None] * vertices[start] + s[:, None] * vertices[end]
            out.append((apex, start, end, s, (vertices[apex] - point).T.copy()))
        return cls(out)

    def __call__(self, positions: np.ndarray, velocity: np.ndarray) -> None:
        """Place every apex on its edge (positions, velocities (3, N), in place); wherever the kernel is usable,
        in the compiled loop of :mod:`.sliver_kernel` (this numpy code is the reference)."""
        if self.batches and (place := kernel.compiled(sliver_kernel.place_apices)) is not None:
            place(positions, velocity, *self._packed, self.PASSES)
            return
        for _ in range(self.PASSES if self.batches else 0):
            for apex, start, end, share, offset in self.batches:
                positions[:, apex] = (1.0 - share) * positions[:, start] + share * positions[:, end] + offset
                velocity[:, apex] = (1.0 - share) * velocity[:, start] + share * velocity[:, end]

    @cached_property
    def _packed(self) -> tuple[np.ndarray, ...]:
        """The batches concatenated in order (apex, start, end, share, offset (3, T)) for the compiled loop
        (the batches are fixed once built)."""
        return tuple(np.ascontiguousarray(np.concatenate([batch[j] for batch in self.batches], axis=-1))
                     for j in range(5))


@dataclass
class FaceNetwork:
    network: SpringNetwork
    integrator: LeapfrogIntegrator
    bone_guard: BoneHalfSpaceGuard
    teeth_guard: BoneHalfSpaceGuard
    eye_guards: list[SphereGuard]
    anchor_offset: np.ndarray          # (N, 3) node -> bone vector at rest (anchor = target + offset)
    material: SkinMaterial
    slivers: SliverTies | None = None

    def set_backend(self, backend: str) -> None:
        """"auto" (the default) or "numba" (the fused kernel and compiled guards wherever numba is usable,
        physics/kernel.py) or "numpy" (the reference path) for the integrator and every guard."""
        if backend not in kernel.BACKENDS:
            raise UserError(f"unknown simulation backend {backend!r}; use one of {', '.join(kernel.BACKENDS)}")
        self.integrator.backend = backend
        for guard in (self.bone_guard, self.teeth_guard, *self.eye_guards):
            guard.backend = backend

    def constrain(self, positions: np.ndarray, velocity: np.ndarray, fraction: float) -> None:
        self.bone_guard(positions, velocity, fraction)
        self.teeth_guard(positions, velocity, fraction)
        for guard in self.eye_guards:
            guard(positions, velocity, fraction)
        if self.slivers is not None:
            self.slivers(positions, velocity)


def _lid_weight(template: HeadTemplate) -> np.ndarray:
    lid_weight = np.zeros(template.node_count)
    for lid in template.organs.lids.values():
        lid_weight = np.maximum(lid_weight, lid.weight)
    return lid_weight


def _canthus_tie(template: HeadTemplate) -> np.ndarray:
    tie = np.zeros(template.node_count)
    for lid in template.organs.lids.values():
        tie = np.maximum(tie, getattr(lid, "canthus_tie", 0.0))
    return tie


def _skin_springs(template: HeadTemplate, material: SkinMaterial, lid_weight: np.ndarray):
    """Biphasic springs on the skin edges (3.1.2), soft (no stiff branch) on lids, lips and mouth lining."""
    skin, k = template.skin, SKIN_EDGE_STIFFNESS
    nodes = skin.vertices
    edges = geometry.unique_edges(skin.faces)
    rest = np.linalg.norm(nodes[edges[:, 1]] - nodes[edges[:, 0]], axis=1)
    lips = skin.lip_distance < 0.009              # the red of the lips stretches far (mouthClose, "oo")
    soft_region = (lid_weight > 0) | skin.group("mouth_bag") | skin.group("lip_inner") | lips
    edge_soft = soft_region[edges[:, 0]] & soft_region[edges[:, 1]]
    lid_edge = (lid_weight[edges[:, 0]] > 0) & (lid_weight[edges[:, 1]] > 0)
    k_soft = np.where(lid_edge, 0.4 * k, k)                 # thin lid skin stretches easily
    k_stiff = np.where(edge_soft, k_soft, k * material.stiff_ratio)
    springs = SpringSet(edges[:, 0], edges[:, 1], rest, k_soft, k_stiff, material.strain_threshold,
                        compression_softness(rest, skin.fitted) * k_soft)
    return springs, edges, k_stiff


def compression_softness(rest: np.ndarray, fitted: bool) -> float:
    """The skin springs' stiffness under compression over their stiffness in tension. A membrane without
    bending stiffness on an elastic foundation (the attachment pairs, stiffness per node ~ the node's area,
    ``h^2``) buckles where its compressed springs' pull sideways (~ force / ``h``) beats the foundation: the
    compression it withstands falls as ``h^3`` for a mesh of edge length ``h``. ``COMPRESSION_SOFTNESS`` was
    set on the default head (median edge ``TEMPLATE_EDGE``); an artist's finer mesh keeps the same margin
    with it scaled by ``(h / TEMPLATE_EDGE)^3`` (``h`` its median edge, head space): a Catmull-Clark head of
    69k vertices (median edge ~0.8 mm) folded rows of 0.4 mm triangles wherever the skin was pushed together
    (browDownLeft 117 inverted triangles, with 0 in its attachment targets), none with the scaled value."""
    if not fitted or not len(rest):
        return COMPRESSION_SOFTNESS
    return COMPRESSION_SOFTNESS * min(1.0, float(np.median(rest)) / TEMPLATE_EDGE) ** 3


def _attachment_pairs(template: HeadTemplate, material: SkinMaterial, lid_weight: np.ndarray):
    """The attachment pair of every node (Fig. 3.4): pair stiffness ``2 c_i = k A_i / spread^2``, firmer where
    targets must be met, anchored at the mirrored offsets of :mod:`.attachment`."""
    skin = template.skin
    nodes = skin.vertices
    n = len(nodes)
    spread = material.spread_mm / 1000.0
    area = np.maximum(skin.areas, 1e-12)
    gain = np.ones(n)
    gain[lid_weight > 0.0] = 1.0 + 11.0 * lid_weight[lid_weight > 0.0]
    tie = _canthus_tie(template)
    gain = np.maximum(gain, 1.0 + CANTHUS_GAIN * tie)
    gain[skin.group("lip_inner") | skin.group("upper_lip") | skin.group("lower_lip")] = 2.0
    gain[skin.group("mouth_bag")] = 3.0
    gain[skin.group("boundary")] = 3.0
    gain[(skin.lip_distance < 0.004) & ~skin.group("mouth_bag")] = 4.0
    for name in ("lips_inner_upper", "lips_inner_lower"):
        gain[skin.contours[name]] = 20.0                   # lip margins must reach their targets to meet
    for name in ("lips_inner_upper",):                     # the commissures: firm, so the corner opens without folding
        for end in (skin.contours[name][0], skin.contours[name][-1]):
            near = np.linalg.norm(nodes - nodes[end], axis=1) < CORNER_RADIUS
            gain[near & ~skin.group("mouth_bag")] = np.maximum(gain[near & ~skin.group("mouth_bag")], CORNER_GAIN)
    pair = SKIN_EDGE_STIFFNESS * area / spread ** 2 * gain
    offset = template.attachment.anchor_offsets(nodes, skin.normals)
    attachments = Attachments(np.arange(n), pair / 2.0, 0.0, (nodes + offset).T, (nodes - offset).T)
    return pair, attachments, offset


def _masses(pair: np.ndarray, edges: np.ndarray, k_stiff: np.ndarray, material: SkinMaterial,
            mass_cap_factor: float) -> tuple[np.ndarray, np.ndarray]:
    """Node masses from ``omega^2 = pair / m`` for the attachment mode, mass scaling capping each node's own
    stability limit (module docstring), and the damping of the chosen damping ratio."""
    n = len(pair)
    omega = 2 * np.pi * material.response_hz
    natural = pair / omega ** 2
    row = np.zeros(n)
    row += np.bincount(edges[:, 0], 2 * k_stiff, n) + np.bincount(edges[:, 1], 2 * k_stiff, n)
    row += pair
    limit = row / natural
    cap = mass_cap_factor * float(np.median(limit))
    masses = np.maximum(natural, row / cap)
    return masses, material.damping_ratio * 2.0 * np.sqrt(pair * masses)


def under_ledge(bone_normal: np.ndarray, skin_normal: np.ndarray) -> np.ndarray:
    """Which nodes hang below a ledge (bool (N,); normals (N, 3) each, rest frame): skin facing forward or
    sideways whose closest bone faces down (MakeHuman's brow under the orbit's roof, bone normal z -0.98).
    Rising, it slides over the rim, not into it: a fitted head's skull guard holds no such node, neither at
    build (:func:`_bone_guard`) nor when it re-anchors a plane (``BoneHalfSpaceGuard.keep_own_bones``)."""
    return (bone_normal[:, 2] < -LEDGE_DOWN) & (skin_normal[:, 2] > -0.5)


def _bone_guard(template: HeadTemplate, lid_weight: np.ndarray) -> BoneHalfSpaceGuard:
    """Skin outside the mouth stays outside skull and jaw (3.1.2, Fig. 3.4); each node's rest height over its
    bone's tangent plane sets its clearance. On a fitted head only skin lying over its bone is held."""
    skin, anchoring = template.skin, template.attachment
    nodes = skin.vertices
    plane_height = np.einsum("ij,ij->i", nodes - anchoring.bone_point, anchoring.bone_normal)
    guarded = skin.group("surface") & (lid_weight == 0) & (plane_height > 0.0015)
    guarded &= ~skin.group("lip_inner") & ~skin.group("mouth_bag") & ~skin.mouth_region
    if skin.fitted:
        # a fitted head (with or without a driven ring): skin whose closest bone faces away from it lies over an
        # opening of the transferred skull (SOMA's lower brow: the orbit's roof, 5 mm above it, facing down),
        # not on the bone; that plane held the brow down when it rose (browOuterUp folded)
        guarded &= np.einsum("ij,ij->i", skin.normals, anchoring.bone_normal) > OVER_BONE
        guarded &= ~under_ledge(anchoring.bone_normal, skin.normals)
    index = np.flatnonzero(guarded)
    clearance = np.minimum(0.0015, 0.5 * plane_height[index])
    guard = BoneHalfSpaceGuard(index, anchoring.bone_point[index].T, anchoring.bone_normal[index].T,
                               anchoring.node_bone[index], clearance)
    bones = template.bones
    surfaces = [BoneSurface(bones.skull_vertices, bones.skull_faces), BoneSurface(bones.jaw_vertices, bones.jaw_faces)]

    def exact(bone: int, points: np.ndarray):
        return surfaces[bone].closest(points)[:2]

    guard.attach_bone_surfaces([(s.vertices, s.normals) for s in surfaces], exact=exact, rest=nodes[index].T,
                               facing=skin.normals[index].T)
    return guard


def _teeth_guard(template: HeadTemplate) -> BoneHalfSpaceGuard:
    """Lips and the skin around the mouth stay in front of the (rendered) teeth instead of the skull's."""
    skin = template.skin
    nodes = skin.vertices
    upper_points, upper_normals = template.organs.arches["upper"]
    lower_points, lower_normals = template.organs.arches["lower"]
    lips = skin.mouth_region & (skin.group("surface") | skin.group("lip_inner"))
    lip_index = np.flatnonzero(lips)
    far_behind = nodes[lip_index].T + np.array([[0.0], [1.0], [0.0]])   # inactive until a tooth is near
    guard = BoneHalfSpaceGuard(lip_index, far_behind, np.tile([[0.0], [-1.0], [0.0]], len(lip_index)),
                               np.zeros(len(lip_index), np.int64), 0.0015)
    guard.attach_bone_surfaces([(upper_points, upper_normals), (lower_points, lower_normals)], reach=0.012,
                               facing=skin.normals[lip_index].T, rest=nodes[lip_index].T)
    guard.set_bone_transforms([np.eye(4), np.eye(4)])
    guard.refresh(nodes.T, everything=True)
    guard.snapshot()
    height = np.einsum("ij,ij->j", nodes[lip_index].T - guard.point, guard.normal)
    guard.clearance = np.clip(0.8 * height, 0.0, 0.0015)       # never pushes a node at rest
    guard.clearance[height <= 0] = -1.0                          # a node behind the arch: off
    return guard


def _cornea(eye_radius: float, sag: np.ndarray | float = 0.0) -> CapBulge:
    """The cornea's bulge (m) in unit directions (3, K) from the eye centre, looking ahead (-Y): what a
    closing lid must pass over (:func:`.organs.cornea_bulge`: ``CORNEA_BULGE`` of the radius, over
    ``CORNEA_DEG``), plus each guarded node's ``sag`` (the depth a skin triangle's flat middle sinks below
    its corners on the sphere), so that a coarse lid's triangles, not only its nodes, stay in front of the
    cornea."""
    return CapBulge(eye_radius, CORNEA_BULGE, CORNEA_DEG, sag)


def _longest_edge(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Per node, its longest incident skin edge (m)."""
    edges = geometry.unique_edges(faces)
    length = np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1)
    out = np.zeros(len(vertices))
    np.maximum.at(out, edges[:, 0], length)
    np.maximum.at(out, edges[:, 1], length)
    return out


def _eye_guards(template: HeadTemplate) -> list[SphereGuard]:
    """Lids stay off the eyeballs and their corneas."""
    skin, organs = template.skin, template.organs
    guards = []
    longest = _longest_edge(skin.vertices, skin.faces)
    for side, lid in organs.lids.items():
        near = np.linalg.norm(skin.vertices - organs.eye_centres[side], axis=1) < organs.eye_radius + 0.004
        idx = np.union1d(lid.index, np.flatnonzero(near))          # lid skin, and skin the lid pulls over
        idx = idx[skin.group("surface")[idx]]
        radius = organs.eye_radius + 0.0003
        sag = longest[idx] ** 2 / (8.0 * organs.eye_radius)            # chord sagitta of the lid's triangles
        guards.append(SphereGuard(idx, organs.eye_centres[side], radius,
                                  extra=_cornea(organs.eye_radius, sag), rest=skin.vertices[idx].T))
    return guards


def build_network(template: HeadTemplate, material: SkinMaterial | None = None,
                  mass_cap_factor: float = 1.0, max_substeps: int = 64) -> FaceNetwork:
    """Springs, attachments, masses, damping and guards for ``template`` (module docstring)."""
    material = (material or SkinMaterial()).clamped()
    lid_weight = _lid_weight(template)
    springs, edges, k_stiff = _skin_springs(template, material, lid_weight)
    pair, attachments, offset = _attachment_pairs(template, material, lid_weight)
    masses, damping = _masses(pair, edges, k_stiff, material, mass_cap_factor)
    network = SpringNetwork(template.skin.vertices, masses, springs, attachments, kinematic=template.skin.kinematic)
    integrator = LeapfrogIntegrator(network, damping, max_substeps=max_substeps)
    skin = template.skin
    lips = skin.group("upper_lip") | skin.group("lower_lip") | skin.group("lip_inner")
    slivers = SliverTies.build(skin.vertices, skin.faces, ~network.kinematic & ~lips)
    return FaceNetwork(network, integrator, _bone_guard(template, lid_weight), _teeth_guard(template),
                       _eye_guards(template), offset, material, slivers)
