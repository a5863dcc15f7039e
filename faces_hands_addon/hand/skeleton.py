# SPDX-License-Identifier: GPL-3.0-or-later
"""The skeleton of the reference hand (thesis 6.2.1): 29 bone meshes (27 hand bones, radius, ulna) carried by
21 rigid bones, a joint hierarchy with an individually oriented frame at each joint centre, the degrees of
freedom of 6.2.1 and the limits of Table 6.4.

Frames (6.2.3 step 3 uses the same convention): ``z`` points from the joint centre towards its child joint
(or the finger tip), ``x`` is the flexion axis and ``y = z x x`` the adduction/abduction axis. A joint's
rotation is ``R = F Rx(flexion) Ry(abduction) Rz(rotation) F^T`` (``F`` the frame as columns), applied about
the joint centre; bones carry no rotation at rest, so every bone's 4x4 maps its rest geometry to its pose.

Signs (worked out from the geometry, so they hold after a warp): positive flexion moves a finger towards
the palm (and the thumb across it), positive abduction moves a finger away from the middle finger (the
middle finger and the wrist: radially; the thumb: away from the index), positive rotation turns the pad
towards the thumb. The engine always builds a right hand in the asset frame (palm towards +X, fingers down
-Z, thumb forward -Y); a left hand is its mirror image (:func:`mirror_matrix`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.errors import UserError

__all__ = ["DOF_KINDS", "Skeleton", "Dof", "rotation_matrices", "mirror_matrix", "TIP_NAMES", "FINGERS"]

DOF_KINDS = ("flexion", "abduction", "rotation")
FINGERS = ("thumb", "index", "middle", "ring", "pinky")
TIP_NAMES = ("thumb-tip", "index-finger-tip", "middle-finger-tip", "ring-finger-tip", "pinky-finger-tip")


def rotation_matrices(axes: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Rodrigues: (K, 3, 3) rotations by ``angles`` (K,) radians about unit ``axes`` (K, 3)."""
    axes = np.asarray(axes, np.float64)
    angles = np.asarray(angles, np.float64)
    c, s = np.cos(angles), np.sin(angles)
    x, y, z = axes[:, 0], axes[:, 1], axes[:, 2]
    t = 1.0 - c
    out = np.empty((len(angles), 3, 3))
    out[:, 0, 0] = c + x * x * t
    out[:, 0, 1] = x * y * t - z * s
    out[:, 0, 2] = x * z * t + y * s
    out[:, 1, 0] = y * x * t + z * s
    out[:, 1, 1] = c + y * y * t
    out[:, 1, 2] = y * z * t - x * s
    out[:, 2, 0] = z * x * t - y * s
    out[:, 2, 1] = z * y * t + x * s
    out[:, 2, 2] = c + z * z * t
    return out


def mirror_matrix() -> np.ndarray:
    """4x4 reflection x -> -x that turns the right hand into a left one (``S M S`` mirrors a pose)."""
    return np.diag([-1.0, 1.0, 1.0, 1.0])


@dataclass(frozen=True)
class Dof:
    """One degree of freedom: ``bone`` index, ``kind`` (flexion / abduction / rotation), limits in radians
    (Table 6.4), for a rotation that follows flexion ``coupled`` = the ratio (None: free), and ``sign``: the
    angle turns about ``+axis`` (1) or ``-axis`` (-1) of the joint frame, so that positive angles keep their
    anatomical meaning in a right-handed frame whose z points to the child."""
    bone: int
    kind: str
    lower: float
    upper: float
    coupled: float | None = None
    sign: float = 1.0

    @property
    def name(self) -> str:
        return self.kind


@dataclass
class Skeleton:
    """Rigid bones in topological order (parents first). Arrays are in metres, rest pose = identity."""
    names: list[str]
    parent: np.ndarray                 # (B,) parent bone index, -1 for the root (forearm)
    position: np.ndarray               # (B, 3) joint centre (the bone's head)
    tail: np.ndarray                   # (B, 3) child joint centre or tip (the bone's tail)
    frame: np.ndarray                  # (B, 3, 3) columns x (flexion), y (abduction), z (to the child)
    dofs: list[Dof]
    mesh_vertices: dict[str, np.ndarray] = field(default_factory=dict)   # bone -> (V, 3) rest vertices
    mesh_faces: dict[str, np.ndarray] = field(default_factory=dict)      # bone -> (F, 3)
    mesh_names: dict[str, list[str]] = field(default_factory=dict)       # bone -> asset mesh names
    tips: dict[str, np.ndarray] = field(default_factory=dict)            # tip name -> (3,) rest point
    mesh_sizes: dict[str, list[int]] = field(default_factory=dict)       # bone -> vertex count per asset mesh

    def __post_init__(self) -> None:
        self.index = {name: i for i, name in enumerate(self.names)}
        self.dof_index = {(self.names[d.bone], d.kind): k for k, d in enumerate(self.dofs)}
        self._kind_column = np.array([DOF_KINDS.index(d.kind) for d in self.dofs], np.int64)
        self._dof_bone = np.array([d.bone for d in self.dofs], np.int64)
        self._signs = np.array([d.sign for d in self.dofs], np.float64)
        self._axes3 = np.tile(np.eye(3), (len(self.names), 1))
        self._frame_t = np.transpose(self.frame, (0, 2, 1))
        depth = np.zeros(len(self.names), np.int64)
        for b, p in enumerate(self.parent):
            depth[b] = 0 if p < 0 else depth[p] + 1
        self._levels = [np.flatnonzero(depth == d) for d in range(int(depth.max()) + 1)]
        self._chained = [(level, self.parent[level]) for level in self._levels[1:]]

    # -- limits and names -------------------------------------------------------------------------
    @property
    def dof_count(self) -> int:
        return len(self.dofs)

    @property
    def lower(self) -> np.ndarray:
        return np.array([d.lower for d in self.dofs])

    @property
    def upper(self) -> np.ndarray:
        return np.array([d.upper for d in self.dofs])

    def dof_names(self) -> list[str]:
        return [f"{self.names[d.bone]}.{d.kind}" for d in self.dofs]

    def dof(self, bone: str, kind: str) -> int:
        try:
            return self.dof_index[(bone, kind)]
        except KeyError:
            raise UserError(f"the hand has no {kind} DOF at {bone!r}") from None

    def children(self, bone: int) -> list[int]:
        return [i for i, p in enumerate(self.parent) if p == bone]

    def chain_below(self, bone: int) -> list[int]:
        """``bone`` and every bone below it, parents first."""
        out, stack = [], [bone]
        while stack:
            b = stack.pop(0)
            out.append(b)
            stack += self.children(b)
        return out

    # -- kinematics ------------------------------------------------------------------------------
    def local_rotations(self, angles: np.ndarray) -> np.ndarray:
        """(B, 3, 3) joint rotations in world axes for the DOF ``angles`` (radians)."""
        bones = len(self.names)
        per_bone = np.zeros((bones, 3))
        per_bone[self._dof_bone, self._kind_column] = angles * self._signs
        r = rotation_matrices(self._axes3, per_bone.ravel()).reshape(bones, 3, 3, 3)
        local = r[:, 0] @ r[:, 1] @ r[:, 2]
        return self.frame @ local @ self._frame_t

    def bone_transforms(self, angles: np.ndarray) -> np.ndarray:
        """(B, 4, 4) rest -> pose transforms of every bone (forward kinematics, one batch per depth)."""
        out = np.zeros((len(self.names), 4, 4))
        out[:, :3, :3] = self.local_rotations(np.asarray(angles, np.float64))     # each joint about its centre
        out[:, :3, 3] = self.position - np.einsum("bij,bj->bi", out[:, :3, :3], self.position)
        out[:, 3, 3] = 1.0
        for level, parent in self._chained:
            out[level] = out[parent] @ out[level]
        return out

    def clamp(self, angles: np.ndarray) -> np.ndarray:
        """Angles within the Table 6.4 limits."""
        return np.clip(angles, self.lower, self.upper)

    def posed_points(self, transforms: np.ndarray, bone: int, points: np.ndarray) -> np.ndarray:
        m = transforms[bone]
        return np.asarray(points) @ m[:3, :3].T + m[:3, 3]

    def tip_bone(self, tip: str) -> int:
        finger = tip.split("-")[0]
        return self.index[f"{finger}-phalanx-distal" if finger == "thumb" else f"{finger}-finger-phalanx-distal"]

    def bone_length(self, bone: int) -> float:
        return float(np.linalg.norm(self.tail[bone] - self.position[bone]))

    def with_geometry(self, position: np.ndarray, tail: np.ndarray, frame: np.ndarray,
                      meshes: dict[str, np.ndarray], tips: dict[str, np.ndarray]) -> "Skeleton":
        """The same joints and DOFs on new geometry (a warped hand, 6.2.3)."""
        return Skeleton(list(self.names), self.parent.copy(), position, tail, frame, list(self.dofs), meshes,
                        dict(self.mesh_faces), dict(self.mesh_names), tips, dict(self.mesh_sizes))

    def asset_mesh(self, name: str) -> np.ndarray:
        """The vertices of one asset mesh (``"ulna"``) in the skeleton's current rest geometry."""
        for bone, names in self.mesh_names.items():
            if name in names:
                k = names.index(name)
                start = int(sum(self.mesh_sizes[bone][:k]))
                return self.mesh_vertices[bone][start:start + self.mesh_sizes[bone][k]]
        raise UserError(f"the hand has no bone mesh {name!r}")


def reoriented_frames(old_frame: np.ndarray, new_position: np.ndarray, new_tail: np.ndarray) -> np.ndarray:
    """Joint frames after a warp (6.2.3 step 3): the new z points from the new joint centre to the warped
    child; the rotation taking the old z onto it is applied to all three axes; then the frame turns about
    z so that x and y lie as close to their old directions as possible."""
    out = np.empty_like(old_frame)
    for b in range(len(old_frame)):
        x_old, y_old, z_old = old_frame[b].T
        z = new_tail[b] - new_position[b]
        z = z / max(np.linalg.norm(z), 1e-12)
        axis = np.cross(z_old, z)
        sine, cosine = np.linalg.norm(axis), float(np.clip(z_old @ z, -1.0, 1.0))
        if sine > 1e-12:
            turn = rotation_matrices((axis / sine)[None], np.array([np.arctan2(sine, cosine)]))[0]
        else:
            turn = np.eye(3)
        x, y = turn @ x_old, turn @ y_old
        # best twist about z: maximise x.x_old + y.y_old
        twist = np.arctan2(np.cross(x, x_old) @ z + np.cross(y, y_old) @ z, x @ x_old + y @ y_old)
        spin = rotation_matrices(z[None], np.array([twist]))[0]
        x, y = spin @ x, spin @ y
        out[b] = np.column_stack([x, y, z])
    return out
