"""Once-a-frame work of the bone guard the compiled path skips or does once (physics/collision.py,
physics/kernel.py): the result must be the same bytes as doing it every time."""
import importlib.util

import numpy as np
import pytest

from faces_hands_addon.physics import BoneHalfSpaceGuard

pytestmark = pytest.mark.skipif(importlib.util.find_spec("numba") is None,
                                reason="numba is not importable here (the numpy path is the only one)")


def _two_bone_guard(rng):
    nodes = np.sort(rng.choice(400, 150, replace=False))
    guard = BoneHalfSpaceGuard(nodes, rng.normal(size=(3, 150)) * 0.01, rng.normal(size=(3, 150)),
                               np.arange(150) % 2, 0.002)
    guard.backend = "numba"
    return guard


def test_planes_that_stay_put_give_the_same_bytes_as_planes_slid_every_substep():
    """Bone 0 stays, bone 1 moves: bone 0's planes are the same at the start and the end of the frame and
    are read from the once-a-frame table, bone 1's are slid; forcing every plane through the slide gives
    the same positions and velocities, bit for bit."""
    moved = np.eye(4)
    moved[:3, 3] = [0.001, -0.002, 0.003]
    outcome = []
    for table in (True, False):
        rng = np.random.default_rng(11)
        guard = _two_bone_guard(rng)
        x, v = rng.normal(size=(3, 400)) * 0.01, rng.normal(size=(3, 400))
        guard.set_bone_transforms([np.eye(4), np.eye(4)])
        guard.begin_frame()
        guard.set_bone_transforms([np.eye(4), moved])
        if not table:                                       # no plane counts as still: all slid
            guard._still = (np.zeros(150, np.bool_), np.zeros((3, 150)), np.zeros((3, 150)))
        for fraction in (0.25, 0.5, 0.75, 1.0):
            guard(x, v, fraction)
            if table and fraction == 0.25:
                assert guard._still[0].sum() == 75         # bone 0's planes, and only those
        outcome.append((x, v))
    assert outcome[0][0].tobytes() == outcome[1][0].tobytes()
    assert outcome[0][1].tobytes() == outcome[1][1].tobytes()


def _own_bone_guard():
    """Nodes 5 mm over two flat bones (z = 0) that keep their own bone, re-anchored at the exact closest
    point once they slid ``moved`` (1.5 mm) in their bone's frame."""
    grid = np.stack(np.meshgrid(np.linspace(-0.05, 0.05, 21), np.linspace(-0.05, 0.05, 21)), -1).reshape(-1, 2)
    vertices = np.column_stack([grid, np.zeros(len(grid))])
    normals = np.tile([0.0, 0.0, 1.0], (len(grid), 1))
    rest = np.column_stack([np.linspace(-0.03, 0.03, 20), np.zeros(20), np.full(20, 0.005)]).T

    def exact(bone, points):
        return np.column_stack([points[:, :2], np.zeros(len(points))]), np.tile([0.0, 0.0, 1.0], (len(points), 1))
    guard = BoneHalfSpaceGuard(np.arange(20), np.zeros((3, 20)), np.tile([[0.0], [0.0], [1.0]], 20),
                               np.arange(20) % 2, 0.002)
    guard.backend = "numba"
    guard.attach_bone_surfaces([(vertices, normals), (vertices, normals)], exact=exact, rest=rest.copy())
    guard.keep_own_bones()
    return guard, rest


def test_a_frame_where_no_node_slid_far_skips_the_exact_re_anchoring_and_changes_nothing():
    jaw = np.eye(4)
    jaw[:3, 3] = [0.0, 0.0, -0.004]
    outcome = []
    for pretest in (True, False):
        guard, rest = _own_bone_guard()
        if not pretest:
            guard._may_have_moved = lambda positions: True
        positions = rest.copy()
        positions[2, 1::2] -= 0.004                         # the jaw's nodes ride with it (odd ones)
        guard.set_bone_transforms([np.eye(4), jaw])
        guard.refresh(positions)
        calls = []
        exact = guard._exact
        guard._exact = lambda bone, points: calls.append(len(points)) or exact(bone, points)
        positions[0] += 0.001                               # 1 mm: under the 1.5 mm of a re-anchoring
        assert not guard._may_have_moved(positions) or not pretest
        guard.refresh(positions)
        if pretest:
            assert calls == []                              # skipped
        positions[0, 4] += 0.001                            # node 4 has now slid 2 mm on the skull
        assert guard._may_have_moved(positions)
        guard.refresh(positions)
        assert calls[-1] == 1 and guard.local_point[0, 4] == pytest.approx(rest[0, 4] + 0.002)
        outcome.append([a.tobytes() for a in (guard.local_point, guard.local_normal, guard._last, guard.point)])
    assert outcome[0] == outcome[1]


def test_compiled_closest_points_on_a_bone_are_numpys_bit_for_bit():
    """The skin guard's exact re-anchoring (face.attachment.BoneSurface.closest) evaluates its candidate
    triangles in a compiled loop once the kernel is loaded; it must answer what core.geometry.closest_points
    answers: on x86-64 the same bits (numpy sums a 3-vector dot product x + z, then y, which the loop
    copies), elsewhere the same to rounding. Points on both sides, near edges and corners and far off."""
    import platform

    from faces_hands_addon.core import geometry
    from faces_hands_addon.face.attachment import BoneSurface
    from faces_hands_addon.physics import anchor_kernel, kernel
    assert kernel.substep_kernel() is not None
    rng = np.random.default_rng(5)
    u, v = np.meshgrid(np.linspace(0, np.pi, 18), np.linspace(0, 2 * np.pi, 24), indexing="ij")
    vertices = np.column_stack([0.05 * np.sin(u).ravel() * np.cos(v).ravel(), 0.06 * np.sin(u).ravel()
                                * np.sin(v).ravel(), 0.07 * np.cos(u).ravel()])
    rows, cols = u.shape
    faces = np.array([[r * cols + c, (r + 1) * cols + c, (r + 1) * cols + (c + 1) % cols] for r in range(rows - 1)
                      for c in range(cols)] + [[r * cols + c, (r + 1) * cols + (c + 1) % cols, r * cols + (c + 1) % cols]
                                               for r in range(rows - 1) for c in range(cols)])
    surface = BoneSurface(vertices, faces)
    points = np.concatenate([vertices[rng.choice(len(vertices), 300)] * rng.uniform(0.8, 1.2, (300, 1)),
                             rng.normal(size=(200, 3)) * 0.1])
    surface.closest(points[:1])                                     # builds the tree
    compiled = kernel.compiled(anchor_kernel.closest_on_candidates, anchor_kernel._ratio)
    mine = surface._closest_compiled(compiled, points)
    reference = geometry.closest_points(surface.vertices, surface.faces, points, tree=surface._tree)
    np.testing.assert_array_equal(mine[1], reference[1])            # the same triangle
    for a, b in zip(mine, reference):
        if platform.machine().lower() in ("x86_64", "amd64"):
            assert a.tobytes() == b.tobytes()
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)
