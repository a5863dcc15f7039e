# SPDX-License-Identifier: GPL-3.0-or-later
"""The skin guard's once-per-frame re-anchoring (:meth:`.collision.BoneHalfSpaceGuard.refresh`) as compiled
loops, for the live preview (thesis 3.1.2: the guard keeps the skin outside the bones the mirrored springs
alone let it pass in violent movements).

Per frame the guard finds the nodes that slid since their plane was chosen, gives each the nearest vertex
plane of the nearest bone within reach (in the bones' current poses) and poses the changed planes with their
bones. In numpy these are ~20 whole-array passes per bone over a few hundred nodes, and the KD-tree or grid
search per bone; here each is one loop over the nodes. The numpy code in :mod:`.collision` stays the
reference: the same nodes, the same vertex (ties to the lower index, as the KD-tree), the same planes.

The bones' vertex grids are packed into flat arrays (:func:`pack_grids`): bone ``b``'s vertices are rows
``vertex_start[b]:vertex_start[b + 1]`` of ``vertices``; its cubes (side ``cell``, ``dims[b]``) are entries
``cube_start[b]:`` of ``starts``, whose ``order`` entries are global vertex rows.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["PackedGrids", "pack_grids", "moved_nodes", "any_moved_on_own_bone", "nearest_bone_planes",
           "pose_planes", "closest_on_candidates"]


class PackedGrids:
    """Every bone's surface vertices, normals and vertex grid in flat arrays (module docstring)."""

    def __init__(self, vertices, normals, vertex_start, order, starts, cube_start, origin, dims, cell):
        self.vertices, self.normals, self.vertex_start = vertices, normals, vertex_start
        self.order, self.starts, self.cube_start = order, starts, cube_start
        self.origin, self.dims, self.cell = origin, dims, cell


def pack_grids(surfaces: list[tuple[np.ndarray, np.ndarray]], cell: float) -> PackedGrids:
    """Pack bone surfaces ``[(vertices (V, 3), normals (V, 3)), ...]`` (rest frames) into cubes of side
    ``cell``: half the guard's reach keeps a cube's few vertices close to the query, and cubes farther than
    the best vertex so far are skipped whole."""
    vertices, normals, orders, starts, origins, dims = [], [], [], [], [], []
    vertex_start, cube_start = [0], [0]
    for verts, norms in surfaces:
        verts = np.asarray(verts, np.float64)
        origin = verts.min(axis=0)
        size = np.floor((verts.max(axis=0) - origin) / cell).astype(np.int64) + 1
        cube = np.minimum(np.floor((verts - origin) / cell).astype(np.int64), size - 1)
        ids = (cube[:, 0] * size[1] + cube[:, 1]) * size[2] + cube[:, 2]
        order = np.argsort(ids, kind="stable")
        first = np.searchsorted(ids[order], np.arange(int(np.prod(size)) + 1))
        orders.append(order + vertex_start[-1])
        starts.append(first[:-1] + vertex_start[-1])
        vertices.append(verts)
        normals.append(np.asarray(norms, np.float64))
        origins.append(origin)
        dims.append(size)
        vertex_start.append(vertex_start[-1] + len(verts))
        cube_start.append(cube_start[-1] + len(first) - 1)
    starts.append(np.array([vertex_start[-1]]))
    return PackedGrids(np.ascontiguousarray(np.concatenate(vertices)), np.ascontiguousarray(np.concatenate(normals)),
                       np.array(vertex_start, np.int64), np.concatenate(orders).astype(np.int64),
                       np.concatenate(starts).astype(np.int64), np.array(cube_start, np.int64),
                       np.ascontiguousarray(origins, np.float64), np.ascontiguousarray(dims, np.int64), float(cell))


def moved_nodes(positions, nodes, last, moved, everything, x_out, active_out):  # pragma: no cover - compiled
    """Gather the guarded nodes' positions (world, ``x_out`` (K, 3)) and list the nodes that moved more
    than ``moved`` metres since their plane was chosen (``last`` (3, K)), all of them with ``everything``;
    returns how many (first entries of ``active_out``)."""
    count = 0
    limit = moved * moved
    for k in range(nodes.shape[0]):
        n = nodes[k]
        dx = positions[0, n] - last[0, k]
        dy = positions[1, n] - last[1, k]
        dz = positions[2, n] - last[2, k]
        x_out[k, 0], x_out[k, 1], x_out[k, 2] = positions[0, n], positions[1, n], positions[2, n]
        if everything or dx * dx + dy * dy + dz * dz > limit:
            active_out[count] = k
            count += 1
    return count


def any_moved_on_own_bone(positions, nodes, own, rotations, shifts, last, moved):  # pragma: no cover - compiled
    """Whether any guarded node may have moved more than ``moved`` metres in its own bone's frame since its
    plane was chosen (``last`` (3, K), bone frame; bone ``own[k]`` posed by ``rotations`` (B, 3, 3) and
    ``shifts`` (B, 3)): a pre-test for the exact one of :meth:`.collision.BoneHalfSpaceGuard.refresh`,
    which only runs when this says yes. ``moved`` carries the caller's margin: this loop's arithmetic may
    differ from numpy's matrix product by rounding."""
    limit = moved * moved
    for k in range(nodes.shape[0]):
        n, b = nodes[k], own[k]
        dx = positions[0, n] - shifts[b, 0]
        dy = positions[1, n] - shifts[b, 1]
        dz = positions[2, n] - shifts[b, 2]
        total = 0.0
        for a in range(3):
            local = rotations[b, 0, a] * dx + rotations[b, 1, a] * dy + rotations[b, 2, a] * dz
            step = local - last[a, k]
            total += step * step
        if total > limit:
            return True
    return False


def nearest_in_bone(px, py, pz, bone, vertices, order, starts, cube_start, origin, dims, cell,
                    reach):  # pragma: no cover - compiled
    """The nearest vertex of ``bone`` closer than ``reach`` to the bone-frame point, ``(distance, row)``,
    ``(inf, -1)`` where none is; ties go to the lower vertex index, as ``cKDTree.query`` answers them."""
    nx, ny, nz = dims[bone, 0], dims[bone, 1], dims[bone, 2]
    ox, oy, oz = origin[bone, 0], origin[bone, 1], origin[bone, 2]
    cx = int(math.floor((px - ox) / cell))
    cy = int(math.floor((py - oy) / cell))
    cz = int(math.floor((pz - oz) / cell))
    span = int(math.ceil(reach / cell))
    best, pick = reach * reach, -1
    for sweep in range(2):                  # the point's own cube first: its best vertex prunes the others
        for gx in range(max(cx - span, 0), min(cx + span, nx - 1) + 1):
            ex = max(ox + gx * cell - px, px - (ox + (gx + 1) * cell), 0.0)
            for gy in range(max(cy - span, 0), min(cy + span, ny - 1) + 1):
                ey = max(oy + gy * cell - py, py - (oy + (gy + 1) * cell), 0.0)
                for gz in range(max(cz - span, 0), min(cz + span, nz - 1) + 1):
                    own = gx == cx and gy == cy and gz == cz
                    if own != (sweep == 0):
                        continue
                    ez = max(oz + gz * cell - pz, pz - (oz + (gz + 1) * cell), 0.0)
                    if ex * ex + ey * ey + ez * ez > best:
                        continue
                    cube = cube_start[bone] + (gx * ny + gy) * nz + gz
                    for s in range(starts[cube], starts[cube + 1]):
                        v = order[s]
                        dx = px - vertices[v, 0]
                        dy = py - vertices[v, 1]
                        dz = pz - vertices[v, 2]
                        d2 = dx * dx + dy * dy + dz * dz
                        if d2 < best or (d2 == best and v < pick):
                            best, pick = d2, v
    if pick < 0:
        return math.inf, -1
    found = math.sqrt(best)
    if found < reach:
        return found, pick
    return math.inf, -1


def nearest_bone_planes(x, active, count, rotations, shifts, vertices, normals, order, starts,
                        cube_start, origin, dims, cell, reach, facing, use_facing, owner, local_point,
                        local_normal, best, local_own):  # pragma: no cover - compiled
    """For each active node (rows ``active[:count]`` of ``x``, world (K, 3)): over the bones in order, the
    nearest vertex within reach in the bone's frame, taken when closer than the best so far and (with
    ``use_facing``) its posed normal faces the node's rest normal (dot > 0.2). Updates ``owner`` (K,),
    ``local_point``/``local_normal`` (3, K) where a vertex is taken; ``best`` (count,) gets the distance (inf
    where none), ``local_own`` (count, 3) the node in its (new) bone's frame."""
    bones = rotations.shape[0]
    for j in range(count):
        k = active[j]
        nearest = math.inf
        for b in range(bones):
            rx, ry, rz = x[k, 0] - shifts[b, 0], x[k, 1] - shifts[b, 1], x[k, 2] - shifts[b, 2]
            px = rx * rotations[b, 0, 0] + ry * rotations[b, 1, 0] + rz * rotations[b, 2, 0]
            py = rx * rotations[b, 0, 1] + ry * rotations[b, 1, 1] + rz * rotations[b, 2, 1]
            pz = rx * rotations[b, 0, 2] + ry * rotations[b, 1, 2] + rz * rotations[b, 2, 2]
            dist, v = nearest_in_bone(px, py, pz, b, vertices, order, starts, cube_start, origin,
                                      dims, cell, reach)
            if v < 0 or not dist < nearest:
                continue
            if use_facing:
                turned = 0.0
                for i in range(3):
                    world = (rotations[b, i, 0] * normals[v, 0] + rotations[b, i, 1] * normals[v, 1]
                             + rotations[b, i, 2] * normals[v, 2])
                    turned += world * facing[i, k]
                if not turned > 0.2:
                    continue
            nearest = dist
            owner[k] = b
            for i in range(3):
                local_point[i, k] = vertices[v, i]
                local_normal[i, k] = normals[v, i]
        best[j] = nearest
        b = owner[k]
        rx, ry, rz = x[k, 0] - shifts[b, 0], x[k, 1] - shifts[b, 1], x[k, 2] - shifts[b, 2]
        for i in range(3):
            local_own[j, i] = rx * rotations[b, 0, i] + ry * rotations[b, 1, i] + rz * rotations[b, 2, i]


def pose_planes(active, count, bone, rotations, shifts, local_point, local_normal, point,
                normal):  # pragma: no cover - compiled
    """Pose the planes of the nodes ``active[:count]`` with their bones (``point = R local_point + t``,
    ``normal = R local_normal``)."""
    for j in range(count):
        k = active[j]
        b = bone[k]
        for i in range(3):
            point[i, k] = (rotations[b, i, 0] * local_point[0, k] + rotations[b, i, 1] * local_point[1, k]
                           + rotations[b, i, 2] * local_point[2, k] + shifts[b, i])
            normal[i, k] = (rotations[b, i, 0] * local_normal[0, k] + rotations[b, i, 1] * local_normal[1, k]
                            + rotations[b, i, 2] * local_normal[2, k])


def _ratio(num, den):  # pragma: no cover - compiled
    return num / (den if abs(den) > 1e-300 else 1e-300)


def closest_on_candidates(vertices, faces, points, candidates, best_point, best_face, best_bary,
                          best_distance):  # pragma: no cover - compiled
    """:func:`..core.geometry.closest_points` after its KD-tree query: the closest point of each point
    (K, 3) on its ``candidates`` (K, C) triangles, with the arithmetic of
    :func:`..core.geometry.closest_points_on_triangles` written out in the same order (a dot product as
    numpy's ``einsum`` sums it on x86-64, x + z first, then y; Ericson's regions tried from the lowest to the
    highest priority), the first of equal distances, and a NaN distance never winning. Fills ``best_*`` as
    that function returns them (bit for bit where numpy sums in that order; a test checks it)."""
    for i in range(points.shape[0]):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        found = False
        for j in range(candidates.shape[1]):
            f = candidates[i, j]
            a0, a1, a2 = vertices[faces[f, 0], 0], vertices[faces[f, 0], 1], vertices[faces[f, 0], 2]
            b0, b1, b2 = vertices[faces[f, 1], 0], vertices[faces[f, 1], 1], vertices[faces[f, 1], 2]
            c0, c1, c2 = vertices[faces[f, 2], 0], vertices[faces[f, 2], 1], vertices[faces[f, 2], 2]
            ab0, ab1, ab2 = b0 - a0, b1 - a1, b2 - a2
            ac0, ac1, ac2 = c0 - a0, c1 - a1, c2 - a2
            ap0, ap1, ap2 = px - a0, py - a1, pz - a2
            bp0, bp1, bp2 = px - b0, py - b1, pz - b2
            cp0, cp1, cp2 = px - c0, py - c1, pz - c2
            d1 = (ab0 * ap0 + ab2 * ap2) + ab1 * ap1          # numpy's einsum order: x, z, then y
            d2 = (ac0 * ap0 + ac2 * ap2) + ac1 * ap1
            d3 = (ab0 * bp0 + ab2 * bp2) + ab1 * bp1
            d4 = (ac0 * bp0 + ac2 * bp2) + ac1 * bp1
            d5 = (ab0 * cp0 + ab2 * cp2) + ab1 * cp1
            d6 = (ac0 * cp0 + ac2 * cp2) + ac1 * cp1
            va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
            denom = va + vb + vc
            v, w = _ratio(vb, denom), _ratio(vc, denom)
            u = 1.0 - v - w
            if (va <= 0) and (d4 - d3 >= 0) and (d5 - d6 >= 0):
                t = _ratio(d4 - d3, (d4 - d3) + (d5 - d6))
                u, v, w = 0.0, 1 - t, t
            if (vb <= 0) and (d2 >= 0) and (d6 <= 0):
                t = _ratio(d2, d2 - d6)
                u, v, w = 1 - t, 0.0, t
            if (d6 >= 0) and (d5 <= d6):
                u, v, w = 0.0, 0.0, 1.0
            if (vc <= 0) and (d1 >= 0) and (d3 <= 0):
                t = _ratio(d1, d1 - d3)
                u, v, w = 1 - t, t, 0.0
            if (d3 >= 0) and (d4 <= d3):
                u, v, w = 0.0, 1.0, 0.0
            if (d1 <= 0) and (d2 <= 0):
                u, v, w = 1.0, 0.0, 0.0
            u = 0.0 if u < 0.0 else (1.0 if u > 1.0 else u)
            v = 0.0 if v < 0.0 else (1.0 if v > 1.0 else v)
            w = 0.0 if w < 0.0 else (1.0 if w > 1.0 else w)
            q0 = u * a0 + v * b0 + w * c0
            q1 = u * a1 + v * b1 + w * c1
            q2 = u * a2 + v * b2 + w * c2
            e0, e1, e2 = q0 - px, q1 - py, q2 - pz
            d = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
            if not d < math.inf:                        # NaN never wins
                continue
            if not found or d < best_distance[i]:
                found = True
                best_distance[i] = d
                best_point[i, 0], best_point[i, 1], best_point[i, 2] = q0, q1, q2
                best_face[i] = f
                best_bary[i, 0], best_bary[i, 1], best_bary[i, 2] = u, v, w
        if not found:
            best_distance[i] = math.inf
            best_point[i, 0] = best_point[i, 1] = best_point[i, 2] = 0.0
            best_face[i] = 0
            best_bary[i, 0] = best_bary[i, 1] = best_bary[i, 2] = 0.0
