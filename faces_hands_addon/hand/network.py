# SPDX-License-Identifier: GPL-3.0-or-later
"""The hand's mass-spring network (thesis 6.2.1: "a mass-spring system, interlinking the skin, skeleton, and
muscles"; the integration as in 3.1.2, reusing :mod:`..physics`).

Nodes are the skin vertices; the skin edges are biphasic springs (soft, then stiff past a strain threshold;
softer under compression, where skin folds). Every node carries an attachment pair (Fig. 3.4): a spring to
a point on the tissue underneath, ``depth`` inside, and one to that point mirrored outward, both carried by
the bones through the skin's skinning weights and pushed out by the geometric muscle below the node. So the
bones move the skin, the muscles bulge it, and the edge springs spread and smooth both.

The constants come from three knobs that do not depend on the mesh (as for the face): ``spread_mm`` (how far
a displaced attachment drags the skin around it), ``response_hz`` (how quickly a node follows its
attachment) and ``damping_ratio``. Nodes far stiffer than the typical one get extra mass (mass scaling:
the same equilibrium, a little slower locally), which keeps the explicit integrator's substeps few.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import numpy as np

from ..core import geometry
from ..core.errors import UserError
from ..physics import Attachments, LeapfrogIntegrator, SpringNetwork, SpringSet

__all__ = ["HandMaterial", "HAND_MATERIAL_RANGES", "HandNetwork", "build_hand_network"]

EDGE_STIFFNESS = 1.0          # N/m; only ratios matter (the attachments are kinematic)
COMPRESSION_SOFTNESS = 0.25
HAND_MATERIAL_RANGES = {"spread_mm": (1.0, 20.0), "stiff_ratio": (1.0, 50.0), "strain_threshold": (0.02, 1.0),
                        "response_hz": (1.0, 40.0), "damping_ratio": (0.1, 4.0), "depth_mm": (0.5, 10.0)}


@dataclass(frozen=True)
class HandMaterial:
    """Skin and connective tissue of the hand (module docstring); ranges in :data:`HAND_MATERIAL_RANGES`."""
    spread_mm: float = 4.0
    stiff_ratio: float = 3.0
    strain_threshold: float = 0.15
    response_hz: float = 4.0
    damping_ratio: float = 1.0
    depth_mm: float = 3.0

    def clamped(self) -> "HandMaterial":
        values = {}
        for f in fields(self):
            value = float(getattr(self, f.name))
            if not np.isfinite(value):
                raise UserError(f"hand material {f.name} must be a number")
            low, high = HAND_MATERIAL_RANGES[f.name]
            values[f.name] = float(np.clip(value, low, high))
        return HandMaterial(**values)

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class HandNetwork:
    network: SpringNetwork
    integrator: LeapfrogIntegrator
    offset: np.ndarray            # (N, 3) target -> anchor (inward); mirror = target - offset
    material: HandMaterial

    def set_targets(self, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Anchor and mirror points (3, N) for node targets (N, 3) (the offset follows the bones only
        through the caller's targets; it is small against the motion)."""
        return (target + self.offset).T, (target - self.offset).T


def build_hand_network(vertices: np.ndarray, faces: np.ndarray, material: HandMaterial | None = None,
                       max_substeps: int = 32) -> HandNetwork:
    """Springs, attachments, masses and damping for the skin ``vertices``/``faces`` (module docstring)."""
    material = (material or HandMaterial()).clamped()
    n = len(vertices)
    edges = geometry.unique_edges(faces)
    rest = np.linalg.norm(vertices[edges[:, 1]] - vertices[edges[:, 0]], axis=1)
    k = np.full(len(edges), EDGE_STIFFNESS)
    springs = SpringSet(edges[:, 0], edges[:, 1], rest, k, k * material.stiff_ratio, material.strain_threshold,
                        COMPRESSION_SOFTNESS * k)
    area = np.maximum(geometry.vertex_areas(vertices, faces), 1e-12)
    pair = EDGE_STIFFNESS * area / (material.spread_mm / 1000.0) ** 2
    normals = geometry.vertex_normals(vertices, faces)
    offset = -normals * material.depth_mm / 1000.0
    attachments = Attachments(np.arange(n), pair / 2.0, 0.0, (vertices + offset).T, (vertices - offset).T)
    omega = 2.0 * np.pi * material.response_hz
    natural = pair / omega ** 2
    row = (np.bincount(edges[:, 0], 2 * k * material.stiff_ratio, n)
           + np.bincount(edges[:, 1], 2 * k * material.stiff_ratio, n) + pair)
    cap = float(np.median(row / natural))
    masses = np.maximum(natural, row / cap)
    damping = material.damping_ratio * 2.0 * np.sqrt(pair * masses)
    network = SpringNetwork(vertices, masses, springs, attachments)
    integrator = LeapfrogIntegrator(network, damping, max_substeps=max_substeps)
    return HandNetwork(network, integrator, offset, material)
