# SPDX-License-Identifier: GPL-3.0-or-later
"""Skin-through-bone guard (thesis 3.1.2: the mirrored springs prevent penetration "except for very violent
movements"; this guard covers those too).

Every guarded node remembers the closest point on its bone and that bone's outward normal there, both in
the bone's own frame. After each substep a node that has sunk below the tangent plane (minus a clearance)
is projected back onto it and loses its inward velocity. Branch-free and vectorised: a dot product, a
``maximum`` and two multiply-adds per node (numpy, the reference), or the same per node in one compiled
loop (:mod:`.kernel`, when numba is importable).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import anchor_kernel, kernel

__all__ = ["BoneHalfSpaceGuard", "SphereGuard", "CapBulge"]

_NO_STILL = (np.zeros(0, np.bool_), np.zeros((3, 0)), np.zeros((3, 0)))   # no interpolation: no still planes


def _compiled_guards(backend: str):
    """The compiled guard loops for ``backend`` (see the classes' ``backend``), or ``None``."""
    return None if backend == "numpy" else kernel.guard_kernels()


class BoneHalfSpaceGuard:
    """Keeps ``nodes`` outside the tangent half-spaces ``(x - point) . normal >= clearance``.

    ``point``/``normal`` (3, K) are given in the rest pose, i.e. in the frame of bone ``bone[k]``;
    :meth:`set_bone_transforms` poses them with the bones (4x4 matrices, e.g. skull identity, jaw pose).
    With :meth:`attach_bone_surfaces`, :meth:`refresh` re-anchors the plane of every node that has slid
    along the bone since its plane was last chosen (incremental: a resting face costs nothing).
    """

    #: "auto" or "numba" (the compiled loop of .kernel wherever numba is usable) or "numpy" (the reference path)
    backend = "auto"

    def __init__(self, nodes: np.ndarray, point: np.ndarray, normal: np.ndarray, bone: np.ndarray,
                 clearance: np.ndarray | float) -> None:
        self.nodes = np.ascontiguousarray(nodes, np.int64)
        self.local_point = np.array(point, np.float64)
        normal = np.asarray(normal, np.float64)
        self.local_normal = normal / np.maximum(np.linalg.norm(normal, axis=0), 1e-12)
        self.bone = np.array(bone, np.int64)
        self.clearance = np.broadcast_to(np.asarray(clearance, np.float64), self.nodes.shape).copy()
        self.point = self.local_point.copy()
        self.normal = self.local_normal.copy()
        self._depth = np.empty(self.nodes.shape[0])
        self._transforms: list[np.ndarray] = []
        self._posed = False              # point/normal are local_point/local_normal posed by _transforms
        self._surfaces = None
        self._packed = None               # the surfaces' grids for the compiled refresh
        self._own = None
        self._refuse = None
        self._initial = (self.local_point.copy(), self.local_normal.copy(), self.bone.copy())
        self._still = None                # this frame's still planes for the compiled guard (_still_planes)

    def keep_own_bones(self, refuse=None) -> None:
        """Guard every node against its *own* bone only (the bone it has now), and re-anchor its plane on the
        exact closest point of that bone only once the node has slid over the bone, measured in the bone's
        own frame (:meth:`refresh`).

        This is the guard a head fitted to an artist's mesh needs. Re-anchoring on the nearest vertex of
        whichever bone is nearest misfires there twice: chin skin swinging down and back with the opening
        jaw passes within reach of the upper teeth and is held by their plane (the chin crumples), and a
        node carried by the jaw, moving with it, is re-anchored every frame on a nearest bone *vertex*
        whose plane can cut through the node's own rest place at the mandible's lower border. Skin carried
        by a bone cannot reach the other bone from outside, and its rest plane stays valid while it rides
        with its bone; the lips, where both bones matter, are left to the teeth guard. A new plane must leave
        the node's own rest place outside (a node lagging behind its bone over a concave part of it would
        otherwise get a plane across its way back). Needs :meth:`attach_bone_surfaces` with ``exact``.

        ``refuse(normal, facing)`` (rest-frame plane normals and the skin's ``facing`` normals, (M, 3) each ->
        bool (M,)): new planes refused on top of those tests; the node keeps its plane (a fitted head passes
        ``face.network.under_ledge``, the rule its build guards by: skin rising under the orbit's roof slides
        over the rim, not into it)."""
        self._own = self.bone.copy()
        self._refuse = refuse

    def reset(self) -> None:
        """Back to the planes given at construction (and, with surfaces, to the rest anchoring)."""
        self.local_point[...], self.local_normal[...], self.bone[...] = (a.copy() for a in self._initial)
        if self._surfaces is not None and self._rest is not None:
            self._last = self._rest.copy()
        self._posed = False
        self.set_bone_transforms([np.eye(4) for _ in (self._transforms or [None])])
        self._start = None

    def begin_frame(self) -> None:
        """Remember the current planes: during the next frame the guard slides them from these to the ones
        posed by :meth:`set_bone_transforms` / :meth:`refresh` (``fraction`` of the substeps), as the bones
        themselves move during the frame -- a jaw that opened in one go must not teleport the skin."""
        self._start = (self.point.copy(), self.normal.copy())
        self._still = None

    def set_bone_transforms(self, transforms: list[np.ndarray] | np.ndarray) -> None:
        """Pose the guard planes with their bones (``transforms[b]`` is bone b's 4x4 matrix). The same
        matrices as last time leave the posed planes as they are (every change of a local plane re-poses
        it at once, :meth:`_pose`)."""
        transforms = [np.array(m, np.float64) for m in transforms]
        if self._posed and len(transforms) == len(self._transforms) and all(
                np.array_equal(new, old) for new, old in zip(transforms, self._transforms)):
            return
        self._transforms = transforms
        self._pose(None)

    def _pose(self, which: np.ndarray | None) -> None:
        """Pose the planes of the guarded nodes ``which`` (all for ``None``) with their bones."""
        self._posed = True
        self._still = None
        if which is None and _compiled_guards(self.backend) is not None:
            every = np.arange(len(self.nodes))
            kernel.compiled(anchor_kernel.pose_planes)(every, len(every), self.bone, *self._bone_frames(),
                                                       self.local_point, self.local_normal, self.point, self.normal)
            return
        for index, matrix in enumerate(self._transforms):
            if which is None:            # every plane: whole-array products, kept where the bone is this one
                mine = (self.bone == index)[None, :]
                np.copyto(self.point, matrix[:3, :3] @ self.local_point + matrix[:3, 3:4], where=mine)
                np.copyto(self.normal, matrix[:3, :3] @ self.local_normal, where=mine)
                continue
            mask = which[self.bone[which] == index]
            if len(mask):
                self.point[:, mask] = matrix[:3, :3] @ self.local_point[:, mask] + matrix[:3, 3:4]
                self.normal[:, mask] = matrix[:3, :3] @ self.local_normal[:, mask]

    def attach_bone_surfaces(self, surfaces: list[tuple[np.ndarray, np.ndarray]], reach: float = 0.02,
                             exact=None, rest: np.ndarray | None = None, facing: np.ndarray | None = None,
                             moved: float = 0.0015) -> None:
        """Let :meth:`refresh` re-anchor the planes on the bones' surfaces: ``surfaces[b]`` = (rest vertices
        (V, 3), outward vertex normals (V, 3)) of bone b. ``exact(b, points)`` -> (closest points, normals)
        on bone b's true surface (rest frame) is used for nodes the nearest-vertex plane finds too close.
        ``rest`` (3, K): where the nodes start; a node is re-anchored once it has moved ``moved`` metres
        from where its plane was last chosen. ``facing`` (3, K): the skin's outward normals at rest; a bone
        plane must face the same way (bone meshes with inner surfaces would otherwise offer planes that
        push the skin into the head)."""
        from scipy.spatial import cKDTree
        self._packed = None
        self._surfaces = [(np.ascontiguousarray(v, np.float64), np.asarray(n, np.float64), cKDTree(v))
                          for v, n in surfaces]
        self._reach = reach
        self._exact = exact
        self._rest = None if rest is None else np.array(rest, np.float64)
        self._last = None if rest is None else self._rest.copy()
        self._facing = None if facing is None else np.asarray(facing, np.float64)
        self._moved = moved
        if not self._transforms:
            self._transforms = [np.eye(4) for _ in surfaces]

    def state(self) -> dict[str, np.ndarray]:
        """The re-anchored planes (for saving a simulation exactly)."""
        out = {"local_point": self.local_point, "local_normal": self.local_normal, "bone": self.bone}
        if getattr(self, "_last", None) is not None:
            out["last"] = self._last
        return out

    def set_state(self, state: dict[str, np.ndarray]) -> None:
        self.local_point[...] = state["local_point"]
        self.local_normal[...] = state["local_normal"]
        self.bone[...] = state["bone"]
        if "last" in state and getattr(self, "_last", None) is not None:
            self._last[...] = state["last"]
        self._pose(None)

    def snapshot(self) -> None:
        """Make the current planes the ones :meth:`reset` returns to."""
        self._initial = (self.local_point.copy(), self.local_normal.copy(), self.bone.copy())

    def refresh(self, positions: np.ndarray, everything: bool = False) -> None:
        """Re-anchor the plane of every node that slid since its last anchoring at the nearest vertex of the
        nearest bone in the bones' current poses (once per frame): skin that slides along the bone keeps an
        accurate plane, and skin near the other bone (lips over the other jaw's teeth) is guarded from it.
        After :meth:`keep_own_bones`, only the node's own bone is considered (see there)."""
        if not self._surfaces:
            return
        if self._own is not None:
            self._refresh_own_bone(positions, everything)
            return
        if self._last is not None and _compiled_guards(self.backend) is not None:
            self._refresh_compiled(positions, everything)
            return
        all_x = positions[:, self.nodes]
        if self._last is None or everything:
            active = np.arange(len(self.nodes))
        else:
            step = all_x - self._last
            active = np.flatnonzero(np.einsum("ij,ij->j", step, step) > self._moved ** 2)
        if not len(active):
            return
        x = all_x[:, active].T
        facing = None if self._facing is None else self._facing[:, active].T
        best = np.full(len(active), np.inf)
        owner = self.bone[active].copy()
        local_point = self.local_point[:, active].T.copy()
        local_normal = self.local_normal[:, active].T.copy()
        for bone, ((verts, normals, tree), matrix) in enumerate(zip(self._surfaces, self._transforms)):
            rot, shift = matrix[:3, :3], matrix[:3, 3]
            local = (x - shift) @ rot                       # into the bone's rest frame
            dist, idx = self._nearest_vertices(bone, local)
            found = np.isfinite(dist) & (dist < best)
            idx = np.minimum(idx, len(verts) - 1)
            if facing is not None:
                found &= np.einsum("ij,ij->i", normals[idx] @ rot.T, facing) > 0.2
            best[found] = dist[found]
            owner[found] = bone
            local_point[found] = verts[idx[found]]
            local_normal[found] = normals[idx[found]]
        if self._exact is not None:
            # a nearest *vertex* plane is crude at folds: nodes it finds close get the true closest point
            for bone in range(len(self._surfaces)):
                rot, shift = self._transforms[bone][:3, :3], self._transforms[bone][:3, 3]
                local = (x - shift) @ rot
                height = np.einsum("ij,ij->i", local - local_point, local_normal)
                pick = np.flatnonzero((owner == bone) & np.isfinite(best)
                                      & (height < self.clearance[active] + 0.001))
                if not len(pick):
                    continue
                p_exact, n_exact = self._exact(bone, local[pick])
                ok = np.ones(len(pick), bool) if facing is None else \
                    np.einsum("ij,ij->i", n_exact @ rot.T, facing[pick]) > 0.2
                local_point[pick[ok]] = p_exact[ok]
                local_normal[pick[ok]] = n_exact[ok]
        self.local_point[:, active] = local_point.T
        self.local_normal[:, active] = local_normal.T
        self.bone[active] = owner
        if self._last is not None:
            self._last[:, active] = x.T
        self._pose(active)

    def _bone_frames(self) -> tuple[np.ndarray, np.ndarray]:
        """The bones' current rotations (B, 3, 3) and translations (B, 3), as the compiled loops take them."""
        return (np.ascontiguousarray([m[:3, :3] for m in self._transforms]),
                np.ascontiguousarray([m[:3, 3] for m in self._transforms]))

    def _refresh_compiled(self, positions: np.ndarray, everything: bool) -> None:
        """:meth:`refresh` in the compiled loops of :mod:`.anchor_kernel` (same nodes, vertices and planes
        as the numpy code above, which stays the reference); the exact closest points stay in numpy."""
        if self._packed is None:
            self._packed = anchor_kernel.pack_grids([(v, n) for v, n, _ in self._surfaces], self._reach)
        moved, nearest, pose = (kernel.compiled(anchor_kernel.moved_nodes),
                                kernel.compiled(anchor_kernel.nearest_bone_planes, anchor_kernel.nearest_in_bone),
                                kernel.compiled(anchor_kernel.pose_planes))
        x, active = np.empty((len(self.nodes), 3)), np.empty(len(self.nodes), np.int64)
        count = moved(positions, self.nodes, self._last, self._moved, everything, x, active)
        if not count:
            return
        rotations, shifts = self._bone_frames()
        grids = self._packed
        best, local_own = np.empty(count), np.empty((count, 3))
        facing = self._facing if self._facing is not None else np.zeros((3, 0))
        nearest(x, active, count, rotations, shifts, grids.vertices, grids.normals, grids.order,
                grids.starts, grids.cube_start, grids.origin, grids.dims, grids.cell, self._reach, facing,
                self._facing is not None, self.bone, self.local_point, self.local_normal, best, local_own)
        active = active[:count]
        if self._exact is not None:
            height = np.einsum("ij,ji->i", local_own - self.local_point[:, active].T, self.local_normal[:, active])
            close = np.isfinite(best) & (height < self.clearance[active] + 0.001)
            for bone, rotation in enumerate(rotations):
                pick = np.flatnonzero(close & (self.bone[active] == bone))
                if not len(pick):
                    continue
                p_exact, n_exact = self._exact(bone, local_own[pick])
                ok = np.ones(len(pick), bool) if self._facing is None else \
                    np.einsum("ij,ji->i", n_exact @ rotation.T, self._facing[:, active[pick]]) > 0.2
                self.local_point[:, active[pick[ok]]] = p_exact[ok].T
                self.local_normal[:, active[pick[ok]]] = n_exact[ok].T
        self._last[:, active] = x[active].T
        self._posed = True
        pose(active, count, self.bone, rotations, shifts, self.local_point, self.local_normal, self.point, self.normal)
        self._still = None

    def _nearest_vertices(self, bone: int, local: np.ndarray):
        """Nearest vertex of ``bone`` within reach of each point (K, 3), bone frame: ``(dist, index)``, inf and
        the vertex count where none is (the KD-tree; the compiled refresh searches the same in a grid)."""
        return self._surfaces[bone][2].query(local, distance_upper_bound=self._reach)

    def _refresh_own_bone(self, positions: np.ndarray, everything: bool) -> None:
        """:meth:`refresh` for :meth:`keep_own_bones`; ``_last`` holds node positions in their bone's frame."""
        if self._exact is None:
            return
        if self._last is not None and not everything and not self._may_have_moved(positions):
            self._posed = True                 # as after re-anchoring no node (the planes stay as they are)
            return
        all_x = positions[:, self.nodes]
        local = np.empty_like(all_x)
        for bone, matrix in enumerate(self._transforms):
            mine = self._own == bone
            local[:, mine] = matrix[:3, :3].T @ (all_x[:, mine] - matrix[:3, 3:4])    # into the bone's frame
        if self._last is None or everything:
            active = np.arange(len(self.nodes))
        else:
            step = local - self._last
            active = np.flatnonzero(np.einsum("ij,ij->j", step, step) > self._moved ** 2)
        for bone, matrix in enumerate(self._transforms):
            mine = active[self._own[active] == bone]
            if not len(mine):
                continue
            point, normal = self._exact(bone, local[:, mine].T)
            # a plane that would push the node's own rest place (its target when nothing pulls it) into the
            # bone is the wrong one (a node lagging behind its bone over a concave part of it)
            ok = np.einsum("ij,ij->i", self._rest[:, mine].T - point, normal) >= self.clearance[mine]
            if self._facing is not None:
                ok &= np.einsum("ij,ij->i", normal @ matrix[:3, :3].T, self._facing[:, mine].T) > 0.2
                if self._refuse is not None:
                    ok &= ~self._refuse(normal, self._facing[:, mine].T)
            self.local_point[:, mine[ok]], self.local_normal[:, mine[ok]] = point[ok].T, normal[ok].T
        if self._last is not None and len(active):
            self._last[:, active] = local[:, active]
        self._pose(active)

    def _may_have_moved(self, positions: np.ndarray) -> bool:
        """The compiled pre-test of :meth:`_refresh_own_bone`: False only when no node can have moved
        ``_moved`` in its bone's frame (a 1e-6 relative margin covers the rounding by which its loop and
        numpy's matrix product may differ), so skipping the exact test then changes nothing. A settle's
        later frames, where the skin barely moves, re-anchor no node in about two frames of three."""
        test = kernel.compiled(anchor_kernel.any_moved_on_own_bone)
        if test is None:
            return True
        rotations, shifts = self._bone_frames()
        return bool(test(positions, self.nodes, self._own, rotations, shifts, self._last,
                         self._moved * (1.0 - 1e-6)))

    def _still_planes(self, compute, start_point: np.ndarray, start_normal: np.ndarray):
        """``(still, point, normal)``: which planes do not move this frame and their slid plane, computed once
        a frame (the planes are final once the frame's refresh has run) for the compiled guard loop."""
        if self._still is None:
            count = len(self.nodes)
            still = np.empty(count, np.bool_)
            point, normal = np.empty((3, count)), np.empty((3, count))
            compute(self.point, self.normal, start_point, start_normal, still, point, normal)
            self._still = (still, point, normal)
        return self._still

    def penetration(self, positions: np.ndarray) -> np.ndarray:
        """How far each guarded node lies inside its clearance band (m, >= 0); ``positions`` is (3, N)."""
        x = positions[:, self.nodes]
        depth = self.clearance - np.einsum("ij,ij->j", x - self.point, self.normal)
        return np.maximum(depth, 0.0)

    def __call__(self, positions: np.ndarray, velocity: np.ndarray, fraction: float = 1.0) -> None:
        """Project escaped nodes back outside and remove their inward velocity (in place, (3, N))."""
        nodes = self.nodes
        start = getattr(self, "_start", None)
        compiled = _compiled_guards(self.backend)
        if compiled is not None and positions.flags.c_contiguous and velocity.flags.c_contiguous:
            interpolate = not (start is None or fraction >= 1.0)
            start_point, start_normal = start if interpolate else (self.point, self.normal)
            still = self._still_planes(compiled[2], start_point, start_normal) if interpolate else _NO_STILL
            compiled[0](positions, velocity, nodes, self.point, self.normal, start_point, start_normal,
                        interpolate, float(fraction), self.clearance, *still)
            return
        if start is None or fraction >= 1.0:
            point, normal = self.point, self.normal
        else:
            point = start[0] + fraction * (self.point - start[0])
            normal = start[1] + fraction * (self.normal - start[1])
            normal /= np.maximum(np.sqrt(np.einsum("ij,ij->j", normal, normal)), 1e-12)
        x = positions[:, nodes]
        depth = self._depth
        np.einsum("ij,ij->j", x - point, normal, out=depth)
        np.subtract(self.clearance, depth, out=depth)
        np.maximum(depth, 0.0, out=depth)
        positions[:, nodes] = x + normal * depth
        v = velocity[:, nodes]
        inward = np.minimum(np.einsum("ij,ij->j", v, normal), 0.0) * (depth > 0)
        velocity[:, nodes] = v - normal * inward


@dataclass(frozen=True)
class CapBulge:
    """More radius for a :class:`SphereGuard` over a cap looking along -Y (the cornea over the iris, 3.1.2
    "Eyes"): ``scale * peak * cos(angle * 90 / cap_deg)^2`` at ``angle`` degrees from -Y inside the cap, 0
    beyond, plus a per-node ``sag`` (m; (K,) or a number). A plain description rather than a function, so
    the guard's compiled loop (:mod:`.kernel`) can evaluate it too."""
    scale: float
    peak: float
    cap_deg: float
    sag: np.ndarray | float = 0.0

    def __call__(self, unit: np.ndarray) -> np.ndarray:
        """Extra radius (m) in the unit directions (3, K) from the centre."""
        angle = np.degrees(np.arccos(np.clip(-unit[1], -1.0, 1.0)))
        return self.scale * np.where(angle < self.cap_deg,
                                     self.peak * np.cos(np.radians(angle) * 90 / self.cap_deg) ** 2, 0.0) + self.sag


class SphereGuard:
    """Keeps ``nodes`` at least ``radius`` from ``centre`` (lids over the eyeball, 3.1.2 "Eyes").

    ``extra(unit)`` (optional): more radius (m) in the unit directions (3, K) from the centre, e.g. the
    cornea's bulge (a :class:`CapBulge`, which the compiled loop handles too; any other callable runs the
    numpy path); with ``rest`` (3, K) node positions a node that lies inside at rest is let off by what
    it lacks there, less and less as it moves away from rest (fully guarded ``fade`` m away), so the guard
    never pushes a node at rest yet a lid that closes over the cornea stays on it."""

    def __init__(self, nodes: np.ndarray, centre: np.ndarray, radius: float, extra=None,
                 rest: np.ndarray | None = None, fade: float = 0.0015) -> None:
        self.nodes = np.ascontiguousarray(nodes, np.int64)
        self.centre = np.asarray(centre, np.float64).reshape(3, 1)
        self.radius = float(radius)
        self.extra = extra
        self.fade = float(fade)
        self.slack = np.zeros(len(self.nodes))
        self.rest = None
        self._sag = None
        if rest is not None and len(self.nodes):
            self.rest = np.asarray(rest, np.float64)
            d = self.rest - self.centre
            dist = np.sqrt(np.einsum("ij,ij->j", d, d))
            wanted = self.radius + (extra(d / np.maximum(dist, 1e-12)) if extra is not None else 0.0)
            self.slack = np.maximum(wanted - dist, 0.0)

    #: "auto", "numba" or "numpy", as for :class:`BoneHalfSpaceGuard`
    backend = "auto"

    def __call__(self, positions: np.ndarray, velocity: np.ndarray, fraction: float = 1.0) -> None:
        plain = self.extra is None or isinstance(self.extra, CapBulge)
        compiled = _compiled_guards(self.backend) if plain else None
        if compiled is not None and positions.flags.c_contiguous:
            bulge = self.extra if self.extra is not None else CapBulge(0.0, 0.0, 0.0)
            if self._sag is None or self._sag[0] is not bulge:
                self._sag = (bulge, np.ascontiguousarray(np.broadcast_to(np.asarray(bulge.sag, np.float64),
                                                                         self.nodes.shape)))
            rest = self.rest if self.rest is not None else np.zeros((3, 0))
            compiled[1](positions, self.nodes, self.centre[:, 0], self.radius, self.extra is not None,
                        float(bulge.scale), float(bulge.peak), float(bulge.cap_deg), self._sag[1],
                        self.rest is not None, rest, self.slack, self.fade)
            return
        x = positions[:, self.nodes]
        d = x - self.centre
        dist = np.sqrt(np.einsum("ij,ij->j", d, d))
        radius = self.radius
        if self.extra is not None:
            radius = radius + self.extra(d / np.maximum(dist, 1e-12))
        if self.rest is not None:
            moved = np.sqrt(np.einsum("ij,ij->j", x - self.rest, x - self.rest))
            radius = radius - self.slack * np.clip(1.0 - moved / self.fade, 0.0, 1.0)
        scale = np.maximum(radius / np.maximum(dist, 1e-12), 1.0)
        positions[:, self.nodes] = self.centre + d * scale
