"""The shared mesh geometry (one copy each): closest points against brute force, edges and their use
counts, normals and areas of a known shape, the mesh check's refusals."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.core import geometry


def _icosphere_like(rng):
    """A random closed-ish triangle soup over a sphere (convex hull of random points)."""
    from scipy.spatial import ConvexHull
    points = rng.normal(size=(200, 3))
    points /= np.linalg.norm(points, axis=1, keepdims=True)
    hull = ConvexHull(points)
    faces = hull.simplices.copy()
    normals = geometry.face_normals(points, faces)
    flip = np.einsum("ij,ij->i", normals, points[faces].mean(axis=1)) < 0
    faces[flip] = faces[flip][:, ::-1]
    return points, faces


def test_closest_points_match_brute_force():
    rng = np.random.default_rng(3)
    vertices, faces = _icosphere_like(rng)
    queries = rng.normal(size=(300, 3)) * 0.7
    point, face, bary, dist = geometry.closest_points(vertices, faces, queries, candidates=len(faces))
    tri = vertices[faces]
    for k in range(0, 300, 7):
        q = np.repeat(queries[k][None], len(faces), 0)
        all_points, _ = geometry.closest_points_on_triangles(q, tri[:, 0], tri[:, 1], tri[:, 2])
        assert dist[k] == pytest.approx(np.linalg.norm(all_points - q, axis=1).min(), abs=1e-12)
    np.testing.assert_allclose(np.einsum("ij,ijk->ik", bary, tri[face]), point, atol=1e-12)
    assert np.all((bary >= 0) & (bary <= 1)) and np.allclose(bary.sum(1), 1)


def test_edges_counts_normals_and_areas_of_a_cube_surface():
    v = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    edges, counts = geometry.unique_edges(faces, return_counts=True)
    assert len(edges) == 18 and np.all(counts == 2)                      # 12 cube edges + 6 diagonals
    assert np.all(edges[:, 0] < edges[:, 1]) and np.all(np.diff(edges[:, 0]) >= 0)
    assert geometry.vertex_areas(v, faces).sum() == pytest.approx(6.0)
    normals = geometry.vertex_normals(v, faces)
    np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0)
    outward = np.einsum("ij,ij->i", normals, v - 0.5)
    assert np.all(np.abs(outward) > 0.5)                                  # all one way round
    open_edges = geometry.unique_edges(faces[2:], return_counts=True)[1]
    assert (open_edges == 1).sum() == 4


@pytest.mark.parametrize("vertices, faces, message", [
    (np.zeros((3, 3)), np.zeros((0, 3), int), "no faces"),
    (np.eye(3), np.array([[0, 1, 5]]), "outside 0..2"),
    (np.array([[0, 0, 0], [1, 0, 0], [np.inf, 0, 0]]), np.array([[0, 1, 2]]), "NaN or infinite"),
    (np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), np.array([[0, 1, 2]]), "zero area"),
])
def test_checked_mesh_names_the_problem(vertices, faces, message):
    with pytest.raises(UserError, match=message):
        geometry.checked_mesh(vertices, faces, "the hand mesh")
