# SPDX-License-Identifier: GPL-3.0-or-later
"""The whole pitch tracker (thesis 6.3) as small steps, so a modal operator can show progress and stop on Esc:
check the photos against the calibration, correct their distortion (6.3.1), ball positions of the front and
back pairs (6.3.3), the ball's markers, orientations and spin (Eqs. 6.10, 6.11; then one constant spin fitted
to every ball's markers in the photos, with its axis uncertainty, :mod:`.spin_fit`), the measured initial flight
parameters and the optimal reference trajectory (Eq. 6.12, Table 6.6), then the hand (6.3.2): glove markers,
hand clusters, labels, root and joint angles.

What cannot be measured is said, not guessed: without the front pair there is no spin and no initial velocity;
without the back pair the reference trajectory rests on the front positions alone; a ball with no marker
keeps its predicted orientation (6.3.3: the thesis recovered the flight parameters with none or one marker on
some balls); a hand exposure whose three back-of-hand markers are not all reconstructed is skipped (6.3.2).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.errors import UserError
from .ball import predicted_radius, refine_centre
from .ball_markers import marker_directions, markers_in_photo, spread
from .ball_model import BallModel, ball_model
from .glove import glove_layout
from .hand_markers import cluster_hands, find_markers, merge_pairs, pair_markers
from .hand_pose import solve_hand
from .images import undistort_image
from .orientation import orient_sequence, rigid_spin, spin_from
from .positions import ball_positions
from .reference import fit_reference, flash_indices, measure_initial, table_row
from .spin_fit import image_spin
from .setup import Calibration
from .stereo import triangulate

__all__ = ["PitchTracker", "PitchResult", "check_photos"]


@dataclass
class PitchResult:
    front: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    back: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    front_times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    orientations: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 3)))
    markers_per_ball: list = field(default_factory=list)
    spin_thesis: object = None
    spin: object = None
    axis_sigma_deg: float = float("nan")
    measured: object = None
    reference: object = None
    table: dict = field(default_factory=dict)
    hands: list = field(default_factory=list)          # (time, HandPose, cluster points, colours)
    hand_times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    warnings: list = field(default_factory=list)
    reprojection_px: dict = field(default_factory=dict)

    def document(self) -> dict:
        """The measurements as JSON-able data (what ``track-pitch --report`` writes)."""
        def arr(a):
            return np.asarray(a).tolist()
        doc = {"format": "faces_hands.pitch_measurement", "version": 1, "front_positions": arr(self.front),
               "front_times": arr(self.front_times), "back_positions": arr(self.back),
               "orientations": arr(self.orientations), "markers_per_ball": self.markers_per_ball,
               "table_6_6": self.table, "warnings": self.warnings, "reprojection_px": self.reprojection_px}
        if self.measured is not None:
            doc["measured"] = {"position": arr(self.measured.position), "velocity": arr(self.measured.velocity),
                               "spin": arr(self.measured.spin)}
        if self.spin_thesis is not None:
            doc["spin_eq_6_11"] = {"axis": arr(self.spin_thesis.axis), "rpm": self.spin_thesis.rpm}
        if self.spin is not None:
            doc["spin"] = {"axis": arr(self.spin.axis), "rpm": self.spin.rpm,
                           "axis_sigma_deg": None if np.isnan(self.axis_sigma_deg) else self.axis_sigma_deg}
        if self.reference is not None:
            doc["reference"] = {"position": arr(self.reference.position), "velocity": arr(self.reference.velocity),
                                "spin": arr(self.reference.spin), "duration": self.reference.duration}
        doc["hand"] = [{"time": float(t), "root": arr(p.root), "angles": arr(p.angles), "labels": p.labels,
                        "missing": p.missing, "residual_mm": 1000 * p.residual} for t, p, *_ in self.hands]
        return doc


def _smoothed(points: np.ndarray, times: np.ndarray) -> np.ndarray:
    """The ball's centres on a parabola in time (over a tenth of a second the flight of Eq. 6.12 is one to far
    below a millimetre): each marker's direction is measured from its ball's centre, and a millimetre off
    there turns it by two degrees."""
    if len(points) < 4:
        return points
    design = np.column_stack([np.ones_like(times), times, times ** 2])
    coefficients, *_ = np.linalg.lstsq(design, points, rcond=None)
    return design @ coefficients


def check_photos(calibration: Calibration, photos: dict[str, np.ndarray]) -> list[str]:
    """Photos named like the calibrated cameras and of their size; returns warnings for missing pairs."""
    warnings = []
    for name, image in photos.items():
        camera = calibration.cameras.get(name)
        if camera is None:
            continue
        if (image.shape[1], image.shape[0]) != tuple(camera.size):
            raise UserError(f"photo {name} is {image.shape[1]}x{image.shape[0]} pixels but camera {name} was calibrated "
                            f"at {camera.size[0]}x{camera.size[1]}; the photos must be the cameras' own, unresized")
    for role, names in calibration.pairs.items():
        missing = [n for n in names if n not in photos]
        if missing:
            warnings.append(f"the {role} pair has no photo from {', '.join(missing)}: its part is skipped")
    if not any(all(n in photos for n in names) for role, names in calibration.pairs.items()):
        raise UserError("no stereo pair has both photos; name the photos like the calibrated cameras ("
                        + ", ".join(sorted(calibration.cameras)) + ")")
    return warnings


class PitchTracker:
    """``steps()`` yields (fraction, message) while it works; ``result`` holds what it found.
    ``hand_rig`` is a callable returning the personalised hand rig (built only if a hand pair is there)."""

    def __init__(self, calibration: Calibration, photos: dict[str, np.ndarray], hand_rig=None,
                 model: BallModel | None = None):
        self.calibration, self.photos, self.hand_rig = calibration, photos, hand_rig
        self.model = model or ball_model()
        self.result = PitchResult()
        self.result.warnings += check_photos(calibration, photos)
        self.flat: dict[str, np.ndarray] = {}

    def steps(self):
        names = [n for n in self.photos if n in self.calibration.cameras]
        for k, name in enumerate(names):
            yield 0.3 * k / len(names), f"correcting lens distortion ({name})"
            self.flat[name] = undistort_image(self.photos[name], self.calibration.cameras[name])
        yield 0.3, "ball positions"
        self._ball()
        yield 0.45, "ball orientations and spin"
        self._spin()
        yield 0.55, "reference trajectory (Eq. 6.12)"
        self._reference()
        yield 0.8, "hand markers"
        self._hand()
        yield 1.0, "done"

    # -- ball --------------------------------------------------------------------------------------
    def _pair(self, role: str):
        pair = self.calibration.pair(role)
        if pair is None or any(c.name not in self.flat for c in pair):
            return None
        return tuple(c.undistorted() for c in pair)

    def _ball(self) -> None:
        r = self.result
        for role in ("front", "back"):
            pair = self._pair(role)
            if pair is None:
                r.warnings.append(f"no {role} pair photos: no {role} ball positions")
                continue
            found = ball_positions(pair, (self.flat[pair[0].name], self.flat[pair[1].name]), self.model.radius,
                                   self.calibration.plate_direction)
            r.warnings += found.warnings
            r.reprojection_px[role] = found.reprojection_px
            if len(found.points) == 0:
                r.warnings.append(f"no ball found in the {role} pair's photos")
            setattr(r, role, found.points)
            if role == "front":
                self._front = (pair, found)
        if len(r.front) >= 2:
            hz = self.calibration.strobes.get("front", 80.0)
            r.front_times = flash_indices(r.front) / hz

    def _spin(self) -> None:
        r = self.result
        if len(r.front) < 2:
            return
        pair, found = self._front
        centres = self._marker_centres(pair, found)
        spreads = [spread(shape, self.model.marker_size, self.model.radius) for shape in self.model.shapes]
        observations, per_ball = [], []
        for n, centre in enumerate(centres):
            detections = []
            for c, cam in enumerate(pair):
                pixel = found.centres[c][n]
                radius = predicted_radius(cam, centre, self.model.radius)
                detections.append(markers_in_photo(self.flat[cam.name], pixel, radius, self.model))
            per_ball.append(detections)
            observations.append(marker_directions(list(pair), detections, centre, self.model.radius, spreads=spreads))
        r.markers_per_ball = [len(o[1]) for o in observations]
        hz = self.calibration.strobes.get("front", 80.0)
        steps = flash_indices(r.front)
        if np.any(np.diff(steps) > 1):
            r.warnings.append("a ball is missing between two front positions; the spin uses the positions before the gap")
            last = int(np.flatnonzero(np.diff(steps) > 1)[0]) + 1
            observations, per_ball, centres = observations[:last], per_ball[:last], centres[:last]
        orientations = orient_sequence(self.model, observations)
        r.spin_thesis = spin_from(orientations, hz)
        refined, r.spin = rigid_spin(self.model, observations, orientations, r.spin_thesis, hz)
        r.orientations = refined
        joint = image_spin(self.model, pair, per_ball, centres, refined, r.spin, hz, spreads)
        if joint is not None:
            r.orientations, r.spin, r.axis_sigma_deg = joint.orientations, joint.spin, joint.axis_sigma_deg
        if sum(r.markers_per_ball) < 4:
            r.warnings.append("fewer than 4 ball markers were found in the front photos; the spin is unreliable")

    def _marker_centres(self, pair, found) -> np.ndarray:
        """The ball centres the marker directions are taken from: each silhouette's circle (never its ellipse,
        :func:`.ball.refine_centre`, its outline from the limb's brightness model, so the strobe's one-sided
        shading does not shift it), stereo, on a parabola in time. A circle that lands away from its ball's
        position by more than the others do (a neighbour's edge, a marker on the limb taken for the outline:
        beyond 3 robust deviations of the circles' shifts, at least 0.5 mm) is replaced by the position plus the
        typical shift."""
        values = [np.max(self.flat[cam.name][..., :3], axis=-1) for cam in pair]
        pixels = [np.array([refine_centre(cam, values[c], found.silhouettes[c][n], found.points[n], self.model.radius,
                                          found.levels[c], ellipse_fallback=False, profile=True)
                            for n in range(len(found.points))]).reshape(-1, 2) for c, cam in enumerate(pair)]
        points = triangulate(list(pair), pixels)
        shift = points - found.points
        finite = np.all(np.isfinite(shift), axis=1)
        if np.any(finite):
            typical = np.median(shift[finite], axis=0)
            off = np.linalg.norm(shift - typical, axis=1)
            limit = max(3.0 * 1.4826 * float(np.median(off[finite])), 5e-4)
            bad = ~finite | ~(off <= limit)
            points[bad] = found.points[bad] + typical
        else:
            points = found.points.copy()
        return _smoothed(points, self.result.front_times)

    def _reference(self) -> None:
        r = self.result
        if len(r.front) < 2 or r.spin is None:
            return
        hz = self.calibration.strobes.get("front", 80.0)
        r.measured = measure_initial(r.front, hz, r.spin.vector)
        scatter = float(np.std(r.spin_thesis.angles) * hz / np.sqrt(max(len(r.spin_thesis.angles), 1))) \
            if len(r.spin_thesis.angles) else 5.0
        r.reference = fit_reference(r.front, r.front_times, r.back, r.measured, max(scatter, 1.0),
                                    self.model.physics)
        r.table = table_row(r.reference, r.measured, np.vstack([r.front, r.back]) if len(r.back) else r.front)

    # -- hand --------------------------------------------------------------------------------------
    def _hand(self) -> None:
        r = self.result
        pairs = [p for p in (self._pair("hand_left"), self._pair("hand_right")) if p is not None]
        if not pairs or self.hand_rig is None:
            return
        rig = self.hand_rig()
        layout = glove_layout(rig.skeleton, rig.rest_positions.astype(np.float64))
        colours = sorted(set(layout.colours), key=layout.colours.index)
        per_pair = []
        for pair in pairs:
            found = tuple(find_markers(self.flat[c.name], colours) for c in pair)
            per_pair.append(pair_markers(pair, found))
        markers = merge_pairs(per_pair)
        rest = layout.rest
        distances = np.linalg.norm(rest[:, None] - rest[None], axis=2)
        spacing = np.sort(distances, axis=1)[:, 1]
        clusters = cluster_hands(markers, 1.5 * float(spacing.max()), span=1.1 * float(distances.max()))
        poses = []
        for group in clusters:
            names = [colours[c] for c in markers.colours[group]]
            pose = solve_hand(rig.skeleton, layout, markers.points[group], names)
            if pose is None:
                r.warnings.append(f"a hand exposure ({len(group)} markers) lacks one of the three back-of-hand markers; "
                                  "skipped (6.3.2)")
                continue
            poses.append((pose, markers.points[group], markers.colours[group]))
        poses.sort(key=lambda p: float(p[0].root[:3, 3] @ self.calibration.plate_direction))
        hz = self.calibration.strobes.get("hand", 75.0)
        r.hands = [(k / hz, pose, pts, cols) for k, (pose, pts, cols) in enumerate(poses)]
        r.hand_times = np.arange(len(poses)) / hz
        self.layout, self.rig = layout, rig
