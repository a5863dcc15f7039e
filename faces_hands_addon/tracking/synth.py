# SPDX-License-Identifier: GPL-3.0-or-later
"""Synthetic ground truth for the pitch tracker (thesis 6.3 made measurable: the thesis had no ground truth,
6.3.3 "Validation"). Everything here is plain data; Blender renders it (``operators/tracking/synth_render``).

:func:`synthetic_rig` places the cameras of the set-up preset (positions jittered, principal point off
centre, lens distortion drawn per camera); :func:`synthetic_pitch` throws a pitch of a given type: the flight
of Eq. 6.12 from jittered initial parameters, the strobe flashes that light the ball in the front (80 Hz) and
back (50 Hz) views, the ball's orientation at each flash (constant spin, random start), and the hand at the
hand strobe's flashes (75 Hz): a root moving with the ball until release and slowing after, joint angles from
the grip through the release pose to the follow-through, the ball in the fingers before release. The pitcher's
hand is the reference hand warped to a synthetic photograph's feature points (6.2.3).
:func:`photo_from_render` turns a pinhole render into a photo: lens distortion and sensor noise.
Every random choice comes from ``numpy.random.default_rng(seed)``.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy import ndimage

from ..core.errors import UserError
from .ball_model import ball_model
from .camera import Camera, look_at, rotation_from_vector
from .flight import MPH, RPM, fly
from .setup import PITCH_TYPES, pitch_preset, setup_preset

__all__ = ["synthetic_rig", "synthetic_pitch", "photo_from_render", "board_poses", "object_points",
           "pitcher_photo", "pitcher_hand", "hand_motion", "smoothstep", "spin_axis"]

RELEASE_LEAD = 0.035        # s of hand flashes before release
FOLLOW = 0.045              # s of hand flashes after release
HAND_DECELERATION = 260.0   # m/s^2 after release (and acceleration before it)


def synthetic_rig(seed: int, setup: dict | None = None) -> dict[str, Camera]:
    """The cameras of the set-up preset, jittered for ``seed``."""
    setup = setup or setup_preset()
    rng = np.random.default_rng([seed, 1])
    cameras = {}
    for name in sorted(setup["cameras"]):
        spec = setup["cameras"][name]
        w, h = int(spec["width"]), int(spec["height"])
        f = 0.5 * w / np.tan(np.radians(spec["fov"]) / 2)
        eye = np.asarray(spec["position"], float) + rng.uniform(-1, 1, 3) * setup["jitter_m"]
        R = look_at(eye, np.asarray(spec["target"], float))
        d = setup["distortion"]
        distortion = [rng.uniform(*d["k1"]), rng.uniform(*d["k2"]), rng.uniform(-1, 1) * d["p"],
                      rng.uniform(-1, 1) * d["p"]]
        cx, cy = (np.array([w, h]) / 2 + rng.uniform(-1, 1, 2) * setup["principal_jitter_px"])
        cameras[name] = Camera(name, (w, h), f, f, cx, cy, distortion, R, -R @ eye)
    return cameras


def smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def spin_axis(tilt_deg: float, gyro_deg: float, flight: np.ndarray) -> np.ndarray:
    """The spin axis for a pitch along ``flight``: ``tilt`` about the flight direction from pure backspin
    (axis to the pitcher's right), then ``gyro`` towards the flight direction."""
    forward = flight / np.linalg.norm(flight)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    t, g = np.radians(tilt_deg), np.radians(gyro_deg)
    axis = np.cos(t) * right + np.sin(t) * up
    return np.cos(g) * axis + np.sin(g) * forward


def pitcher_photo(template_features: dict, seed: int) -> dict:
    """A synthetic hand photograph's feature points (6.2.3 input): the reference hand's feature points seen
    from its back, scaled for a pitcher's hand (3-9 % larger, each finger's length a little different)."""
    rng = np.random.default_rng([seed, 2])
    scale = 1.0 + rng.uniform(0.03, 0.09)
    pixel = 0.0004                       # m per pixel of the photograph
    points = {}
    for name, p in template_features.items():
        finger = name.split("_")[0]
        stretch = 1.0 + (rng.uniform(-0.03, 0.03) if finger in ("thumb", "index", "middle", "ring", "pinky") else 0)
        y, z = p[1] * scale, p[2] * scale * stretch
        points[name] = [float(1000 + y / pixel), float(200 - z / pixel)]
    return {"points": points, "ruler": [[100.0, 900.0], [100.0 + 0.2 / pixel, 900.0]], "ruler_mm": 200.0,
            "image": "synthetic pitcher hand"}


@lru_cache(maxsize=2)
def pitcher_hand(seed: int):
    """The synthetic pitcher's right hand (a :class:`...hand.rig.HandRig` warped to :func:`pitcher_photo`) and
    the photo input it was built from."""
    from ..hand.rig import build_hand_rig
    from ..hand.template import reference_template
    photo = pitcher_photo(reference_template().features, seed)
    return build_hand_rig("right", photo), photo


def _flash_times(flight, start: float, hz: float, span: tuple[float, float], duration: float, phase: float):
    times = np.arange(start + phase, duration, 1.0 / hz)
    y = flight.at(times)[:, 1] if len(times) else np.zeros(0)
    return times[(y >= span[0]) & (y <= span[1])]


def hand_motion(pitch: dict, rng, skeleton, dof_names: list[str], times: np.ndarray, release: np.ndarray,
                velocity: np.ndarray, ball_local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Root transforms (K, 4, 4) and joint angles (K, DOFs) of the hand at ``times`` (s from release)."""
    forward = velocity / np.linalg.norm(velocity)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    finger_dir = 0.55 * forward + 0.83 * up                # fingers up and forward at release
    palm_dir = np.cross(finger_dir, right)
    # rest frame: fingers along -Z, palm along +X, thumb along -Y (towards the pitcher's left for a right hand)
    rest = np.stack([[1.0, 0, 0], [0, 0, -1.0]])
    world = np.stack([palm_dir / np.linalg.norm(palm_dir), finger_dir / np.linalg.norm(finger_dir)])
    u, _, vt = np.linalg.svd(world.T @ rest)
    base = u @ np.diag([1, 1, np.linalg.det(u @ vt)]) @ vt
    snap = np.radians(1400.0)                               # rad/s wrist snap about the pitcher's right
    grip, rel, follow = (pitch.get(k, {}) for k in ("grip", "release", "follow"))
    jitter = np.radians(pitch.get("_angle_jitter", 0.0))
    lower, upper = skeleton.lower, skeleton.upper
    noise = {name: rng.uniform(-1, 1) * jitter for name in set(grip) | set(rel)}
    roots, angles = [], []
    for t in times:
        turn = rotation_from_vector(right * snap * t) @ base
        offset = velocity * t - 0.5 * HAND_DECELERATION * abs(t) * t * forward
        root = np.eye(4)
        root[:3, :3] = turn
        root[:3, 3] = release + offset - turn @ ball_local
        a = np.zeros(len(dof_names))
        for k, name in enumerate(dof_names):
            g = np.radians(grip.get(name, 0.0)) + noise.get(name, 0.0)
            r = np.radians(rel.get(name, 0.0)) + noise.get(name, 0.0)
            f = np.radians(follow.get(name, 0.0))
            a[k] = g + (r - g) * smoothstep((t + RELEASE_LEAD) / RELEASE_LEAD) + f * smoothstep(t / FOLLOW)
        roots.append(root)
        angles.append(np.clip(a, lower, upper))
    return np.array(roots), np.array(angles)


def synthetic_pitch(pitch: str, seed: int, setup: dict | None = None, pitches: dict | None = None) -> dict:
    """The ground truth of one synthetic pitch (module docstring) as plain arrays; the hand part is filled by
    :func:`hand_motion` once the pitcher's hand is built (it needs the rig)."""
    setup, pitches = setup or setup_preset(), pitches or pitch_preset()
    if pitch not in PITCH_TYPES:
        raise UserError(f"unknown pitch {pitch!r}; choose one of {', '.join(PITCH_TYPES)}")
    spec, jitter = pitches["pitches"][pitch], pitches["jitter"]
    rng = np.random.default_rng([seed, 3, PITCH_TYPES.index(pitch)])
    release = np.asarray(pitches["release_point"], float) + rng.uniform(-1, 1, 3) * jitter["release_m"]
    target = np.asarray(pitches["target"], float) + rng.uniform(-1, 1, 3) * np.array([0.15, 0.0, 0.2])
    speed = (spec["speed_mph"] + rng.uniform(-1, 1) * jitter["speed_mph"]) * MPH
    aim = target - release
    aim[2] += 0.5 * 9.81 * (np.linalg.norm(aim) / speed) ** 2 * 0.6     # aim a little high: the pitch drops
    velocity = speed * aim / np.linalg.norm(aim)
    if spec.get("random_axis"):
        axis = rng.normal(size=3)
    else:
        axis = spin_axis(spec["tilt"] + rng.uniform(-1, 1) * jitter["axis_deg"],
                         spec["gyro"] + rng.uniform(-1, 1) * jitter["axis_deg"], velocity)
    axis /= np.linalg.norm(axis)
    rate = (spec["spin_rpm"] + rng.uniform(-1, 1) * jitter["spin_rpm"] * (spec["spin_rpm"] > 200)) * RPM
    duration = 1.25 * 18.0 / speed
    flight = fly(release, velocity, axis * rate, duration, ball_model().physics)
    strobes = setup["strobes"]
    front = _flash_times(flight, 0.0, strobes["front"]["hz"], setup["views"]["front"], duration,
                         rng.uniform(0, 1 / strobes["front"]["hz"]))
    back = _flash_times(flight, 0.0, strobes["back"]["hz"], setup["views"]["back"], duration,
                        rng.uniform(0, 1 / strobes["back"]["hz"]))
    start = rotation_from_vector(rng.normal(size=3))
    hand_hz = strobes["hand"]["hz"]
    hand_times = np.arange(-RELEASE_LEAD + rng.uniform(0, 1 / hand_hz), FOLLOW, 1 / hand_hz)

    def orientation(t):
        return rotation_from_vector(axis * rate * t) @ start

    return {"pitch": pitch, "seed": int(seed), "release": release, "velocity": velocity, "spin": axis * rate,
            "speed_mph": speed / MPH, "spin_rpm": rate / RPM, "flight": flight, "duration": duration,
            "front_times": front, "back_times": back, "front_positions": flight.at(front),
            "back_positions": flight.at(back), "front_orientations": np.array([orientation(t) for t in front]),
            "back_orientations": np.array([orientation(t) for t in back]), "hand_times": hand_times,
            "orientation_at": orientation, "start_orientation": start, "spec": {**spec, "_angle_jitter":
                                                                                 jitter["angles_deg"]},
            "rng": np.random.default_rng([seed, 4, PITCH_TYPES.index(pitch)])}


def board_poses(camera: Camera, inner: tuple[int, int], square: float, count: int = 4) -> list[np.ndarray]:
    """Checkerboard placements (4x4, board -> world) filling about half of ``camera``'s view at different tilts."""
    cols, rows = inner
    width = (cols + 1) * square
    fov = 2 * np.arctan(0.5 * camera.size[0] / camera.fx)
    distance = width / (0.55 * 2 * np.tan(fov / 2))
    tilts = [(-28, 0, 5), (28, 0, -5), (0, -28, 10), (0, 28, -10), (18, 18, 0), (-18, -18, 0)][:count]
    out = []
    for ax, ay, az in tilts:
        local = rotation_from_vector(np.radians([ax, 0, 0])) @ rotation_from_vector(np.radians([0, ay, 0])) \
            @ rotation_from_vector(np.radians([0, 0, az]))
        board_in_cam = local
        centre_cam = np.array([0.0, 0.0, distance])
        origin_cam = centre_cam - board_in_cam @ np.array([(cols - 1) * square / 2, (rows - 1) * square / 2, 0])
        m = np.eye(4)
        m[:3, :3] = camera.R.T @ board_in_cam
        m[:3, 3] = camera.R.T @ (origin_cam - camera.t)
        out.append(m)
    return out


def object_points(centre, size: float) -> np.ndarray:
    """The 3D calibration object's sphere centres (16, 3): the corners of a cube of edge ``size`` turned 25
    degrees about the vertical and tipped 20 degrees, then the corners of a cube half that size inside it,
    turned another 45 degrees; corner k of both cubes has colour k (:func:`.calibration_set.object_centres`
    tells them apart by the pose that fits)."""
    corners = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], float)
    turn = rotation_from_vector(np.radians([20.0, 0.0, 0.0])) @ rotation_from_vector(np.radians([0.0, 0.0, 25.0]))
    inner = turn @ rotation_from_vector(np.radians([0.0, 0.0, 45.0])) @ rotation_from_vector(np.radians([25, 0, 0]))
    return np.asarray(centre, float) + np.vstack([0.5 * size * corners @ turn.T, 0.25 * size * corners @ inner.T])


def photo_from_render(render: np.ndarray, camera: Camera, rng, sigma: float) -> np.ndarray:
    """The photo a lens with ``camera.distortion`` and a noisy sensor would take of the pinhole ``render``
    (H, W, 3 float): each photo pixel samples the render where its undistorted ray points; Gaussian noise."""
    h, w = render.shape[:2]
    v, u = np.mgrid[0:h, 0:w].astype(np.float64) + 0.5
    pixels = np.column_stack([u.ravel(), v.ravel()])
    xy = camera.normalised(pixels)
    su = (xy[:, 0] * camera.fx + camera.cx - 0.5).reshape(h, w)
    sv = (xy[:, 1] * camera.fy + camera.cy - 0.5).reshape(h, w)
    out = np.empty_like(render, dtype=np.float32)
    for c in range(render.shape[2]):
        out[..., c] = ndimage.map_coordinates(render[..., c], [sv, su], order=1, mode="constant")
    out += rng.normal(0.0, sigma, out.shape).astype(np.float32)
    return np.clip(out, 0.0, 1.0)
