# SPDX-License-Identifier: GPL-3.0-or-later
"""Direct parameters (thesis 3.1.1 and 3.1.2 "Eyes, Teeth, Tongue"): the jaw's four degrees of freedom
("pitch and yaw as well as horizontal and vertical position") about the temporomandibular joint, eye gaze,
eyelids that close and follow the gaze, and a rigid tongue. Everything returns 4x4 matrices in head
coordinates or, for the lids (which are part of the skin), rotated rest positions of the lid nodes.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..physics import kernel
from . import lid_kernel
from .organs import CORNEA_BULGE, CORNEA_DEG, cornea_bulge

__all__ = ["JawLimits", "rotation", "jaw_matrix", "opening_glide", "eye_matrix", "tongue_matrix", "LidRig",
           "eye_elevation", "EYE_YAW_DEG", "EYE_PITCH_DEG"]

EYE_YAW_DEG = 35.0       # gaze range left/right at eye_yaw = +-1
EYE_PITCH_DEG = 25.0     # gaze range up/down at eye_pitch = +-1


def rotation(axis: np.ndarray, angle: float, centre: np.ndarray | None = None) -> np.ndarray:
    """4x4 rotation by ``angle`` (radians, right hand) about ``axis`` through ``centre`` (Rodrigues,
    ``I + sin K + (1 - cos) K^2``, written out: a frame builds a dozen of these, numpy's small-array calls
    cost more than the arithmetic)."""
    x, y, z = (float(v) for v in axis)
    size = math.sqrt(x * x + y * y + z * z)
    x, y, z = x / size, y / size, z / size
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    out = np.array([[c + t * x * x, t * x * y - s * z, t * x * z + s * y, 0.0],
                    [t * x * y + s * z, c + t * y * y, t * y * z - s * x, 0.0],
                    [t * x * z - s * y, t * y * z + s * x, c + t * z * z, 0.0],
                    [0.0, 0.0, 0.0, 1.0]])
    if centre is not None:
        centre = np.asarray(centre, np.float64)
        out[:3, 3] = centre - out[:3, :3] @ centre
    return out


def translation(offset: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, 3] = offset
    return out


@dataclass(frozen=True)
class JawLimits:
    """Ranges of the jaw's direct parameters (3.1.1: pitch, yaw, horizontal and vertical position)."""
    open_deg: float = 26.0          # jaw_open = 1: rotation about the condyles ...
    gape: float = 0.0455            # ... plus the condylar glide: the lower incisors travel this far
    yaw_deg: float = 6.0            # jaw_yaw = +-1: ~9 mm sideways at the chin
    forward: float = 0.006          # jaw_forward = 1: protrusion (m)
    backward: float = 0.002         # jaw_forward = -1: retrusion (m)
    drop: float = 0.005             # jaw_drop = 1: straight down (m)
    lift: float = 0.001             # jaw_drop = -1: up (m)


def opening_glide(pivot: np.ndarray, axis: np.ndarray, incisor: np.ndarray,
                  limits: JawLimits = JawLimits()) -> np.ndarray:
    """Translation that accompanies full opening (3.1.1: "jaw motion involves a combination of rotation and
    translation"): the condyles glide forward and down along the articular eminence so that the lower
    incisors move mostly down (``limits.gape`` metres, 15 deg behind the vertical), whatever the proportions
    of the head; rotation + glide amount to a rotation about a centre well below the condyles."""
    rotate = rotation(axis, np.radians(limits.open_deg), pivot)
    direction = np.array([0.0, np.sin(np.radians(15.0)), -np.cos(np.radians(15.0))])
    wanted = incisor + limits.gape * direction
    return wanted - (rotate[:3, :3] @ incisor + rotate[:3, 3])


def jaw_matrix(pivot: np.ndarray, axis: np.ndarray, jaw_open: float, jaw_yaw: float, jaw_forward: float,
               jaw_drop: float, limits: JawLimits = JawLimits(), glide: np.ndarray | None = None) -> np.ndarray:
    """Jaw pose: pitch about the TMJ axis with the condylar ``glide`` (see :func:`opening_glide`, scaled by
    the opening), yaw about the vertical through the TMJ midpoint (+ moves the chin to the character's
    left, +X), then translation (forward is -Y, drop is -Z). Parameters are clamped to their ranges."""
    jaw_open = float(np.clip(jaw_open, 0.0, 1.0))
    jaw_yaw = float(np.clip(jaw_yaw, -1.0, 1.0))
    jaw_forward = float(np.clip(jaw_forward, -1.0, 1.0))
    jaw_drop = float(np.clip(jaw_drop, -1.0, 1.0))
    pitch = rotation(axis, np.radians(limits.open_deg) * jaw_open, pivot)
    yaw = rotation(np.array([0.0, 0.0, 1.0]), np.radians(limits.yaw_deg) * jaw_yaw, pivot)
    forward = (limits.forward if jaw_forward > 0 else limits.backward) * jaw_forward
    down = (limits.drop if jaw_drop > 0 else limits.lift) * jaw_drop
    shift = np.array([0.0, -forward, -down])
    if glide is not None:
        shift = shift + np.asarray(glide, np.float64) * jaw_open
    return translation(shift) @ yaw @ pitch


def eye_matrix(centre: np.ndarray, eye_yaw: float, eye_pitch: float) -> np.ndarray:
    """Gaze: + yaw looks to the character's left (+X), + pitch looks up; about the eyeball centre."""
    yaw = np.radians(EYE_YAW_DEG) * float(np.clip(eye_yaw, -1, 1))
    pitch = np.radians(EYE_PITCH_DEG) * float(np.clip(eye_pitch, -1, 1))
    return rotation(np.array([0.0, 0.0, 1.0]), yaw, centre) @ rotation(np.array([1.0, 0.0, 0.0]), -pitch, centre)


def tongue_matrix(jaw: np.ndarray, pivot: np.ndarray, tip_up: float, back: float, out: float,
                  tip_up_deg: float = 35.0, back_m: float = 0.010, out_m: float = 0.024,
                  out_lift: float = 0.0045) -> np.ndarray:
    """Rigid tongue carried by the jaw (3.1.2 "Eyes, Teeth, Tongue"): tip raised about ``pivot`` (mid-tongue,
    :func:`.organs.tongue_in_arch`) towards the alveolar ridge, pulled back, stuck out. Sticking out first lifts the tongue (``out_lift``,
    most of it over the first 30 % of the travel) so that it slides out over the lower incisors rather
    than through them."""
    tip_up, back, out = (float(np.clip(v, 0.0, 1.0)) for v in (tip_up, back, out))
    raise_tip = rotation(np.array([1.0, 0.0, 0.0]), -np.radians(tip_up_deg) * tip_up, pivot)
    lift = out_lift * (1.0 - (1.0 - min(out / 0.3, 1.0)) ** 2)
    shift = translation(np.array([0.0, back_m * back - out_m * out, lift]))
    return jaw @ shift @ raise_tip


def eye_elevation(points: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Angle above the forward (-Y) direction about the eye's horizontal (X) axis."""
    d = points - centre
    return np.arctan2(d[:, 2], -d[:, 1])


CANTHUS_RADIUS = 0.0035     # m around each canthus within which the lid skin turns less, not at all at it
# on a fitted head (an artist's mesh: nodes 1-2 mm from the canthus node, which is often the lowest corner of
# its triangles) the tie reaches further: within 3.5 mm the lid weight rose from 0.14 on MakeHuman's canthus
# to 0.56 on a node 1.2 mm away, which turned down past it in eyeLookDown (4.0-4.75 mm all fold nothing there)
FITTED_CANTHUS_RADIUS = 0.0045


class LidRig:
    """Eyelids as part of the skin (thesis 3.1.2: "eyes together with the animatable eyelids").

    Lid nodes rotate about the eyeball's horizontal axis, so they slide over the eyeball without entering
    it. The upper margin closes down to a meeting line a quarter of the way up the fissure, the lower
    margin rises to it; both follow the gaze pitch (upper 70 %, lower 40 %). Lid skin further from the
    margin rotates less (weight falling to 0 over ``falloff``), so the lid skin stretches smoothly up to
    the brow and down to the cheek. The canthi are tied to the orbit: within ``CANTHUS_RADIUS`` of them
    (``FITTED_CANTHUS_RADIUS`` on a fitted head) the lids turn less and less, and where the fissure narrows
    towards them both lids follow the gaze alike, so the corner's small triangles do not fold over when the
    eye closes or looks down.
    """
    MEETING = 0.25                  # fraction of the fissure the lower lid travels when closing
    FOLLOW_UPPER, FOLLOW_LOWER = 0.7, 0.4
    RAISE = 0.16                    # rad the levator lifts the upper margin (~2 mm on the eyeball, AU5)
    SQUEEZE = 0.14                  # rad the orbicularis oculi lifts the lower margin (~1.5 mm, AU6/AU7)
    OVERLAP = 0.03                  # rad the upper margin closes past the meeting line: closed means closed

    def __init__(self, centre: np.ndarray, nodes: np.ndarray, upper_margin: np.ndarray,
                 lower_margin: np.ndarray, falloff_upper: float = 0.009, falloff_lower: float = 0.006,
                 radius: float = 0.022, eyeball_radius: float = 0.012, surface: np.ndarray | None = None,
                 setup_radius: float | None = None, fade: np.ndarray | None = None,
                 side: np.ndarray | None = None) -> None:
        """``setup_radius``: set the rig up only on the nodes that close to the eye centre (the others get
        weight 0; a large artist's mesh need not be searched whole); ``fade`` (N,): a per-node factor on the
        weight (0 off the face of a fitted head); ``side`` (N,): +1 / -1 for nodes known to belong to the
        upper / lower lid (the skin's lid groups; the margin's inner strip by the canthi lies lower than
        its elevation test expects), 0 to decide by elevation."""
        self.centre = np.asarray(centre, np.float64)
        #: rad past the meeting line the upper margin closes (a fitted head's coarse margins need more:
        #: :func:`.mesh_template._closing_overlap`)
        self.overlap = self.OVERLAP
        self.clear_radius = eyeball_radius + 0.0005
        self.eyeball_radius = eyeball_radius
        nodes = np.asarray(nodes, np.float64)
        self.surface = np.ones(len(nodes), bool) if surface is None else np.asarray(surface, bool)
        up, low = np.asarray(upper_margin, np.float64), np.asarray(lower_margin, np.float64)
        self._ux, self._ue = self._curve(up)
        self._lx, self._le = self._curve(low)
        select = (np.arange(len(nodes)) if setup_radius is None
                  else np.flatnonzero(np.linalg.norm(nodes - self.centre, axis=1) < setup_radius))
        theta_u, theta_l, is_upper, weight = self._setup(nodes[select], up, low, falloff_upper, falloff_lower,
                                                         radius)
        self.theta_u, self.theta_l = np.zeros(len(nodes)), np.zeros(len(nodes))
        self.is_upper, self.weight = np.zeros(len(nodes), bool), np.zeros(len(nodes))
        self.theta_u[select], self.theta_l[select] = theta_u, theta_l
        self.is_upper[select], self.weight[select] = is_upper, weight
        if side is not None:
            self.is_upper = np.where(np.asarray(side) > 0, True, np.where(np.asarray(side) < 0, False, self.is_upper))
        # how open the fissure is at each node's x, 0 at the canthi: towards the corners, where the two
        # lids meet in tiny triangles, both lids move alike (see :meth:`rotations`)
        # the canthi are tied to the orbit (the canthal tendons): lid skin right at them does not turn
        canthi = np.vstack([up[[np.argmin(up[:, 0]), np.argmax(up[:, 0])]], low[[np.argmin(low[:, 0]),
                                                                                  np.argmax(low[:, 0])]]])
        reach = CANTHUS_RADIUS if fade is None else FITTED_CANTHUS_RADIUS
        near = np.min(np.linalg.norm(nodes[:, None] - canthi[None], axis=2), axis=1) / reach
        near = np.clip(near, 0.0, 1.0)
        self.weight = self.weight * near * near * (3 - 2 * near)
        # how firmly the canthal tendons hold each node (1 on a canthus, 0 from the radius on): on a
        # fitted head only (``fade`` given), whose artist's mesh may have slivers there (SOMA: a 0.2 mm edge)
        self.canthus_tie = np.zeros(len(nodes))
        aperture = np.maximum(self.theta_u - self.theta_l, 0.0)
        t = np.clip(aperture / max(0.5 * float(aperture[select].max(initial=0.0)), 1e-9), 0.0, 1.0)
        self.open_share = t * t * (3 - 2 * t)
        if fade is not None:
            self.weight = self.weight * np.asarray(fade, np.float64)
            self.canthus_tie = (1.0 - near * near * (3 - 2 * near)) * np.asarray(fade, np.float64)
        self.index = np.flatnonzero(self.weight > 0)

    def _setup(self, nodes: np.ndarray, up: np.ndarray, low: np.ndarray, falloff_upper: float,
               falloff_lower: float, radius: float):
        """Per node: the margins' rest elevations above it, which lid it belongs to, and its weight."""
        x = nodes[:, 0]
        # beyond the canthi both margins meet: clamp to the corner elevation (np.interp does)
        theta_u = np.interp(x, self._ux, self._ue)
        theta_l = np.interp(x, self._lx, self._le)
        elevation = eye_elevation(nodes, self.centre)
        near = np.linalg.norm(nodes - self.centre, axis=1) < radius
        # a node on a canthus, where both margins meet, belongs to the lower lid (it stays when the lid
        # closes): an exact tie must not be decided by the last bit of the elementwise trigonometry, which
        # numpy's vectorised loops compute differently for an element that falls in a scalar head or tail
        # (where depends on the array's address: the 10k head's corner node changed lid from run to run)
        is_upper = elevation > 0.5 * (theta_u + theta_l) + 1e-9
        d_up = np.min(np.linalg.norm(nodes[:, None] - up[None], axis=2), axis=1)
        d_low = np.min(np.linalg.norm(nodes[:, None] - low[None], axis=2), axis=1)
        distance = np.where(is_upper, d_up, d_low)
        falloff = np.where(is_upper, falloff_upper, falloff_lower)
        t = np.clip(1.0 - distance / falloff, 0.0, 1.0)
        return theta_u, theta_l, is_upper, np.where(near, t * t * (3 - 2 * t), 0.0)        # smoothstep

    def _curve(self, margin: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Margin elevation as a function of x (sorted samples for ``np.interp``)."""
        order = np.argsort(margin[:, 0], kind="stable")
        return margin[order, 0], eye_elevation(margin[order], self.centre)

    def rotations(self, close: float, pitch: float, lift: float = 0.0, squeeze: float = 0.0,
                  nodes: np.ndarray | None = None) -> np.ndarray:
        """Rotation angle (radians, + = up) of every node (or of ``nodes`` only) for lid closure ``close``,
        gaze ``pitch``, upper-lid raise ``lift`` (levator palpebrae superioris, FACS AU5: :data:`RAISE` at 1)
        and the orbicularis oculi's contraction ``squeeze``, which pushes the lower lid up (the cheek raiser
        and lid tightener, AU6/AU7: :data:`SQUEEZE` at 1)."""
        pick = slice(None) if nodes is None else nodes
        theta_u, theta_l = self.theta_u[pick], self.theta_l[pick]
        close = float(np.clip(close, 0.0, 1.0))
        gaze = np.radians(EYE_PITCH_DEG) * float(np.clip(pitch, -1.0, 1.0))
        t = self.open_share[pick]        # at the canthi both lids follow the gaze alike and nothing else
        corner = 0.5 * (self.FOLLOW_UPPER + self.FOLLOW_LOWER)
        upper = (theta_u + (self.FOLLOW_UPPER * t + corner * (1 - t)) * gaze
                 + self.RAISE * float(np.clip(lift, 0.0, 1.0)) * t)
        lower = (theta_l + (self.FOLLOW_LOWER * t + corner * (1 - t)) * gaze
                 + self.SQUEEZE * float(np.clip(squeeze, 0.0, 1.0)) * t)
        aperture = np.maximum(upper - lower, 0.0)
        meeting = lower + self.MEETING * aperture
        upper_final = upper + close * (meeting - self.overlap * t - upper)   # closed means closed
        lower_final = lower + close * (meeting - lower)
        delta = np.where(self.is_upper[pick], upper_final - theta_u, lower_final - theta_l)
        return self.weight[pick] * delta

    def rotate(self, rest: np.ndarray, close: float, pitch: float, lift: float = 0.0,
               squeeze: float = 0.0) -> np.ndarray:
        """Rest positions of all nodes (N,3) rotated by :meth:`rotations` about the eye's X axis."""
        out = rest.copy()
        out[self.index] = self.rotate_lid(rest[self.index], close, pitch, lift, squeeze)
        return out

    def rotate_lid(self, lid_rest: np.ndarray, close: float, pitch: float, lift: float = 0.0,
                   squeeze: float = 0.0) -> np.ndarray:
        """:meth:`rotate` for the lid's own nodes only: their rest positions (len(index), 3) in, rotated out
        (what a frame needs; the other nodes do not move)."""
        index = self.index
        if (rotate := kernel.compiled(lid_kernel.rotate_lid_nodes)) is not None:
            out = np.empty_like(lid_rest, np.float64)
            rotate(np.ascontiguousarray(lid_rest, np.float64), self.centre, self.theta_u[index], self.theta_l[index],
                   self.open_share[index], self.weight[index], self.is_upper[index],
                   self.surface[index].astype(np.float64), float(np.clip(close, 0.0, 1.0)),
                   np.radians(EYE_PITCH_DEG) * float(np.clip(pitch, -1.0, 1.0)), float(np.clip(lift, 0.0, 1.0)),
                   float(np.clip(squeeze, 0.0, 1.0)), self.FOLLOW_UPPER, self.FOLLOW_LOWER, self.RAISE, self.SQUEEZE,
                   self.MEETING, self.overlap, self.clear_radius, self.eyeball_radius, CORNEA_DEG, CORNEA_BULGE, out)
            return out
        angle = self.rotations(close, pitch, lift, squeeze, index)
        d = lid_rest - self.centre
        c, s = np.cos(angle), np.sin(angle)
        # elevation +a about X with forward = -Y: (y, z) -> (y cos a + z sin a, z cos a - y sin a)
        out = lid_rest.copy()
        out[:, 1] = self.centre[1] + d[:, 1] * c + d[:, 2] * s
        out[:, 2] = self.centre[2] + d[:, 2] * c - d[:, 1] * s
        # a lid sliding down over the cornea must stay outside the eyeball: lift moving surface nodes that
        # the canonical (flat) lid puts inside the sphere, in proportion to how far they have turned
        moved = out - self.centre
        radius = np.linalg.norm(moved, axis=1)
        lift = np.clip(np.abs(angle) / 0.06, 0.0, 1.0) * self.surface[index]
        ahead = np.degrees(np.arccos(np.clip(-moved[:, 1] / np.maximum(radius, 1e-12), -1.0, 1.0)))
        clear = self.clear_radius + self.eyeball_radius * cornea_bulge(ahead)    # over the cornea too
        new_radius = radius + lift * np.maximum(clear - radius, 0.0)
        return self.centre + moved * (new_radius / np.maximum(radius, 1e-12))[:, None]
