"""The pitch tracker's geometry (thesis 6.3.1-6.3.3): calibration recovers a known camera, triangulation of a
known point, epipolar matching, ball centres by ellipse and circular Hough (a side-lit half-moon too), two
overlapping balls separated."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.tracking.ball import find_silhouettes, refine_centre, split_merged
from faces_hands_addon.tracking.calibrate import board_points, calibrate_intrinsics, solve_pose
from faces_hands_addon.tracking.camera import Camera, look_at, rotation_from_vector, vector_from_rotation
from faces_hands_addon.tracking.checkerboard import find_corners
from faces_hands_addon.tracking.stereo import match_pair, triangulate
from pitch_images import board_image, sphere_image

TRUE = Camera("test", (240, 180), 230.0, 232.0, 123.0, 88.0, [-0.12, 0.03, 0.001, -0.0015])
INNER, SQUARE = (7, 5), 0.03


def _pose(angles_deg, distance=0.5) -> np.ndarray:
    r = rotation_from_vector(np.radians(angles_deg))
    m = np.eye(4)
    m[:3, :3] = r
    m[:3, 3] = np.array([0.0, 0.0, distance]) - r @ np.array([3 * SQUARE, 2 * SQUARE, 0.0])
    return m


def test_calibration_recovers_a_known_camera():
    views = []
    for angles in ([35, 0, 5], [-35, 0, -5], [0, 35, 8], [0, -35, -8], [25, 25, 0], [-25, 25, 10]):
        image = board_image(TRUE, _pose(angles), INNER, SQUARE)
        image += np.random.default_rng(len(views)).normal(0, 0.01, image.shape)
        views.append(find_corners(image, INNER))
    found = calibrate_intrinsics(views, INNER, SQUARE, TRUE.size).camera
    assert found.fx == pytest.approx(TRUE.fx, rel=0.01) and found.fy == pytest.approx(TRUE.fy, rel=0.01)
    assert abs(found.cx - TRUE.cx) < 3.0 and abs(found.cy - TRUE.cy) < 3.0
    assert found.distortion[0] == pytest.approx(TRUE.distortion[0], abs=0.03)
    # extrinsics from known non-coplanar points (the 3D calibration object)
    eye = np.array([1.0, -2.0, 1.5])
    R = look_at(eye, [0.0, 0.0, 0.4])
    posed = TRUE.with_pose(R, -R @ eye)
    points = np.array([[x, y, z] for x in (-0.3, 0.3) for y in (-0.3, 0.3) for z in (0.1, 0.7)])
    pose, error = solve_pose(found, points, posed.project(points))
    assert np.linalg.norm(pose.centre - eye) < 0.02
    assert np.degrees(np.linalg.norm(vector_from_rotation(pose.R @ R.T))) < 0.5
    assert error < 0.5


def test_checkerboard_refused_when_cut_off():
    image = board_image(TRUE, _pose([0, 0, 0], 0.25), INNER, SQUARE)      # too close: corners outside
    with pytest.raises(UserError, match="checkerboard"):
        find_corners(image, INNER)


def _pair():
    out = []
    for z in (1.2, 2.0):
        eye = np.array([-3.5, 1.5, z])
        R = look_at(eye, [0.0, 1.5, 1.6])
        out.append(Camera(f"c{z}", (320, 240), 300.0, 300.0, 160.0, 120.0, [-0.05, 0.0, 0.0, 0.0], R, -R @ eye))
    return out


def test_triangulation_of_a_known_point():
    cams = _pair()
    point = np.array([[0.1, 1.7, 1.55], [0.3, 0.9, 1.8]])
    pixels = [c.project(point) for c in cams]
    assert np.allclose(triangulate(cams, pixels), point, atol=1e-7)
    noisy = [p + np.array([[0.3, -0.2], [-0.25, 0.1]]) for p in pixels]
    assert np.max(np.linalg.norm(triangulate(cams, noisy) - point, axis=1)) < 0.02
    # correspondences along epipolar lines, shuffled order
    match = match_pair(cams[0], cams[1], pixels[0], pixels[1][::-1])
    assert sorted(map(tuple, match.pairs)) == [(0, 1), (1, 0)]


def test_ball_centre_by_ellipse_and_hough_on_a_half_moon():
    cams = [c.undistorted() for c in _pair()]
    centre = np.array([0.2, 1.5, 1.6])
    radius = 0.0366
    light = np.array([0.2, 1.5, 5.0])                      # from above: the lower half is dark
    image = sphere_image(cams[0], centre[None], radius * 6, light, ambient=0.0)
    value = image.max(axis=2)
    found = find_silhouettes(image, 10).silhouettes
    assert len(found) == 1
    true = cams[0].project(centre[None])[0]
    ellipse_error = np.linalg.norm(found[0].centre - true)
    refined = refine_centre(cams[0], value, found[0], centre + [0.01, 0.0, 0.0], radius * 6, 0.3)
    assert np.linalg.norm(refined - true) < 0.5 < ellipse_error


def test_two_overlapping_balls_are_separated():
    cam = _pair()[0].undistorted()
    centres = np.array([[0.0, 1.4, 1.6], [0.0, 1.536, 1.6], [0.0, 2.3, 1.6], [0.0, 0.6, 1.6]])
    image = sphere_image(cam, centres, 0.08)
    found = find_silhouettes(image, 10)
    merged = [s for s in found.silhouettes if s.merged]
    assert len(merged) == 1 and len(found.silhouettes) == 3
    radius = float(np.median([s.axes[1] for s in found.silhouettes if not s.merged]))
    parts = split_merged(image.max(axis=2), merged[0], radius, 0.4)
    true = cam.project(centres[:2])
    assert len(parts) == 2
    distances = np.linalg.norm(np.array([p.centre for p in parts])[:, None] - true[None], axis=2).min(axis=0)
    assert np.all(distances < 1.5)
