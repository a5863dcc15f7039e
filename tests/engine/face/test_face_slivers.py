"""Sliver ties (face/network.py ``SliverTies``): what counts as a sliver is relative to the mesh."""
import numpy as np

from faces_hands_addon.face.network import SLIVER_HEIGHT, SliverTies


def _dense_grid_with_one_sliver(spacing=0.0004, n=30):
    """A sheet of right triangles 0.4 mm on a side (every right-angle corner 0.28 mm from its hypotenuse:
    under SLIVER_HEIGHT, yet an ordinary triangle of this mesh) and, beside it, one real sliver whose corner
    lies 0.01 mm from its opposite edge."""
    xs, zs = np.meshgrid(np.arange(n) * spacing, np.arange(n) * spacing)
    vertices = np.stack([xs.ravel(), np.zeros(n * n), zs.ravel()], 1)
    index = np.arange(n * n).reshape(n, n)
    a, b, c, d = index[:-1, :-1].ravel(), index[:-1, 1:].ravel(), index[1:, :-1].ravel(), index[1:, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])
    base = len(vertices)
    sliver = np.array([[0.0, 0.0, -0.001], [0.0008, 0.0, -0.001], [0.0004, 0.0, -0.00099]])
    return np.concatenate([vertices, sliver]), np.concatenate([faces, [[base, base + 1, base + 2]]]), base + 2


def test_a_dense_mesh_ties_its_slivers_not_its_ordinary_triangles():
    vertices, faces, apex = _dense_grid_with_one_sliver()
    free = np.ones(len(vertices), bool)
    ties = SliverTies.build(vertices, faces, free)
    tied = np.concatenate([batch[0] for batch in ties.batches])
    assert tied.tolist() == [apex]
    # the absolute bound alone (as before) welds every triangle of the sheet, in chains that share nodes
    welded = SliverTies.build(vertices, faces, free, height=SLIVER_HEIGHT)
    assert sum(len(batch[0]) for batch in welded.batches) == len(faces)


def test_a_coarse_mesh_keeps_the_absolute_bound():
    """At the heads' resolution (edges of millimetres) the bound is SLIVER_HEIGHT, as it was: the same ties."""
    vertices, faces, _ = _dense_grid_with_one_sliver(spacing=0.004)
    free = np.ones(len(vertices), bool)
    ties = SliverTies.build(vertices, faces, free)
    absolute = SliverTies.build(vertices, faces, free, height=SLIVER_HEIGHT)
    for mine, theirs in zip(ties.batches, absolute.batches, strict=True):
        for a, b in zip(mine, theirs, strict=True):
            np.testing.assert_array_equal(a, b)
