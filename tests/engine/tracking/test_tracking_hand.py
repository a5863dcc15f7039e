"""The pitcher's hand (thesis 6.3.2): automatic marker labels on a synthetic set of glove markers, Horn's
absolute orientation, joint angles within Table 6.4, a hidden finger, hand clusters."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon.hand.template import reference_template
from faces_hands_addon.tracking.camera import rotation_from_vector
from faces_hands_addon.tracking.glove import glove_layout
from faces_hands_addon.tracking.hand_markers import Markers3D, cluster_hands
from faces_hands_addon.tracking.hand_pose import couple_rotations, horn, solve_hand


@pytest.fixture(scope="module")
def hand():
    template = reference_template()
    return template.skeleton, glove_layout(template.skeleton, template.skin.vertices)


def _pose(skeleton, rng):
    names = skeleton.dof_names()
    angles = np.zeros(skeleton.dof_count)
    for k, name in enumerate(names):
        if name.endswith("flexion") and ("phalanx" in name or name.startswith("thumb")):
            angles[k] = np.radians(rng.uniform(5, 60))
        elif name.endswith("abduction") and "phalanx-proximal" in name:
            angles[k] = np.radians(rng.uniform(-4, 4))
    root = np.eye(4)
    root[:3, :3] = rotation_from_vector(rng.normal(size=3))
    root[:3, 3] = rng.uniform(-1, 1, 3)
    return root, couple_rotations(skeleton, skeleton.clamp(angles))


def test_horn_recovers_a_rigid_motion():
    rng = np.random.default_rng(0)
    points = rng.normal(size=(5, 3))
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = rotation_from_vector([0.4, -1.2, 2.0]), [1.0, 2.0, -0.5]
    moved = points @ m[:3, :3].T + m[:3, 3]
    assert np.allclose(horn(points, moved), m, atol=1e-10)


def test_automatic_labels_and_joint_angles(hand):
    skeleton, layout = hand
    rng = np.random.default_rng(7)
    correct = total = 0
    errors = []
    for trial in range(2):
        root, angles = _pose(skeleton, rng)
        points = layout.positions(skeleton, root, angles) + rng.normal(0, 0.0005, (18, 3))
        order = rng.permutation(18)
        pose = solve_hand(skeleton, layout, points[order], [layout.colours[i] for i in order])
        for name, index in pose.labels.items():
            correct += int(layout.names[order[index]] == name)
            total += 1
        names = skeleton.dof_names()
        errors += [abs(np.degrees(pose.angles[names.index(d)] - angles[names.index(d)])) for d in pose.solved]
        assert np.all(pose.angles >= skeleton.lower - 1e-9) and np.all(pose.angles <= skeleton.upper + 1e-9)
    assert total == 2 * 18 and correct == total
    assert np.mean(errors) < 3.0


def test_hidden_finger_and_missing_back_marker(hand):
    skeleton, layout = hand
    rng = np.random.default_rng(11)
    root, angles = _pose(skeleton, rng)
    points = layout.positions(skeleton, root, angles)
    hidden = [layout.names.index(n) for n in ("ring_pip", "ring_dip", "ring_nail")]
    keep = [i for i in range(18) if i not in hidden]
    pose = solve_hand(skeleton, layout, points[keep], [layout.colours[i] for i in keep])
    assert sorted(pose.missing) == ["ring_dip", "ring_nail", "ring_pip"]
    assert all(layout.names[keep[k]] == n for n, k in pose.labels.items())
    assert not any(d.startswith("ring-finger-phalanx") for d in pose.solved)
    no_back = [i for i in range(18) if i != layout.back[1]]
    assert solve_hand(skeleton, layout, points[no_back], [layout.colours[i] for i in no_back]) is None


def test_hand_exposures_cluster_apart(hand):
    skeleton, layout = hand
    rng = np.random.default_rng(5)
    clouds = []
    for k in range(3):
        root, angles = _pose(skeleton, rng)
        root[:3, 3] = [0.0, 0.35 * k, 1.7]
        clouds.append(layout.positions(skeleton, root, angles))
    points = np.vstack(clouds)
    markers = Markers3D(points, np.zeros(len(points), np.int64))
    rest = layout.rest
    link = 1.5 * np.sort(np.linalg.norm(rest[:, None] - rest[None], axis=2), axis=1)[:, 1].max()
    groups = cluster_hands(markers, link)
    assert sorted(len(g) for g in groups) == [18, 18, 18]
