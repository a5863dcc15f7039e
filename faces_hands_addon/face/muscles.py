# SPDX-License-Identifier: GPL-3.0-or-later
"""Muscle deformation (thesis 3.1.2 "Muscles", "Properties", "Muscle Deformation").

Per frame, in the thesis' order:

1. *Active contraction*: "In the case of a linear muscle, the control points are constrained to follow the
   original course of the muscle" towards the fixed origin (a point at arc length ``s`` moves to
   ``s (1 - c k)`` along the rest polyline). "Sphincter muscles contract towards their center"; the
   orbicularis oris centre is shifted along the protrusion axis "gradually": fully for the innermost
   fibre, not at all for the outermost. *Rounding* (our reading of the shifted centre): once the centre
   lies in front of the teeth, the lips no longer rest on the dental arch, so the contracting ring also
   closes sideways. With contraction ``c`` and protrusion ``p > 0`` the horizontal shrink grows by
   ``c p rounding[0]`` and the inner fibres' lateral parts close vertically by up to ``c p rounding[1]``
   (most at the corners, none in the middle): the small rounded opening of /u/ (3.1.3). Bilabial
   closure (no protrusion) is unchanged.
2. *Jaw*: "muscles attached to the jaw are moved along by rotating their control points" (rows on the jaw).
3. *Connections*: "Muscle connections are preserved by restoring the original distance of the involved
   control points to their center ... the weighted average of the control points, where points belonging
   to a muscle with higher contraction value have an increased weight".
4. *Stretch*: the corrections spread into each muscle while its bone-fixed points stay ("the control
   points that attach to the bone as well as those that are pulled at by other muscles are kept fixed ...
   intermediate segments are elongated"): a small screened-Laplace solve on the grid, prefactored.
5. *Bulging and thinning*: "When muscles contract, they become thicker, and when they are stretched, they
   get thinner. For linear muscles, the center exhibits the highest amount of bulging, while sphincter
   muscles become thicker evenly"; the top surface moves along the muscle normal.

Everything is vectorised over a few hundred control points; the result is a displacement of every control
point relative to its bone-carried rest position, which the skin attachments follow.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .muscle_layout import ConnectionSpec, PlacedMuscle

__all__ = ["MuscleSystem", "MuscleState"]

CONNECTION_GAIN = 8.0        # weight of a control point = 1 + gain * contraction of its muscle
RETRACTED_OUTER = 0.5        # orbicularis oris pulled back: the outermost fibre travels this much of the innermost


@dataclass
class MuscleState:
    points: np.ndarray           # (P, 3) deformed control points (muscle centre line, incl. bulge)
    displacement: np.ndarray     # (P, 3) relative to the bone-carried rest position
    thickness: np.ndarray        # (P,) current thickness (m)


def _transform(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ matrix[:3, :3].T + matrix[:3, 3]


class MuscleSystem:
    """All muscles of a head as flat arrays (see the module docstring)."""

    def __init__(self, placed: list[PlacedMuscle], connections: list[ConnectionSpec],
                 mouth_axes: np.ndarray | None = None) -> None:
        self.names = [m.spec.name for m in placed]
        self.specs = [m.spec for m in placed]
        self.shapes = [m.shape for m in placed]
        sizes = [r * c for r, c in self.shapes]
        self.offsets = np.r_[0, np.cumsum(sizes)].astype(np.int64)
        self.rest = np.concatenate([m.points.reshape(-1, 3) for m in placed])
        self.normal = np.concatenate([m.normals.reshape(-1, 3) for m in placed])
        self.bone = np.concatenate([np.repeat(m.row_bone, m.shape[1]) for m in placed])
        #: how far the jaw carries each control point: its row's bone (0 skull, 1 jaw), or a fraction where
        #: the skin it moves is carried part way (the lips towards the mouth corners, :meth:`set_jaw_carry`)
        self.jaw_carry = self.bone.astype(np.float64)
        self.muscle_of_point = np.concatenate([np.full(s, i) for i, s in enumerate(sizes)])
        self.thickness_rest = np.concatenate([np.full(s, m.spec.thickness) for s, m in zip(sizes, placed)])
        # mouth frame (x: right -> left corner, y: protrusion axis reversed, z: up), rows are axes
        self.mouth_axes = np.eye(3) if mouth_axes is None else np.asarray(mouth_axes, np.float64)
        self._prepare_kinds(placed)
        self._prepare_cells()
        self._prepare_connections(placed, connections)
        self._prepare_propagation()

    # -- static preparation ----------------------------------------------------------------------
    def slice(self, index: int) -> slice:
        return slice(int(self.offsets[index]), int(self.offsets[index + 1]))

    def _prepare_kinds(self, placed: list[PlacedMuscle]) -> None:
        self.arclength, self.fibre_length, self.position_along = [], [], []
        for m in placed:
            pts = m.points
            rows, cols = m.shape
            seg = np.linalg.norm(np.diff(pts, axis=0), axis=-1)             # (R-1, C)
            s = np.vstack([np.zeros((1, cols)), np.cumsum(seg, axis=0)])    # (R, C)
            length = np.maximum(s[-1], 1e-9)
            self.arclength.append(s)
            self.fibre_length.append(length)
            self.position_along.append(s / length)
        self.centres = [None] * len(placed)
        self.fibre_squeeze = [None] * len(placed)

    def set_jaw_carry(self, carry: np.ndarray) -> None:
        """Per control point, the fraction (0..1) of the jaw's motion that carries it at rest."""
        self.jaw_carry = np.clip(np.asarray(carry, np.float64), 0.0, 1.0)

    def set_centres(self, centres: list[np.ndarray | None]) -> None:
        """Sphincter centres of contraction (head coordinates, rest pose), one per muscle or None."""
        self.centres = [None if c is None else np.asarray(c, np.float64) for c in centres]
        self.fibre_squeeze = []
        for index, (spec, centre) in enumerate(zip(self.specs, self.centres)):
            if spec.kind != "sphincter" or centre is None:
                self.fibre_squeeze.append(None)
                continue
            pts = self.rest[self.slice(index)].reshape(*self.shapes[index], 3)
            local = (pts - centre) @ self.mouth_axes.T if spec.group == "oris" else pts - centre
            # typical vertical offset of each fibre -> taper: outer fibres shrink less, never crossing
            reach = np.median(np.abs(local[..., 2]), axis=0) + 1e-4
            factor = (reach[0] / reach) ** spec.taper
            horizontal, vertical = spec.squeeze
            # rounding (module docstring): sideways shrink tapered on its own; the lateral closure is a
            # vertical squeeze, tapered like it, growing from the middle (0) to the corners (1) of each fibre
            sideways = spec.rounding[0] * (reach[0] / reach) ** spec.rounding_taper
            half_width = np.maximum(np.abs(local[..., 0]).max(axis=0), 1e-4)
            lateral = np.clip(np.abs(local[..., 0]) / half_width, 0.0, 1.0) ** 2          # (R, C)
            self.fibre_squeeze.append((horizontal * factor, vertical * factor, sideways,
                                       spec.rounding[1] * factor * lateral))

    def _prepare_cells(self) -> None:
        cells, owner = [], []
        for index, (rows, cols) in enumerate(self.shapes):
            base = self.offsets[index]
            grid = np.arange(rows * cols).reshape(rows, cols) + base
            row_pairs = [(r, r + 1) for r in range(rows - 1)]
            if self.specs[index].closed:
                row_pairs.append((rows - 1, 0))
            for r0, r1 in row_pairs:
                for c in range(max(cols - 1, 1)):
                    c1 = min(c + 1, cols - 1)
                    a, b, cc, d = grid[r0, c], grid[r1, c], grid[r0, c1], grid[r1, c1]
                    cells.append([a, b, d]); owner.append(index)
                    if c1 != c:
                        cells.append([a, d, cc]); owner.append(index)
        self.cells = np.array(cells, np.int64)
        self.cell_muscle = np.array(owner, np.int64)

    def _prepare_connections(self, placed: list[PlacedMuscle], connections: list[ConnectionSpec]) -> None:
        index_of = {name: i for i, name in enumerate(self.names)}
        self.groups, self.pushes = [], []
        for conn in connections:
            points = []
            for name, pairs in conn.members:
                m = index_of[name]
                sr, sc = placed[m].coarse_to_fine
                rows, cols = self.shapes[m]
                for r, c in pairs:
                    fr, fc = min(r * sr, rows - 1), min(c * sc, cols - 1)
                    points.append(self.offsets[m] + fr * cols + fc)
            points = np.unique(np.array(points, np.int64))
            if conn.kind == "push":
                self._prepare_push(conn, points, placed, index_of)
                continue
            self.groups.append((conn.name, points))
        self.connected = np.zeros(len(self.rest), bool)
        for _, pts in self.groups:
            self.connected[pts] = True

    def _prepare_push(self, conn: ConnectionSpec, sources: np.ndarray, placed: list[PlacedMuscle],
                      index_of: dict[str, int]) -> None:
        """A push's target points (every point of the target muscles) and their weights: ``gain`` faded
        to 0 at ``reach`` from the nearest source point."""
        targets = np.concatenate([np.arange(self.offsets[index_of[name]], self.offsets[index_of[name] + 1])
                                  for name in conn.targets])
        distance = np.linalg.norm(self.rest[targets][:, None] - self.rest[sources][None], axis=2).min(axis=1)
        t = np.clip(distance / conn.reach, 0.0, 1.0)
        axes = np.array([float(a in conn.axes) for a in "xyz"])
        self.pushes.append((sources, targets, conn.gain * (1.0 - t * t * (3.0 - 2.0 * t)), axes))

    def _prepare_propagation(self) -> None:
        """Per muscle, the linear map from corrections at its fixed points to all its points."""
        self.propagation = []
        for index, (rows, cols) in enumerate(self.shapes):
            n = rows * cols
            grid = np.arange(n).reshape(rows, cols)
            lap = np.zeros((n, n))
            pairs = [(grid[r, c], grid[r + 1, c]) for r in range(rows - 1) for c in range(cols)]
            pairs += [(grid[r, c], grid[r, c + 1]) for r in range(rows) for c in range(cols - 1)]
            if self.specs[index].closed:
                pairs += [(grid[rows - 1, c], grid[0, c]) for c in range(cols)]
            for a, b in pairs:
                lap[a, a] += 1; lap[b, b] += 1; lap[a, b] -= 1; lap[b, a] -= 1
            local = self.slice(index)
            fixed = self.connected[local].copy()
            if self.specs[index].kind == "linear":
                fixed[grid[0]] = True                                     # origin stays on the bone
            free = ~fixed
            screen = 0.05 if self.specs[index].kind == "linear" else 1.0
            if not np.any(free) or not np.any(self.connected[local]):
                self.propagation.append(None)
                continue
            a = lap[np.ix_(free, free)] + screen * np.eye(int(free.sum()))
            b = -lap[np.ix_(free, fixed)]
            spread = np.linalg.solve(a, b)                                # (free, fixed)
            full = np.zeros((n, int(fixed.sum())))
            full[np.flatnonzero(fixed)] = np.eye(int(fixed.sum()))
            full[np.flatnonzero(free)] = spread
            self.propagation.append((np.flatnonzero(fixed), full))

    # -- per frame -------------------------------------------------------------------------------
    def deform(self, contraction: np.ndarray, protrusion: float, jaw: np.ndarray) -> MuscleState:
        """Deformed control points for muscle ``contraction`` (per muscle, [0, 1]), orbicularis oris
        ``protrusion`` ([-1, 1]) and the jaw pose (4x4)."""
        contraction = np.clip(np.asarray(contraction, np.float64), 0.0, 1.0)
        protrusion = float(np.clip(protrusion, -1.0, 1.0))
        carry = self.jaw_carry[:, None]
        carried = self.rest + carry * (_transform(jaw, self.rest) - self.rest)
        on_jaw = self.jaw_carry > 0.5
        normal = self.normal.copy()
        normal[on_jaw] = self.normal[on_jaw] @ jaw[:3, :3].T
        points = carried.copy()
        own_length = np.ones(len(self.rest))        # fibre length ratio from the muscle's own contraction
        for index, spec in enumerate(self.specs):
            if spec.kind == "linear" and contraction[index] > 0:
                sl = self.slice(index)
                points[sl] = self._shortened(index, contraction[index], jaw)
                own_length[sl] = 1.0 - contraction[index] * spec.max_shortening
        points = self._push(points, carried)
        for index, spec in enumerate(self.specs):
            if spec.kind != "linear" and self.centres[index] is not None:
                self._squeeze(index, contraction[index], protrusion, jaw, points, own_length)
        points = self._connect(points, contraction)
        thickness = self._bulge(points, contraction, own_length)
        surface = points + normal * (thickness - self.thickness_rest)[:, None]
        return MuscleState(surface, surface - carried, thickness)

    def _shortened(self, index: int, c: float, jaw: np.ndarray) -> np.ndarray:
        """A linear muscle's points moved along their own fibres towards the origin (module docstring, 1),
        then carried by the jaw."""
        spec, sl = self.specs[index], self.slice(index)
        rows, cols = self.shapes[index]
        rest = self.rest[sl].reshape(rows, cols, 3)
        s = self.arclength[index]
        target = s * (1.0 - c * spec.max_shortening)
        # locate each target arc length on the rest polyline of its own column
        seg = np.clip((s[None, :, :] <= target[:, None, :]).sum(axis=1) - 1, 0, rows - 2)        # (R, C)
        cols_idx = np.arange(cols)[None, :]
        s0, s1 = s[seg, cols_idx], s[seg + 1, cols_idx]
        t = np.clip((target - s0) / np.maximum(s1 - s0, 1e-12), 0.0, 1.0)[..., None]
        flat = (rest[seg, cols_idx] * (1 - t) + rest[seg + 1, cols_idx] * t).reshape(-1, 3)
        return flat + self.jaw_carry[sl][:, None] * (_transform(jaw, flat) - flat)

    def _push(self, points: np.ndarray, carried: np.ndarray) -> np.ndarray:
        """Pushes (:class:`.muscle_layout.ConnectionSpec` of kind "push"): the tissue a contracting muscle
        bunches up moves what lies beyond it (the mentalis raising the chin boss pushes the lower lip up,
        FACS AU17; one side's risorius pulling the whole lip ring sideways, ARKit mouthLeft): each target point
        moves by the mean displacement of the source points (along the push's axes), faded with its
        distance from them."""
        for sources, targets, weight, axes in self.pushes:
            moved = (points[sources] - carried[sources]).mean(axis=0) * axes
            if np.any(moved):
                points[targets] += weight[:, None] * moved
        return points

    def _squeeze(self, index: int, c: float, protrusion: float, jaw: np.ndarray, points: np.ndarray,
                 own_length: np.ndarray) -> None:
        """A sphincter contracting towards its centre (module docstring, 1), in place."""
        spec, sl = self.specs[index], self.slice(index)
        rows, cols = self.shapes[index]
        centre, squeeze = self.centres[index], self.fibre_squeeze[index]
        if spec.group == "oris":
            centre_now = 0.5 * (centre + _transform(jaw, centre[None])[0])
            axes = self.mouth_axes
        else:
            centre_now = centre
            axes = np.eye(3)
        local = (points[sl].reshape(rows, cols, 3) - centre_now) @ axes.T
        rounding = c * max(protrusion, 0.0) if spec.group == "oris" else 0.0
        sx = 1.0 - c * squeeze[0][None, :] - rounding * squeeze[2][None, :]
        sz = (1.0 - c * squeeze[1][None, :]) * np.clip(1.0 - rounding * squeeze[3], 0.0, 1.0)
        local[..., 0] *= sx
        local[..., 2] *= sz
        if spec.group == "oris" and protrusion != 0.0:
            travel = spec.protrusion[0] if protrusion > 0 else spec.protrusion[1]
            outer = 0.0 if protrusion > 0 else RETRACTED_OUTER      # pulled back, the whole lip goes back
            inner_weight = np.linspace(1.0, outer, cols) if cols > 1 else np.ones(1)
            local[..., 1] -= protrusion * travel * inner_weight[None, :]
        points[sl] = (local @ axes + centre_now).reshape(-1, 3)
        own_length[sl] = np.broadcast_to(0.5 * (sx + sz), (rows, cols)).ravel()

    def _connect(self, points: np.ndarray, contraction: np.ndarray) -> np.ndarray:
        if not self.groups:
            return points
        before = points.copy()
        weight_all = 1.0 + CONNECTION_GAIN * contraction[self.muscle_of_point]
        for _, pts in self.groups:
            w = weight_all[pts][:, None]
            centre_now = (w * before[pts]).sum(0) / w.sum()
            centre_rest = (w * self.rest[pts]).sum(0) / w.sum()
            offset_rest = self.rest[pts] - centre_rest
            points[pts] = centre_now + offset_rest         # original distances to the centre restored
        correction = points - before
        out = before.copy()
        for index, prop in enumerate(self.propagation):
            if prop is None:
                continue
            fixed, full = prop
            sl = self.slice(index)
            local = correction[sl]
            out[sl] += full @ local[fixed]
        return out

    def _bulge(self, points: np.ndarray, contraction: np.ndarray, own_length: np.ndarray) -> np.ndarray:
        """Thickness per point: thicker with contraction (linear: most mid-belly, sphincter: evenly),
        thinner when stretched beyond the length its own contraction gave it (volume kept: t ~ 1/sqrt)."""
        thickness = self.thickness_rest.copy()
        for index, (sl, rows, cols, profile, rest_thickness) in enumerate(self._bulge_static()):
            spec = self.specs[index]
            pts = points[sl].reshape(rows, cols, 3)
            seg = np.linalg.norm(np.diff(pts, axis=0), axis=-1)
            length = np.maximum(np.add.reduce(seg, axis=0), 1e-9)
            # the mean over rows, as ndarray.mean computes it (sum, then divide), without its overhead
            expected = self.fibre_length[index] * (np.add.reduce(own_length[sl].reshape(rows, cols), axis=0) / rows)
            stretch = np.minimum(np.maximum(length / np.maximum(expected, 1e-9), 0.25), 4.0)
            grow = 1.0 + spec.bulge * contraction[index] * profile
            thickness[sl] = (rest_thickness * grow / np.sqrt(stretch)[None, :]).ravel()
        return thickness

    def _bulge_static(self) -> list:
        """Per muscle: slice, rows, columns, bulge profile along the fibre (linear: sin, most mid-belly;
        sphincter: even) and rest thickness grid -- fixed once the muscles are placed (built on first use)."""
        static = getattr(self, "_bulge_cache", None)
        if static is None:
            static = []
            for index, spec in enumerate(self.specs):
                rows, cols = self.shapes[index]
                sl = self.slice(index)
                profile = (np.sin(np.pi * self.position_along[index]) if spec.kind == "linear"
                           else np.ones((rows, cols)))
                static.append((sl, rows, cols, profile, self.thickness_rest[sl].reshape(rows, cols).copy()))
            self._bulge_cache = static
        return static

    def fibres(self, points: np.ndarray) -> list[tuple[str, np.ndarray]]:
        """Fibre polylines (muscle name, (R, 3)) of a deformed state, for visualisation."""
        out = []
        for index, name in enumerate(self.names):
            rows, cols = self.shapes[index]
            grid = points[self.slice(index)].reshape(rows, cols, 3)
            closed = self.specs[index].closed
            for c in range(cols):
                line = grid[:, c]
                out.append((name, np.vstack([line, line[:1]]) if closed else line))
        return out
