# SPDX-License-Identifier: GPL-3.0-or-later
"""The eye openings of the artist's mesh, seen from the front (thesis 3.1.2 "Creating New Animatable Head
Models from the Template" and "Eyes, Teeth, Tongue": the lids are skin, and the eyeball shows between them).

The lid landmarks are only as good as the landmark fit, and over an eye opening nothing holds them: on a
mesh whose lids fold back into an eye socket instead of ending at a hole (the MakeHuman base mesh) the
whole eye contour can settle on one lid, and the landmarks' own upper and lower lid then lie next to each
other on the same skin. So the opening is looked for on the mesh itself: a front view (orthographic, along
+Y in head space) of the skin around the landmark eye is rasterised, and the opening is the region where
the first skin hit is missing (a hole) or lies well behind the lids (a socket's lining seen through the
opening): the largest such region around the landmark eye that stays clear of the view's edges. Where the
face turns back steeply beside the eye (a narrow face: its temple falls more than ``DEPTH`` behind the lids
within a quarter of the eye's width of the outer canthus), that region runs off the view through the
canthus; the test is then made deeper (``DEPTH_STEPS``) until the opening stands on its own (a socket's
lining or a hole lies 10-40 mm behind the lids, the temple a few millimetres); where there is none even
then, the view is made taller (``REACH``: a lid contour fitted 3 mm too high cut the opening off). Its top and bottom edge,
column by column, are the lid margins: the points of the skin just above and below it.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage, sparse
from scipy.sparse.csgraph import connected_components

from ..core.geometry import similarity_transform

__all__ = ["EyeOpening", "find_eye_opening", "snap_lids", "main_piece", "PIXEL", "DEPTH", "MIN_HEIGHT"]

PIXEL = 0.00025      # m: raster step of the front view
DEPTH = 0.003        # m behind the lid landmarks from which a hit is not lid skin (a socket seen through)
MIN_HEIGHT = 0.001   # m: an opening must be at least this tall somewhere
MIN_WIDTH = 0.4      # ... and at least this share of the landmark eye's width
SAMPLES = 17         # points per lid margin (corners included)
EDGE = 4             # pixels beyond an opening's edge over which the margin's front is looked for
REACH = (0.6, 0.9)   # the view reaches this share of the landmark eye's width above and below its centre;
                     # the wider view only where the narrower one has no opening
DEPTH_STEPS = (1, 2, 4, 8)   # DEPTH times these: deeper tests where the shallower one's hollow runs off the view


class EyeOpening:
    """An eye opening found on the mesh: the upper and lower lid margins (k, 3), head space, sorted along +X
    and sharing their two corners, and the largest height of the opening (m)."""

    def __init__(self, upper: np.ndarray, lower: np.ndarray, height: float) -> None:
        self.upper, self.lower, self.height = upper, lower, float(height)


def _depth_image(vertices: np.ndarray, faces: np.ndarray, xs: np.ndarray, zs: np.ndarray) -> np.ndarray:
    """First-hit Y (the nearest skin seen from -Y) per pixel (len(zs), len(xs)); inf where no triangle."""
    tri = vertices[faces]
    keep = ((tri[:, :, 0].max(1) >= xs[0]) & (tri[:, :, 0].min(1) <= xs[-1]) & (tri[:, :, 2].max(1) >= zs[0])
            & (tri[:, :, 2].min(1) <= zs[-1]))
    tri = tri[keep]
    a, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    det = e1[:, 0] * e2[:, 2] - e1[:, 2] * e2[:, 0]
    ok = np.abs(det) > 1e-14
    a, e1, e2, det, tri = a[ok], e1[ok], e2[ok], det[ok], tri[ok]
    z_lo, z_hi = tri[:, :, 2].min(1), tri[:, :, 2].max(1)
    depth = np.full((len(zs), len(xs)), np.inf)
    rows = 8
    for begin in range(0, len(zs), rows):
        z = zs[begin:begin + rows]
        near = np.flatnonzero((z_hi >= z[0]) & (z_lo <= z[-1]))
        if not len(near):
            continue
        px, pz = np.meshgrid(xs, z)
        dx = px.ravel()[:, None] - a[None, near, 0]
        dz = pz.ravel()[:, None] - a[None, near, 2]
        u = (dx * e2[None, near, 2] - dz * e2[None, near, 0]) / det[None, near]
        v = (e1[None, near, 0] * dz - e1[None, near, 2] * dx) / det[None, near]
        y = a[None, near, 1] + u * e1[None, near, 1] + v * e2[None, near, 1]
        y = np.where((u >= -1e-9) & (v >= -1e-9) & (u + v <= 1 + 1e-9), y, np.inf)
        depth[begin:begin + rows] = y.min(axis=1).reshape(len(z), len(xs))
    return depth


def _margin(depth: np.ndarray, columns: np.ndarray, rows: np.ndarray, step: int, xs, zs, lid_depth) -> np.ndarray:
    """Skin points just outside the opening, from its edge pixel ``rows`` of each of ``columns`` one pixel
    on in the direction ``step`` (+1 up, -1 down); their depth is the frontmost skin within ``EDGE`` of
    there (the skin at a margin that turns into a socket is seen edge-on, any depth along it)."""
    edge = np.clip(rows + step, 0, len(zs) - 1)
    reach = np.clip(edge[None] + step * np.arange(EDGE)[:, None], 0, len(zs) - 1)
    y = depth[reach, columns[None]].min(axis=0)
    y = np.where(np.isfinite(y), y, lid_depth[columns])
    return np.column_stack([xs[columns], y, zs[edge]])


def _opening_region(hollow: np.ndarray, width: float):
    """The largest region of ``hollow`` pixels clear of the view's edges, if it is tall and wide enough:
    its columns, top and bottom row per column, and its height (m); None otherwise."""
    label, count = ndimage.label(hollow)
    if count == 0:
        return None
    edge = np.unique(np.concatenate([label[0], label[-1], label[:, 0], label[:, -1]]))
    area = np.bincount(label.ravel(), minlength=count + 1)
    area[edge] = 0
    area[0] = 0
    best = int(np.argmax(area))
    if area[best] == 0:
        return None
    region = label == best
    columns = np.flatnonzero(region.any(axis=0))
    top = region.shape[0] - 1 - np.argmax(region[::-1, columns], axis=0)      # highest opening pixel per column
    bottom = np.argmax(region[:, columns], axis=0)
    height = float((top - bottom + 1).max() * PIXEL)
    if height < MIN_HEIGHT or (columns[-1] - columns[0] + 1) * PIXEL < MIN_WIDTH * width:
        return None
    return columns, top, bottom, height


def find_eye_opening(vertices: np.ndarray, faces: np.ndarray, upper: np.ndarray,
                     lower: np.ndarray) -> EyeOpening | None:
    """The eye opening around the landmark lid contours ``upper``/``lower`` (k, 3; corner to corner, head
    space) on the skin ``vertices``/``faces`` (module docstring); None if the mesh has none there."""
    contour = np.vstack([upper, lower])
    width = float(np.linalg.norm(upper[0] - upper[-1]))
    centre_z = float(contour[:, 2].mean())
    xs = np.arange(contour[:, 0].min() - 0.25 * width, contour[:, 0].max() + 0.25 * width, PIXEL)
    order = np.argsort(contour[:, 0], kind="stable")
    lid_depth = np.interp(xs, contour[order, 0], contour[order, 1])     # the lids' depth along the eye
    for reach in REACH:
        zs = np.arange(centre_z - reach * width, centre_z + reach * width, PIXEL)
        depth = _depth_image(vertices, faces, xs, zs)
        for factor in DEPTH_STEPS:
            found = _opening_region(depth > lid_depth[None] + factor * DEPTH, width)
            if found is not None:
                break
        if found is not None:
            break
    else:
        return None
    columns, top, bottom, height = found
    upper_m = _margin(depth, columns, top, 1, xs, zs, lid_depth)
    lower_m = _margin(depth, columns, bottom, -1, xs, zs, lid_depth)
    pick = np.unique(np.linspace(0, len(columns) - 1, SAMPLES).round().astype(int))
    upper_m, lower_m = upper_m[pick], lower_m[pick]
    for end in (0, -1):                 # the corners: where the two margins meet, on the lids' depth
        corner = 0.5 * (upper_m[end] + lower_m[end])
        upper_m[end] = lower_m[end] = corner
    return EyeOpening(upper_m, lower_m, height)


def main_piece(faces: np.ndarray, landmark_triangles: np.ndarray) -> np.ndarray:
    """Which ``faces`` are on the connected piece of the mesh most landmarks lie on (not eyeballs, lashes
    or teeth modelled as pieces of their own)."""
    n = int(faces.max()) + 1
    rows = faces[:, [0, 1, 2]].ravel()
    cols = faces[:, [1, 2, 0]].ravel()
    graph = sparse.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    _, component = connected_components(graph, directed=False)
    main = np.bincount(component[faces[landmark_triangles, 0]]).argmax()
    return component[faces[:, 0]] == main


def _along(margin: np.ndarray, contour: np.ndarray) -> np.ndarray:
    """The lid landmarks ``contour`` (corner to corner) moved onto ``margin`` (sorted along +X): each at the
    same fraction of the way from corner to corner, measured along X."""
    a, b = contour[0, 0], contour[-1, 0]
    t = (contour[:, 0] - a) / (b - a if abs(b - a) > 1e-12 else 1e-12)
    start, end = (margin[0, 0], margin[-1, 0]) if a < b else (margin[-1, 0], margin[0, 0])
    x = start + np.clip(t, 0.0, 1.0) * (end - start)
    return np.column_stack([x, np.interp(x, margin[:, 0], margin[:, 1]), np.interp(x, margin[:, 0], margin[:, 2])])


def snap_lids(positions: np.ndarray, vertices: np.ndarray, faces: np.ndarray, canonical: np.ndarray,
              contours: dict) -> tuple[np.ndarray, np.ndarray]:
    """Lid landmarks moved onto the edges of the mesh's eye openings (module docstring): ``positions``
    (468, 3) the located landmarks and ``vertices``/``faces`` the mesh, in the mesh's coordinates;
    ``canonical`` the canonical face (head space) that says which way the face looks. Returns the new
    positions (not yet on the surface: project them) and the ids of the landmarks that moved. An eye
    without an opening keeps its landmarks."""
    to_head = similarity_transform(positions, canonical)
    head = vertices @ to_head[:3, :3].T + to_head[:3, 3]
    landmarks = positions @ to_head[:3, :3].T + to_head[:3, 3]
    out, moved = landmarks.copy(), []
    for side in ("L", "R"):
        upper, lower = contours[f"eye_{side}_upper"], contours[f"eye_{side}_lower"]
        found = find_eye_opening(head, faces, landmarks[upper], landmarks[lower])
        if found is None:
            continue
        out[upper] = _along(found.upper, landmarks[upper])
        out[lower[1:-1]] = _along(found.lower, landmarks[lower])[1:-1]      # the corners are shared
        moved += [np.asarray(upper), np.asarray(lower[1:-1])]
    back = np.linalg.inv(to_head)
    ids = np.unique(np.concatenate(moved)) if moved else np.zeros(0, np.int64)
    result = positions.copy()
    result[ids] = out[ids] @ back[:3, :3].T + back[:3, 3]
    return result, ids
