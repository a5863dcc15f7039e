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

import numpy as np

from ..errors import UserError
from ..physics import (Attachments, BoneHalfSpaceGuard, LeapfrogIntegrator, SphereGuard, SpringNetwork,
                       SpringSet)
from . import geometry
from .template import HeadTemplate

__all__ = ["SkinMaterial", "MATERIAL_RANGES", "FaceNetwork", "build_network"]

SKIN_EDGE_STIFFNESS = 1.0     # N/m; the scale is free (muscles move anchors kinematically)
COMPRESSION_SOFTNESS = 0.25   # skin yields under compression (a membrane without bending would buckle)

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
class FaceNetwork:
    network: SpringNetwork
    integrator: LeapfrogIntegrator
    bone_guard: BoneHalfSpaceGuard
    teeth_guard: BoneHalfSpaceGuard
    eye_guards: list[SphereGuard]
    anchor_offset: np.ndarray          # (N, 3) node -> bone vector at rest (anchor = target + offset)
    material: SkinMaterial

    def constrain(self, positions: np.ndarray, velocity: np.ndarray, fraction: float) -> None:
        self.bone_guard(positions, velocity, fraction)
        self.teeth_guard(positions, velocity, fraction)
        for guard in self.eye_guards:
            guard(positions, velocity, fraction)


def build_network(template: HeadTemplate, material: SkinMaterial | None = None,
                  mass_cap_factor: float = 1.0, max_substeps: int = 64) -> FaceNetwork:
    """Springs, attachments, masses, damping and guards for ``template`` (module docstring)."""
    material = (material or SkinMaterial()).clamped()
    skin = template.skin
    nodes = skin.vertices
    n = len(nodes)
    k = SKIN_EDGE_STIFFNESS
    spread = material.spread_mm / 1000.0
    omega = 2 * np.pi * material.response_hz
    edges = geometry.unique_edges(skin.faces)
    rest = np.linalg.norm(nodes[edges[:, 1]] - nodes[edges[:, 0]], axis=1)
    lid_weight = np.zeros(n)
    for lid in template.lids.values():
        lid_weight = np.maximum(lid_weight, lid.weight)
    lips = template.lip_distance < 0.009              # the red of the lips stretches far (mouthClose, "oo")
    soft_region = (lid_weight > 0) | skin.group("mouth_bag") | skin.group("lip_inner") | lips
    edge_soft = soft_region[edges[:, 0]] & soft_region[edges[:, 1]]
    lid_edge = (lid_weight[edges[:, 0]] > 0) & (lid_weight[edges[:, 1]] > 0)
    k_soft = np.where(lid_edge, 0.4 * k, k)                 # thin lid skin stretches easily
    k_stiff = np.where(edge_soft, k_soft, k * material.stiff_ratio)
    springs = SpringSet(edges[:, 0], edges[:, 1], rest, k_soft, k_stiff, material.strain_threshold,
                        COMPRESSION_SOFTNESS * k_soft)

    # attachment pair per node: 2 * c_i = k * A_i / spread^2, firmer where targets must be met
    area = np.maximum(template.areas, 1e-12)
    gain = np.ones(n)
    gain[lid_weight > 0.0] = 1.0 + 11.0 * lid_weight[lid_weight > 0.0]
    gain[skin.group("lip_inner") | skin.group("upper_lip") | skin.group("lower_lip")] = 2.0
    gain[skin.group("mouth_bag")] = 3.0
    gain[skin.group("boundary")] = 3.0
    gain[(template.lip_distance < 0.004) & ~skin.group("mouth_bag")] = 4.0
    for name in ("lips_inner_upper", "lips_inner_lower"):
        gain[skin.contours[name]] = 20.0                   # lip margins must reach their targets to meet
    pair = k * area / spread ** 2 * gain
    attach = pair / 2.0
    offset = template.bone_point - nodes
    depth = np.linalg.norm(offset, axis=1)
    # nodes with no bone underneath (lids, bag) still get a short inward offset for the mirror pair
    inward = -template.normals * 0.004
    offset = np.where((depth > 1e-4)[:, None] & (template.bone_depth > 0)[:, None], offset, inward)
    attachments = Attachments(np.arange(n), attach, 0.0, (nodes + offset).T, (nodes - offset).T)

    # masses: omega^2 = pair / m for the attachment mode; mass scaling caps each node's own limit
    natural = pair / omega ** 2
    row = np.zeros(n)
    row += np.bincount(edges[:, 0], 2 * k_stiff, n) + np.bincount(edges[:, 1], 2 * k_stiff, n)
    row += pair
    limit = row / natural
    cap = mass_cap_factor * float(np.median(limit))
    masses = np.maximum(natural, row / cap)
    damping = material.damping_ratio * 2.0 * np.sqrt(pair * masses)
    network = SpringNetwork(nodes, masses, springs, attachments, kinematic=template.kinematic)
    integrator = LeapfrogIntegrator(network, damping, max_substeps=max_substeps)

    # the guard's planes: each node's rest height over its bone's tangent plane sets its clearance
    plane_height = np.einsum("ij,ij->i", nodes - template.bone_point, template.bone_normal)
    guarded = skin.group("surface") & (lid_weight == 0) & (plane_height > 0.0015)
    guarded &= ~skin.group("lip_inner") & ~skin.group("mouth_bag") & ~template.mouth_region
    index = np.flatnonzero(guarded)
    clearance = np.minimum(0.0015, 0.5 * plane_height[index])
    bone_guard = BoneHalfSpaceGuard(index, template.bone_point[index].T, template.bone_normal[index].T,
                                    template.node_bone[index], clearance)
    bones = template.bones
    meshes = [(bones.skull_vertices, bones.skull_faces), (bones.jaw_vertices, bones.jaw_faces)]
    bone_normals = [geometry.vertex_normals(v, f) for v, f in meshes]

    def exact(bone: int, points: np.ndarray):
        verts, faces = meshes[bone]
        point, face, bary, _ = geometry.closest_points(verts, faces, points)
        normal = np.einsum("ij,ijk->ik", bary, bone_normals[bone][faces[face]])
        return point, normal / np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)

    bone_guard.attach_bone_surfaces([(meshes[0][0], bone_normals[0]), (meshes[1][0], bone_normals[1])],
                                    exact=exact, rest=nodes[index].T, facing=template.normals[index].T)
    # lips and the skin around the mouth stay in front of the (rendered) teeth instead of the skull's
    upper_points, upper_normals = template.arches["upper"]
    lower_points, lower_normals = template.arches["lower"]
    lips = template.mouth_region & (skin.group("surface") | skin.group("lip_inner"))
    lip_index = np.flatnonzero(lips)
    far_behind = nodes[lip_index].T + np.array([[0.0], [1.0], [0.0]])   # inactive until a tooth is near
    teeth_guard = BoneHalfSpaceGuard(lip_index, far_behind, np.tile([[0.0], [-1.0], [0.0]], len(lip_index)),
                                     np.zeros(len(lip_index), np.int64), 0.0015)
    teeth_guard.attach_bone_surfaces([(upper_points, upper_normals), (lower_points, lower_normals)], reach=0.012,
                                     facing=template.normals[lip_index].T, rest=nodes[lip_index].T)
    teeth_guard.set_bone_transforms([np.eye(4), np.eye(4)])
    teeth_guard.refresh(nodes.T, everything=True)
    teeth_guard.snapshot()
    height = np.einsum("ij,ij->j", nodes[lip_index].T - teeth_guard.point, teeth_guard.normal)
    teeth_guard.clearance = np.clip(0.8 * height, 0.0, 0.0015)       # never pushes a node at rest
    teeth_guard.clearance[height <= 0] = -1.0                          # a node behind the arch: off
    eye_guards = []
    for side, lid in template.lids.items():
        idx = lid.index[skin.group("surface")[lid.index]]
        radius = template.eye_radius + 0.0003
        idx = idx[np.linalg.norm(nodes[idx] - template.eye_centres[side], axis=1) >= radius]
        eye_guards.append(SphereGuard(idx, template.eye_centres[side], radius))
    return FaceNetwork(network, integrator, bone_guard, teeth_guard, eye_guards, offset, material)
