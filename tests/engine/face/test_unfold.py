# SPDX-License-Identifier: GPL-3.0-or-later
"""The fold mender (face.unfold): turned-over skin triangles are mended by a harmonic displacement, what is
pinned stays, and a skin without folds is left byte for byte."""
import numpy as np

from faces_hands_addon.core import geometry
from faces_hands_addon.face.unfold import FoldMender


def _sheet(n: int = 12, spacing: float = 0.001):
    """A flat n x n sheet of 1 mm squares in the XZ plane (normals along -Y), two triangles each."""
    x, z = np.meshgrid(np.arange(n) * spacing, np.arange(n) * spacing)
    vertices = np.c_[x.ravel(), np.zeros(n * n), z.ravel()]
    faces = []
    for r in range(n - 1):
        for c in range(n - 1):
            a, b, d, e = r * n + c, r * n + c + 1, (r + 1) * n + c, (r + 1) * n + c + 1
            faces += [(a, b, e), (a, e, d)]
    return vertices, np.array(faces)


def _flipped(vertices, faces, rest):
    return int(np.sum(np.einsum("ij,ij->i", geometry.face_normals(vertices, faces),
                                geometry.face_normals(rest, faces)) < 0))


def test_a_node_pushed_past_its_neighbours_is_mended_and_the_rim_stays():
    rest, faces = _sheet()
    n = 12
    pinned = np.zeros(len(rest), bool)
    pinned[:n] = pinned[-n:] = True                     # two rims
    moved = rest + np.array([0.0, 0.0, 0.0005])         # the whole sheet slides up 0.5 mm (a smooth move)
    centre = 6 * n + 6
    moved[centre, 0] += 0.0025                          # one node pushed 2.5 spacings sideways: folds
    assert _flipped(moved, faces, rest) > 0
    mender = FoldMender(rest, faces, ~pinned, np.ones(len(faces), bool))
    out = moved.copy()
    left = mender.mend(out)
    assert left == 0 and _flipped(out, faces, rest) == 0
    assert mender.mended > 0
    np.testing.assert_array_equal(out[pinned], moved[pinned])
    far = np.linalg.norm(rest - rest[centre], axis=1) > 0.004       # beyond the region: untouched
    np.testing.assert_array_equal(out[far], moved[far])
    # the smooth part of the move is kept: the mended region still slid up with the rest
    assert abs(out[centre, 2] - (rest[centre, 2] + 0.0005)) < 1e-4


def test_a_skin_without_folds_keeps_its_bytes():
    rest, faces = _sheet()
    rng = np.random.default_rng(7)
    moved = rest + rng.normal(0.0, 0.00005, rest.shape)            # small noise: nothing turns over
    assert _flipped(moved, faces, rest) == 0
    out = moved.copy()
    assert FoldMender(rest, faces, np.ones(len(rest), bool), np.ones(len(faces), bool)).mend(out) == 0
    assert out.tobytes() == moved.tobytes()


def test_a_fold_among_pinned_nodes_is_left_as_the_settle_made_it():
    rest, faces = _sheet()
    moved = rest.copy()
    moved[6 * 12 + 6, 0] += 0.0025
    out = moved.copy()
    left = FoldMender(rest, faces, np.zeros(len(rest), bool), np.ones(len(faces), bool)).mend(out)
    assert left > 0 and out.tobytes() == moved.tobytes()


def test_hidden_triangles_do_not_count():
    rest, faces = _sheet()
    moved = rest.copy()
    moved[6 * 12 + 6, 0] += 0.0025
    out = moved.copy()
    mender = FoldMender(rest, faces, np.ones(len(rest), bool), np.zeros(len(faces), bool))
    assert mender.mend(out) == 0 and out.tobytes() == moved.tobytes()


def test_the_face_rig_mends_a_fold_in_its_state_and_holds_the_lid_margins():
    """FaceRig.mend_folds on the default head: a cheek node pushed through its neighbours is mended in the
    simulation state (the next frame starts from it), the lid margins stay where they were."""
    from faces_hands_addon.face.rig import build_default_rig
    rig = build_default_rig("default")
    rig.reset()
    skin = rig.template.skin
    x = rig.face.network.positions                       # (3, N), the simulation state
    rest = np.asarray(skin.vertices, np.float64)
    surface = np.flatnonzero(skin.group("surface") & ~skin.group("upper_lip") & ~skin.group("lower_lip"))
    node = int(surface[np.argmin(np.linalg.norm(rest[surface] - (rest[surface].mean(0) + [0.03, 0, 0]), axis=1))])
    neighbours = np.unique(skin.faces[np.any(skin.faces == node, axis=1)])
    reach = np.linalg.norm(rest[neighbours] - rest[node], axis=1).max()
    x[:, node] += 3.0 * reach * (rest[neighbours].mean(0) - rest[node] + [reach, 0, 0]) / reach
    before = np.array(x.T, np.float64)
    assert len(rig._mender.folded(before) if rig._mender else FoldMender(
        rest, skin.faces, np.ones(len(rest), bool), np.ones(len(skin.faces), bool)).folded(before)) > 0
    margins = np.concatenate([np.asarray(skin.contours[f"eye_{s}_{k}"]) for s in "LR" for k in ("upper", "lower")])
    assert rig.mend_folds() == 0
    after = np.array(rig.face.network.positions.T, np.float64)
    assert len(rig._mender.folded(after)) == 0
    np.testing.assert_array_equal(after[margins], before[margins])


def test_touching_lip_margins_are_found_and_an_untraced_margin_is_no_error():
    from faces_hands_addon.face.unfold import touching
    points = np.array([[0, 0, 0], [0.002, 0, 0], [0, 0, -0.0005], [0.002, 0, -0.003]], float)
    upper, lower = np.array([0, 1]), np.array([2, 3])
    assert sorted(touching(points, upper, lower, 0.001).tolist()) == [0, 2]
    assert len(touching(points, upper, np.array([], np.int64), 0.001)) == 0
