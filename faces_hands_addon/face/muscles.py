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
from scipy import sparse

from ..physics import kernel
from . import muscle_kernel
from .muscle_layout import ConnectionSpec, PlacedMuscle

__all__ = ["MuscleSystem", "MuscleState"]

CONNECTION_GAIN = 8.0        # weight of a control point = 1 + gain * contraction of its muscle
RETRACTED_OUTER = 0.5        # orbicularis oris pulled back: the outermost fibre travels this much of the innermost
LINEAR_SCREEN = 0.05         # step 4's screening of a linear muscle's free points (per grid step)
SPHINCTER_SCREEN = 1.0       # ... of a sphincter's, beside its connected rows (a correction fades ~0.38 a row)
BETWEEN_SCREEN = 0.3         # ... of a sphincter's rows between its connected rows (fades ~0.58 a row)


def _screening(kind: str, fixed: np.ndarray, middle: float | None = None) -> np.ndarray:
    """Per grid point (rows x cols, flattened), how strongly step 4's spread of the connection corrections
    is screened back to rest. The thesis (3.1.2 "Muscle Deformation") keeps the points "pulled at by other
    muscles" fixed and elongates the "intermediate segments"; a linear muscle's points between its origin
    and its insertion do that (``LINEAR_SCREEN``). A sphincter's rows beside its connections fade back fast
    (``SPHINCTER_SCREEN``), but the rows *between* its connected rows (the orbicularis oris' middle, between
    the left and the right ``upper_lip`` / ``lower_lip`` groups) are such an intermediate segment: screened
    as hard, a one-sided levator labii superioris or depressor labii inferioris moved the lip's midline
    by 8-13 % of its own rise (0.5-0.9 mm on fitted heads, under the audit's 1 mm for mouthUpperUp /
    mouthLowerDown); ``BETWEEN_SCREEN`` lets it follow further. The grid rows sit on landmarks, so the
    muscle's midline follows alike on every head; what differs is the skin: a cupid's bow (the outer lip
    contour dipping at the midline, MakeHuman 2.6 mm) is dragged up by its rising neighbours, a flat, thick
    lip (African head) is not, and its midline needs the muscle to carry it (0.3: its midline rises 1.0 mm
    for levator labii superioris, was 0.7 at 0.5). Not down to the linear value: the lower lip margin and
    the nose fold then (default head, 0.25: noseSneer 1 inverted; 0.2: mouthLowerDown 3 as well).
    ``middle`` (muscles.json ``middle_screen``) screens the rows of the widest gap between connected rows
    but the one beside each group (the lip's middle) apart: the lower lip (0.2) lets its midline follow a
    depressor labii inferioris further (African head 0.8 -> 1.05-1.08 mm) without folding the default
    head's lip margin (0.2 everywhere between: mouthLowerDown 3/2 inverted) nor, with the rows beside the
    groups at 0.3, MakeHuman's skin outside the commissures in mouthPucker (2 inverted). The upper lip
    keeps 0.3: 0.28-0.29 fold one triangle at the default head's alar crease in noseSneer."""
    rows = fixed.shape[0]
    if kind == "linear":
        return np.full(fixed.size, LINEAR_SCREEN)
    screen = np.full(fixed.shape, SPHINCTER_SCREEN)
    connected_rows = np.flatnonzero(fixed.any(axis=1))
    inner = connected_rows[(connected_rows > 0) & (connected_rows < rows - 1)]
    if len(inner):
        screen[inner.min() + 1:inner.max()] = BETWEEN_SCREEN
        if middle is not None and len(inner) > 1:
            gap = int(np.argmax(np.diff(inner)))
            screen[inner[gap] + 2:inner[gap + 1] - 1] = middle
    return screen.ravel()


@dataclass
class MuscleState:
    points: np.ndarray           # (P, 3) deformed control points (muscle centre line, incl. bulge)
    displacement: np.ndarray     # (P, 3) relative to the bone-carried rest position
    thickness: np.ndarray        # (P,) current thickness (m)


def _transform(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def _protrusion_weights(columns: int, red_lip: int) -> np.ndarray:
    """Share of the orbicularis oris' travel each fibre (column, innermost first) takes when the lips
    protrude or retract: the fibres under the red lip (out to the vermilion border, ``red_lip`` refined
    columns; the pars marginalis) move as one with the innermost, the outer ones less and less, the outermost
    not at all (3.1.2 "Muscle Deformation": the centre is shifted "gradually"). Tapering from the innermost
    fibre instead left the vermilion border with half the travel: the lips' outline hardly came forward."""
    if columns <= 1:
        return np.ones(max(columns, 1))
    full = int(np.clip(red_lip, 0, columns - 1))
    return np.concatenate([np.ones(full), np.linspace(1.0, 0.0, columns - full)])


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
        #: rest lip opening an oris point closes first (:meth:`set_rest_closing`; zero for closed rest lips)
        self.rest_closing = np.zeros_like(self.rest)
        self.muscle_of_point = np.concatenate([np.full(s, i) for i, s in enumerate(sizes)])
        self.thickness_rest = np.concatenate([np.full(s, m.spec.thickness) for s, m in zip(sizes, placed)])
        # mouth frame (x: right -> left corner, y: protrusion axis reversed, z: up), rows are axes
        self.mouth_axes = np.eye(3) if mouth_axes is None else np.asarray(mouth_axes, np.float64)
        self._prepare_kinds(placed)
        self._prepare_cells()
        self._prepare_connections(placed, connections)
        self._prepare_propagation()
        self._prepare_tables()

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
        self._sphincters = None

    def set_jaw_carry(self, carry: np.ndarray) -> None:
        """Per control point, the fraction (0..1) of the jaw's motion that carries it at rest."""
        self.jaw_carry = np.clip(np.asarray(carry, np.float64), 0.0, 1.0)

    def set_rest_closing(self, offsets: np.ndarray) -> None:
        """Per control point, how far it moves (head coordinates, rest pose) when parted rest lips close
        (an artist's head keeps its lips apart; the default template closes them before the muscles are
        laid out, :func:`.skin.close_rest_lips`)."""
        self.rest_closing = np.asarray(offsets, np.float64).reshape(self.rest.shape)

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
        self._prepare_sphincters()

    def _prepare_sphincters(self) -> None:
        """Per control point of every sphincter with a centre: its muscle, its fibre's squeeze factors and
        protrusion weight (flat, so that :meth:`_contract_sphincters` treats all of them at once)."""
        muscles = [i for i, spec in enumerate(self.specs) if spec.kind != "linear" and self.centres[i] is not None]
        if not muscles:
            self._sphincters = None
            return
        pieces = []
        for index in muscles:
            rows, cols = self.shapes[index]
            horizontal, vertical, sideways, lateral = self.fibre_squeeze[index]
            spec = self.specs[index]
            grid = lambda values: np.broadcast_to(values, (rows, cols)).ravel()      # noqa: E731
            inner = _protrusion_weights(cols, spec.red_lip_columns * max(1, int(spec.refine[1])))
            oris = spec.group == "oris"
            pieces.append((np.arange(self.offsets[index], self.offsets[index + 1]), np.full(rows * cols, index),
                           grid(horizontal), grid(vertical), grid(sideways), grid(lateral),
                           grid(inner) if oris else np.zeros(rows * cols), np.full(rows * cols, oris),
                           np.full(rows * cols, spec.protrusion[0] if oris else 0.0),
                           np.full(rows * cols, spec.protrusion[1] if oris else 0.0)))
        (points, muscle, horizontal, vertical, sideways, lateral, inner, oris, forward,
         backward) = (np.concatenate(column) for column in zip(*pieces))
        self._sphincters = (points, muscle, np.stack([horizontal, vertical, sideways, lateral]), inner,
                            oris.astype(bool), forward, backward,
                            np.array([self.centres[i] if i in muscles else np.zeros(3) for i in range(len(self.specs))]))

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
            spec = self.specs[index]
            n = rows * cols
            grid = np.arange(n).reshape(rows, cols)
            lap = np.zeros((n, n))
            pairs = [(grid[r, c], grid[r + 1, c]) for r in range(rows - 1) for c in range(cols)]
            pairs += [(grid[r, c], grid[r, c + 1]) for r in range(rows) for c in range(cols - 1)]
            if spec.closed:
                pairs += [(grid[rows - 1, c], grid[0, c]) for c in range(cols)]
            for a, b in pairs:
                lap[a, a] += 1; lap[b, b] += 1; lap[a, b] -= 1; lap[b, a] -= 1
            local = self.slice(index)
            fixed = self.connected[local].copy()
            if spec.kind == "linear":
                fixed[grid[0]] = True                                     # origin stays on the bone
            free = ~fixed
            if not np.any(free) or not np.any(self.connected[local]):
                self.propagation.append(None)
                continue
            screen = _screening(spec.kind, fixed.reshape(rows, cols), spec.middle_screen)[free]
            a = lap[np.ix_(free, free)] + np.diag(screen)
            b = -lap[np.ix_(free, fixed)]
            spread = np.linalg.solve(a, b)                                # (free, fixed)
            full = np.zeros((n, int(fixed.sum())))
            full[np.flatnonzero(fixed)] = np.eye(int(fixed.sum()))
            full[np.flatnonzero(free)] = spread
            self.propagation.append((np.flatnonzero(fixed), full))

    def _prepare_tables(self) -> None:
        """Flat index tables that let :meth:`deform` treat every linear muscle, every connection group and
        every muscle's bulge at once instead of muscle by muscle (built once; the layout never changes)."""
        index = np.arange(len(self.rest))
        row = np.concatenate([np.repeat(np.arange(r), c) for r, c in self.shapes])
        col = np.concatenate([np.tile(np.arange(c), r) for r, c in self.shapes])
        rows_of = np.array([r for r, _ in self.shapes])[self.muscle_of_point]
        cols_of = np.array([c for _, c in self.shapes])[self.muscle_of_point]
        # every column of every muscle: its points in row order, padded (arc length +inf past the end)
        column = np.concatenate([[0], np.cumsum([c for _, c in self.shapes])])[self.muscle_of_point] + col
        longest = int(max(r for r, _ in self.shapes))
        grid = np.zeros((int(column.max()) + 1, longest), np.int64)
        grid[column, row] = index
        arclength = np.full(grid.shape, np.inf)
        arclength[column, row] = np.concatenate([a.ravel() for a in self.arclength])
        linear = np.array([spec.kind == "linear" for spec in self.specs])[self.muscle_of_point]
        shortening = np.array([spec.max_shortening if spec.kind == "linear" else 0.0 for spec in self.specs])
        self._linear = (np.flatnonzero(linear), column[linear], row[linear], rows_of[linear], arclength, grid,
                        shortening)
        # bulge: the fibre (column) of each point, and each fibre's segments (point -> next point in its column)
        has_next = row < rows_of - 1
        self._fibres = (column, np.flatnonzero(has_next), index[has_next] + cols_of[has_next], rows_of,
                        np.concatenate([length for length in self.fibre_length]),
                        np.array([spec.bulge for spec in self.specs])[self.muscle_of_point],
                        np.concatenate([a.ravel() for a in self.position_along]), linear)
        # connections: each group's points (no point is in two groups), then the propagation as one matrix
        members = np.concatenate([pts for _, pts in self.groups]) if self.groups else np.zeros(0, np.int64)
        group_of = np.concatenate([np.full(len(pts), g) for g, (_, pts) in enumerate(self.groups)]) \
            if self.groups else np.zeros(0, np.int64)
        spread = np.zeros((len(self.rest), len(self.rest)))
        for muscle, prop in enumerate(self.propagation):
            if prop is not None:
                base = int(self.offsets[muscle])
                fixed, full = prop
                spread[base:base + full.shape[0], base + fixed] = full
        self._groups = (members, group_of, len(self.groups), sparse.csr_matrix(spread),
                        np.array([prop is not None for prop in self.propagation])[self.muscle_of_point])

    # -- per frame -------------------------------------------------------------------------------
    def deform(self, contraction: np.ndarray, protrusion: float, jaw: np.ndarray) -> MuscleState:
        """Deformed control points for muscle ``contraction`` (per muscle, in [0, 1]), orbicularis oris
        ``protrusion`` (in [-1, 1]) and the jaw pose (4x4). The values come from the rig's controls, clamped
        once where they enter it (``anim.layers.mix``, ``FaceRig.set_controls``)."""
        contraction = np.asarray(contraction, np.float64)
        protrusion = float(protrusion)
        if (compiled := kernel.compiled(muscle_kernel.deform_points, *muscle_kernel.HELPERS)) is not None:
            surface, carried, thickness = np.empty_like(self.rest), np.empty_like(self.rest), np.empty(len(self.rest))
            compiled(contraction, protrusion, np.ascontiguousarray(jaw[:3, :3], np.float64),
                     np.ascontiguousarray(jaw[:3, 3], np.float64), self.rest, self.normal,
                     np.ascontiguousarray(self.jaw_carry, np.float64), self.muscle_of_point, *self._kernel_tables(),
                     np.ascontiguousarray(self.rest_closing, np.float64), self.thickness_rest, surface, carried,
                     thickness)
            return MuscleState(surface, surface - carried, thickness)
        carry = self.jaw_carry[:, None]
        carried = self.rest + carry * (_transform(jaw, self.rest) - self.rest)
        on_jaw = self.jaw_carry > 0.5
        normal = self.normal.copy()
        normal[on_jaw] = self.normal[on_jaw] @ jaw[:3, :3].T
        points = carried.copy()
        own_length = np.ones(len(self.rest))        # fibre length ratio from the muscle's own contraction
        self._contract_linear(contraction, jaw, points, own_length)
        points = self._push(points, carried)
        self._contract_sphincters(contraction, protrusion, jaw, points, own_length)
        points = self._connect(points, contraction)
        thickness = self._bulge(points, contraction, own_length)
        surface = points + normal * (thickness - self.thickness_rest)[:, None]
        return MuscleState(surface, surface - carried, thickness)

    def _kernel_tables(self) -> tuple:
        """:meth:`_prepare_tables`' tables as :func:`.muscle_kernel.deform_points` takes them (linear,
        pushes, sphincters, connections, bulge), packed once per sphincter layout (:meth:`set_centres`)."""
        cached = getattr(self, "_packed", None)
        if cached is not None and cached[0] is self._sphincters:
            return cached[1]
        which, column, row, rows, arclength, grid, shortening = self._linear
        linear = (which, column, row, rows, np.ascontiguousarray(arclength), grid, shortening.astype(np.float64))
        empty, sizes = np.zeros(0, np.int64), lambda parts: np.r_[0, np.cumsum([len(x) for x in parts])].astype(np.int64)
        sources, targets = [push[0] for push in self.pushes], [push[1] for push in self.pushes]
        pushes = (np.concatenate(sources) if sources else empty, sizes(sources),
                  np.concatenate(targets) if targets else empty, sizes(targets),
                  np.concatenate([push[2] for push in self.pushes]) if targets else np.zeros(0),
                  np.array([push[3] for push in self.pushes], np.float64).reshape(-1, 3))
        if self._sphincters is None:
            sphincters = (empty, empty, np.zeros((4, 0)), np.zeros(0), np.zeros(0, bool), np.zeros(0), np.zeros(0),
                          np.zeros((len(self.specs), 3)), self.mouth_axes, False)
        else:
            which_s, muscle, squeeze, inner, oris, forward, backward, centres = self._sphincters
            sphincters = (which_s.astype(np.int64), muscle.astype(np.int64), np.ascontiguousarray(squeeze, np.float64),
                          inner.astype(np.float64), oris, forward.astype(np.float64), backward.astype(np.float64),
                          np.ascontiguousarray(centres, np.float64), np.ascontiguousarray(self.mouth_axes), True)
        members, group_of, count, spread, spreads = self._groups
        connect = (members.astype(np.int64), group_of.astype(np.int64), int(count), spreads, spread.indptr,
                   spread.indices, spread.data)
        column, start, following, _, fibre_length, bulge, along, is_linear = self._fibres
        fibres = int(column.max()) + 1
        bulge_tables = (column, start, following, np.ascontiguousarray(fibre_length[:fibres], np.float64),
                        bulge.astype(np.float64), along.astype(np.float64), is_linear)
        self._packed = (self._sphincters, (linear, pushes, sphincters, connect, bulge_tables))
        return self._packed[1]

    def _contract_linear(self, contraction: np.ndarray, jaw: np.ndarray, points: np.ndarray,
                         own_length: np.ndarray) -> None:
        """Step 1 for every linear muscle at once (module docstring): each control point moves to its
        shortened arc length along the rest polyline of its own column, then goes its share of the way with
        the jaw (``jaw_carry``) (in place)."""
        which, column, row, rows, arclength, grid, shortening = self._linear
        ratio = 1.0 - contraction * shortening                        # per muscle
        muscle = self.muscle_of_point[which]
        active = contraction[muscle] > 0
        which, column, row, rows, ratio = which[active], column[active], row[active], rows[active], ratio[muscle[active]]
        if not len(which):
            return
        s = arclength[column]                                         # (K, longest), +inf past the end
        target = s[np.arange(len(which)), row] * ratio
        seg = np.clip((s <= target[:, None]).sum(axis=1) - 1, 0, rows - 2)
        s0 = arclength[column, seg]
        s1 = arclength[column, seg + 1]
        t = np.clip((target - s0) / np.maximum(s1 - s0, 1e-12), 0.0, 1.0)[:, None]
        moved = self.rest[grid[column, seg]] * (1 - t) + self.rest[grid[column, seg + 1]] * t
        moved += self.jaw_carry[which][:, None] * (_transform(jaw, moved) - moved)
        points[which] = moved
        own_length[which] = ratio

    def _contract_sphincters(self, contraction: np.ndarray, protrusion: float, jaw: np.ndarray, points: np.ndarray,
                             own_length: np.ndarray) -> None:
        """Step 1 for every sphincter at once (module docstring): towards its centre (the oris' centre
        halfway carried by the jaw, in the mouth frame), squeezed per fibre, the oris with protrusion and
        rounding (in place)."""
        if self._sphincters is None:
            return
        which, muscle, squeeze, inner, oris, forward, backward, centres = self._sphincters
        c = contraction[muscle]
        centre = centres[muscle]
        centre = np.where(oris[:, None], 0.5 * (centre + _transform(jaw, centre)), centre)
        local = points[which] - centre
        local[oris] = local[oris] @ self.mouth_axes.T
        rounding = np.where(oris, c * max(protrusion, 0.0), 0.0)
        sx = 1.0 - c * squeeze[0] - rounding * squeeze[2]
        sz = (1.0 - c * squeeze[1]) * np.clip(1.0 - rounding * squeeze[3], 0.0, 1.0)
        local[:, 0] *= sx
        local[:, 2] *= sz
        if protrusion != 0.0:
            travel = forward if protrusion > 0 else backward
            # pulled back, the whole lip goes back: the outermost fibre travels RETRACTED_OUTER of the innermost
            weight = inner if protrusion > 0 else RETRACTED_OUTER + (1.0 - RETRACTED_OUTER) * inner
            local[oris, 1] -= (protrusion * travel * weight)[oris]
        local[oris] = local[oris] @ self.mouth_axes
        # parted rest lips: scaled towards the centre, the rest opening closes in proportion to the
        # contraction; it closes at twice that rate (shut by half the full squeeze, the same at full), so a
        # partly contracted oris meets the other lip as on a template whose lips rest together (3.1.3 closures)
        shut = np.clip(1.0 - sz, 0.0, 1.0)
        early = (np.minimum(2.0 * shut, 1.0) - shut) * (1.0 - max(protrusion, 0.0))
        points[which] = local + centre + early[:, None] * self.rest_closing[which]
        own_length[which] = 0.5 * (sx + sz)

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

    def _connect(self, points: np.ndarray, contraction: np.ndarray) -> np.ndarray:
        """Steps 3 and 4 (module docstring): each connection group's original distances to its weighted
        centre restored, the corrections spread into the muscles (one sparse product for all of them)."""
        members, group_of, count, spread, spreads = self._groups
        if not count:
            return points
        weight = (1.0 + CONNECTION_GAIN * contraction[self.muscle_of_point[members]])[:, None]
        total = np.zeros((count, 1))
        np.add.at(total, group_of, weight)
        centre_now, centre_rest = np.zeros((count, 3)), np.zeros((count, 3))
        np.add.at(centre_now, group_of, weight * points[members])
        np.add.at(centre_rest, group_of, weight * self.rest[members])
        correction = np.zeros_like(points)
        correction[members] = (centre_now / total)[group_of] + (self.rest[members] - (centre_rest / total)[group_of]) \
            - points[members]
        correction[~spreads] = 0.0              # a muscle without propagation keeps its points
        return points + spread @ correction

    def _bulge(self, points: np.ndarray, contraction: np.ndarray, own_length: np.ndarray) -> np.ndarray:
        """Thickness per point (step 5): thicker with contraction (linear: most mid-belly, sphincter:
        evenly), thinner when stretched beyond the length its own contraction gave it (volume kept:
        t ~ 1/sqrt), every fibre at once."""
        column, start, following, rows, fibre_length, bulge, along, linear = self._fibres
        fibres = int(column.max()) + 1
        step = points[following] - points[start]
        length = np.maximum(np.bincount(column[start], np.sqrt(np.einsum("ij,ij->i", step, step)), fibres), 1e-9)
        expected = fibre_length * (np.bincount(column, own_length, fibres) / np.bincount(column, None, fibres))
        stretch = np.minimum(np.maximum(length / np.maximum(expected, 1e-9), 0.25), 4.0)
        profile = np.where(linear, np.sin(np.pi * along), 1.0)
        grow = 1.0 + bulge * contraction[self.muscle_of_point] * profile
        return self.thickness_rest * grow / np.sqrt(stretch)[column]

    def fibre_order(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The points of every fibre polyline of :meth:`fibres`, in its order, as one gather: ``(index, line
        lengths, muscle of each line)`` (a closed fibre repeats its first point), built once."""
        cached = getattr(self, "_fibre_order", None)
        if cached is None:
            index, lengths, muscle = [], [], []
            for m in range(len(self.names)):
                rows, cols = self.shapes[m]
                grid = np.arange(self.offsets[m], self.offsets[m + 1]).reshape(rows, cols)
                for c in range(cols):
                    line = np.r_[grid[:, c], grid[:1, c]] if self.specs[m].closed else grid[:, c]
                    index.append(line)
                    lengths.append(len(line))
                    muscle.append(m)
            cached = self._fibre_order = (np.concatenate(index), np.array(lengths), np.array(muscle))
        return cached

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
