# SPDX-License-Identifier: GPL-3.0-or-later
"""The thumb resting on the curled fingers, beyond the thesis (its hand, 6.2.1-6.2.2, has no collisions; its
future work, 6.2.5, asks for them).

Why: in a fist the thenar muscles press the thumb onto the fingers, and the fingers push back. Without that
push only the extensor pollicis brevis (Table A.1: 46 N x 3 mm) extends the thumb's MCP joint against the
7 mm flexing arms of opponens and adductor pollicis, so a free thumb held about 0.1 of thenar contraction and
the thenar eminence could not swell (Fig. 6.18; 0.6 mm of skin lift in the fist). With the fingers as a stop
the thumb's flexion is held where it meets them, as a joint limit holds it (Eq. 6.7 with Table 6.4).

After each frame of the pseudo-muscle dynamics, every sample of the thumb's proximal and distal phalanx axes
must lie at least the two bones' skin radii (``radii``: the median distance of each bone's own skin nodes from
its axis, :func:`.crease.bone_radii`; 15-19 mm summed) from every sample of the middle and ring fingers'
proximal and middle phalanx axes, so the thumb rests on the fingers' skin (before this contact the fist's thumb
axes lay 9.6 mm from the fingers'). The index finger and the distal phalanges are left out: a tip pinch
presses the thumb pad into the curled index finger, which this contact would push apart. Where a sample is
nearer, the thumb's CMC flexion and abduction and its MCP and IP flexion turn by the smallest amounts that
restore it (linearised: a sample moves by ``w x (p - c) dtheta`` for a DOF turning about ``w`` through its
joint centre ``c``), within the Table 6.4 limits, a few sweeps per frame, and the thumb's speed into the
fingers is removed (as at a joint limit). A sample on the palm side of the phalanx it meets is inside the
curl and is pushed out to the back of that phalanx (the outside of the fist), not further into the palm. While
the thumb touches (within ``STICK``), its angles are held unless it moves off the fingers (sticking friction),
so the thenar muscles' push does not slide it off. Only the thumb moves: the fingers are curled by the long
flexors, far stronger.

The contact is continuous: a frame's motion is checked along its way, not only where it ends. The thumb's
inertia is small (Eq. 6.8) against the thenar muscles' torque, so in one 1/30 s frame a held thumb (at rest
every frame) could turn 40-50 degrees; checked only at the end position, the squeeze of the showcase motion
(:mod:`.motion`) carried it right through the curled fingers to its CMC limits in one frame (tunnelling: the
end position lay past the fingers, 8 mm clear of them on the palm side, so nothing pushed it back) and back
out 12 frames later. Now, when a thumb or finger sample travels more than ``SWEPT_STEP`` (a quarter of the
contact distance) relative to the other over a frame, the motion from the frame's start angles to its end
angles (straight in joint space, fingers and thumb together) is checked every ``SWEPT_STEP``; at the first
check where a thumb sample comes nearer a finger than its contact distance (or than it started, if it
started nearer), the first touch is found by bisection and the thumb's DOFs are put there with their speed
removed: the fingers stop the thumb as a joint limit does (Eq. 6.7 with Table 6.4: the angle is held at the
stop and the speed into it dropped). The usual contact resolution then runs from there. A frame whose
samples travel less than ``SWEPT_STEP`` is checked at its end only, as before (a sample cannot cross a
15-19 mm contact zone in one such step), and so is one that starts farther from every finger than twice its
largest travel (a margin for the arc a turning sample takes against its chord).
Deterministic; ``enabled = False`` leaves the muscles alone.
"""
from __future__ import annotations

import numpy as np

from .contact import turn_apart
from .pseudo import PseudoMuscles
from .skeleton import Skeleton, rotation_matrices

__all__ = ["ThumbContact", "DISTANCE"]

DISTANCE = 0.0160         # m between the thumb's and a finger's phalanx axes when no skin radii are given
FINGER_BONES = (("middle", "proximal"), ("middle", "intermediate"), ("ring", "proximal"),
                ("ring", "intermediate"))
THUMB = ("thumb-phalanx-proximal", "thumb-phalanx-distal")
DOFS = (("thumb-metacarpal", "flexion"), ("thumb-metacarpal", "abduction"),
        ("thumb-phalanx-proximal", "flexion"), ("thumb-phalanx-distal", "flexion"))
SWEEPS = 4
TOLERANCE = 2e-4          # m of shortfall left alone
MAX_TURN = np.radians(6.0)
STICK = 0.001             # m: a thumb this near its contact distance is touching (sticking friction)
RELEASE = 0.003           # m: a held thumb stays held within this (the fingers settling under it part by ~0.1 mm)
SWEPT_STEP = 0.004        # m a thumb or finger sample may travel between two contact checks along a frame's motion
BISECTIONS = 5
HELD_ARRAYS = ("thumb_held_angles", "thumb_held_gaps", "thumb_held_pressing")   # the hold, in a saved rig


def _points(skeleton: Skeleton, bones: list[int], samples: int) -> tuple[np.ndarray, np.ndarray]:
    s = np.linspace(0.0, 1.0, samples)[:, None]
    rest = [skeleton.position[b] + s * (skeleton.tail[b] - skeleton.position[b]) for b in bones]
    return np.concatenate(rest), np.repeat(bones, samples)


class ThumbContact:
    """Keeps the thumb's phalanges out of the curled fingers by its own flexion DOFs (module docstring)."""

    def __init__(self, skeleton: Skeleton, pseudo: PseudoMuscles, radii: np.ndarray | None = None, samples: int = 6):
        self.skeleton, self.pseudo, self.enabled = skeleton, pseudo, True
        thumb = [skeleton.index[b] for b in THUMB]
        fingers = [skeleton.index[f"{f}-finger-phalanx-{p}"] for f, p in FINGER_BONES]
        self.rest, self.owner = _points(skeleton, thumb, samples)
        self.finger_rest, self.finger_owner = _points(skeleton, fingers, samples)
        # (thumb samples, finger samples) contact distance: the two bones' skin radii (skin on skin), or DISTANCE
        radii = np.full(len(skeleton.names), DISTANCE / 2) if radii is None else np.asarray(radii, np.float64)
        self.distance = radii[self.owner][:, None] + radii[self.finger_owner][None, :]
        self.dofs = np.array([skeleton.dof(b, k) for b, k in DOFS])
        self.bones = np.array([skeleton.index[b] for b, _ in DOFS])
        self.signs = np.array([skeleton.dofs[k].sign for k in self.dofs])
        # every DOF of the thumb's bones (the CMC's rotation and the MCP's abduction too), held while it sticks
        self.held_dofs = np.array(sorted(k for (bone, _), k in skeleton.dof_index.items()
                                         if bone.startswith("thumb-")))
        self.flexion = skeleton.dof("thumb-metacarpal", "flexion")
        # which samples each DOF carries: every DOF at or above the sample's bone in the thumb's chain
        self.moves = np.array([[b in skeleton.chain_below(int(bone)) for b in self.owner] for bone in self.bones])
        self._held = None
        # each finger sample's palmar direction at rest (its bone's tip moving as the bone flexes), for the
        # curl rule of :meth:`_rows`; distal phalanges (pads that a pinch meets) have none
        rest_t = skeleton.bone_transforms(np.zeros(skeleton.dof_count))
        palmar = np.zeros((len(skeleton.names), 3))
        for b in set(self.finger_owner.tolist()):
            if skeleton.names[b].endswith("distal"):
                continue
            q = np.zeros(skeleton.dof_count)
            q[skeleton.dof(skeleton.names[b], "flexion")] = 0.01
            tip = skeleton.bone_transforms(q)[b] @ np.r_[skeleton.tail[b], 1.0]
            move = tip[:3] - (rest_t[b] @ np.r_[skeleton.tail[b], 1.0])[:3]
            palmar[b] = move / np.linalg.norm(move)
        self.palmar = palmar[self.finger_owner]
        self.curl = np.linalg.norm(self.palmar, axis=1) > 0
        self._owners = np.concatenate([self.owner, self.finger_owner])
        self._rests = np.concatenate([self.rest, self.finger_rest])

    def _measure(self, transforms: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The thumb samples (S, 3), their offsets from the finger samples (S, F, 3) and distances (S, F)."""
        m = transforms[self._owners]
        posed = np.einsum("sij,sj->si", m[:, :3, :3], self._rests) + m[:, :3, 3]
        points, fingers = posed[:len(self.owner)], posed[len(self.owner):]
        between = points[:, None, :] - fingers[None, :, :]
        return points, between, np.sqrt(np.einsum("tfi,tfi->tf", between, between))

    def gaps(self, transforms: np.ndarray, measured=None) -> np.ndarray:
        """(S,) each thumb sample's clearance: its distance to a finger sample less their contact distance, at
        the nearest (m; negative inside the fingers)."""
        square = self._measure(transforms)[2] if measured is None else measured[2]
        return (square - self.distance).min(axis=1)

    def reset(self) -> None:
        self._held = None

    def state(self) -> dict[str, np.ndarray]:
        """The sticking hold as arrays named ``thumb_held_*`` (none while the thumb is free), for a saved rig."""
        if self._held is None:
            return {}
        return dict(zip(HELD_ARRAYS, self._held))

    def restore(self, arrays: dict[str, np.ndarray]) -> None:
        """Take back a hold saved by :meth:`state` (free when ``arrays`` holds none)."""
        self._held = (tuple(np.asarray(arrays[n], np.float64) for n in HELD_ARRAYS) if HELD_ARRAYS[0] in arrays
                      else None)

    def _axes(self, transforms: np.ndarray, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World axes (D, 3) of the DOFs (signed like them; a joint turns ``F Rx Ry Rz F^T``, :mod:`.skeleton`)
        and their joint centres (D, 3)."""
        sk = self.skeleton
        parents = sk.parent[self.bones]
        world = transforms[parents][:, :3, :3] @ sk.frame[self.bones]
        axes = world[:, :, 0].copy()                                    # flexion: the frame's x
        flex = rotation_matrices(np.array([[1.0, 0.0, 0.0]]), np.array([angles[self.flexion] * self.signs[0]]))[0]
        axes[1] = (world[1] @ flex)[:, 1]                               # CMC abduction: y after flexion
        centres = np.einsum("dij,dj->di", transforms[parents][:, :3, :3], sk.position[self.bones]) \
            + transforms[parents][:, :3, 3]
        return axes * self.signs[:, None], centres

    def _rows(self, transforms: np.ndarray, angles: np.ndarray, measured=None,
              margin: float = TOLERANCE) -> tuple[np.ndarray, np.ndarray]:
        """Shortfalls (R,) of the thumb samples nearer a finger than ``distance`` less ``margin`` and their
        Jacobian (R, D): how fast each one's clearance grows per radian of each DOF."""
        points, between, square = self._measure(transforms) if measured is None else measured
        nearest = np.argmin(square - self.distance, axis=1)
        rows = np.arange(len(points))
        gap, want = square[rows, nearest], self.distance[rows, nearest]
        self._clearance = gap - want
        close = np.flatnonzero(want - gap > margin)
        if len(close) == 0:
            return np.zeros(0), np.zeros((0, len(self.dofs)))
        normal = between[close, nearest[close]] / np.maximum(gap[close], 1e-9)[:, None]
        short = want[close] - gap[close]
        # a thumb sample on the palm side of a curled finger's proximal or middle phalanx is inside the curl:
        # pushed out to the back of that phalanx (the outside of the fist), not further into the palm
        f = nearest[close]
        m = transforms[self.finger_owner[f]]
        palmar = np.einsum("rij,rj->ri", m[:, :3, :3], self.palmar[f])
        depth = np.einsum("ri,ri->r", between[close, f], palmar)
        inside = self.curl[f] & (depth > 0)
        normal[inside] = -palmar[inside]
        short[inside] = want[close][inside] + depth[inside]
        axes, centres = self._axes(transforms, angles)
        lever = np.cross(axes[None, :, :], points[close][:, None, :] - centres[None, :, :])   # (R, D, 3)
        jac = np.einsum("rdi,ri->rd", lever, normal) * self.moves[:, close].T
        return short, jac

    def _stop_at_contact(self, before: np.ndarray, transforms: np.ndarray) -> np.ndarray:
        """Continuous contact (module docstring): along the frame's motion from the angles ``before`` to the
        current ones (straight in joint space), the thumb stops where a sample first meets the fingers."""
        sk, angles = self.skeleton, self.pseudo.angles
        start, end = self._measure(sk.bone_transforms(before)), self._measure(transforms)
        moved = end[1] - start[1]                       # each thumb sample's travel relative to each finger's
        travel = float(np.sqrt(np.einsum("tfi,tfi->tf", moved, moved).max()))
        steps = int(np.ceil(travel / SWEPT_STEP))
        clearance = start[2] - self.distance
        if steps <= 1 or float(clearance.min()) > 2.0 * travel:    # too far from the fingers to reach them
            return transforms
        floor = np.minimum(clearance.min(axis=1), 0.0) - TOLERANCE
        touching = lambda s: np.any(self.gaps(sk.bone_transforms(before + s * (angles - before))) < floor)
        reached = 0.0
        for k in range(1, steps + 1):
            if touching(k / steps):
                break
            reached = k / steps
        else:
            return transforms
        low, high = reached, k / steps                  # the first touch lies between: bisect for it
        for _ in range(BISECTIONS):
            middle = 0.5 * (low + high)
            low, high = (low, middle) if touching(middle) else (middle, high)
        thumb = self.held_dofs
        angles[thumb] = before[thumb] + low * (angles[thumb] - before[thumb])
        self.pseudo.velocity[thumb] = 0.0
        return sk.bone_transforms(angles)

    def resolve(self, transforms: np.ndarray, before: np.ndarray | None = None) -> np.ndarray:
        """Push the thumb out of the fingers (module docstring), at the bone ``transforms`` of the current
        angles, having stopped it where it first met them on its way from the angles ``before`` (the frame's
        start), if given; returns the transforms of the angles it leaves (the same array when the thumb did
        not move)."""
        pseudo, angles, dofs = self.pseudo, self.pseudo.angles, self.dofs
        if not self.enabled:
            return transforms
        if before is not None:
            transforms = self._stop_at_contact(np.asarray(before, np.float64), transforms)
        measured = None
        if self._held is not None:              # sticking: held unless every sample moved off the fingers
            held, before, pressing = self._held
            turn = angles[dofs] - held[np.searchsorted(self.held_dofs, dofs)]
            measured = self._measure(transforms)
            # a turn that presses a touching sample into the fingers at the held angles is stopped there too
            # when, over one frame, it carried the thumb right through them (a squeeze, :mod:`.motion`)
            if np.any(self.gaps(transforms, measured) < before - 1e-5) or \
                    np.any(pressing @ turn < -1e-5):
                angles[self.held_dofs] = held
                pseudo.velocity[self.held_dofs] = 0.0
                transforms, measured = self.skeleton.bone_transforms(angles), None
        moved, was_held = True, self._held is not None
        for _ in range(SWEEPS):
            shorts, jac = self._rows(transforms, angles, measured)
            measured, moved = None, False
            if len(shorts) == 0:
                break
            if not turn_apart(pseudo, dofs, shorts, jac, MAX_TURN):
                break
            transforms = self.skeleton.bone_transforms(angles)
            moved = True
        gaps = self.gaps(transforms) if moved else self._clearance
        self._held = None
        if -STICK < gaps.min() < (RELEASE if was_held else STICK):
            self._held = (angles[self.held_dofs].copy(), gaps, self._rows(transforms, angles, None, -RELEASE)[1])
        return transforms
