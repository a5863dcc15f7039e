"""Radial-basis warp (3.1.2 "Building the Reference Head") and the skin-through-bone guard."""
import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.physics import BoneHalfSpaceGuard, RBFWarp, SphereGuard


def test_rbf_interpolates_landmarks_exactly_and_reproduces_affine_maps():
    rng = np.random.default_rng(0)
    source = rng.normal(size=(20, 3))
    target = source + rng.normal(scale=0.1, size=(20, 3))
    warp = RBFWarp(source, target)
    np.testing.assert_allclose(warp(source), target, atol=1e-9)
    matrix = np.array([[1.2, 0.1, 0.0], [0.0, 0.9, 0.2], [0.1, 0.0, 1.1]])
    affine = RBFWarp(source, source @ matrix.T + [0.3, -0.2, 0.5], kernel="cubic")
    points = rng.normal(size=(50, 3)) * 3
    np.testing.assert_allclose(affine(points), points @ matrix.T + [0.3, -0.2, 0.5], atol=1e-8)


def test_rbf_rejects_degenerate_input():
    with pytest.raises(UserError):
        RBFWarp(np.zeros((3, 3)), np.zeros((3, 3)))
    with pytest.raises(UserError):
        RBFWarp(np.zeros((5, 3)), np.zeros((4, 3)))


def test_bone_guard_projects_escaped_nodes_and_follows_the_bone():
    positions = np.array([[0.0, -0.001, 0.0], [0.0, -0.010, 0.0]]).T.copy()   # (3, N); bone plane y = 0
    velocity = np.array([[0.0, 0.5, 0.0], [0.0, 0.5, 0.0]]).T.copy()
    guard = BoneHalfSpaceGuard(np.array([0, 1]), np.zeros((3, 2)), np.tile([[0.0], [-1.0], [0.0]], 2),
                               np.array([0, 1]), 0.002)
    guard(positions, velocity)
    assert positions[1, 0] == pytest.approx(-0.002) and velocity[1, 0] == pytest.approx(0.0)
    assert positions[1, 1] == pytest.approx(-0.010) and velocity[1, 1] == pytest.approx(0.5)
    moved = np.eye(4)
    moved[1, 3] = -0.02                                        # bone 1 moves 2 cm forward
    guard.set_bone_transforms([np.eye(4), moved])
    guard(positions, velocity)
    assert positions[1, 1] == pytest.approx(-0.022)


def test_sphere_guard_keeps_nodes_outside_the_eyeball():
    positions = np.array([[0.0, -0.005, 0.0]]).T.copy()
    SphereGuard(np.array([0]), np.zeros(3), 0.012)(positions, np.zeros_like(positions))
    assert np.linalg.norm(positions[:, 0]) == pytest.approx(0.012)
