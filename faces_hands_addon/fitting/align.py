# SPDX-License-Identifier: GPL-3.0-or-later
"""Rough similarity alignment of the canonical face onto an arbitrary head mesh.

Thesis 3.1.2 "Creating New Animatable Head Models from the Template" needs feature points "at
corresponding locations on the target skin mesh"; before a non-rigid registration can find them the
template must sit on the target's face at roughly the right place and size. Two steps:

1. **Depth-image search** (2.5D template matching): the target's front surface is rendered into an
   orthographic depth image (as seen along the viewing direction, from area-weighted surface samples),
   and the template's inner face (eyes, nose, mouth, chin) is slid over it at a ladder of scales. The
   cost is the masked sum of squared depth differences with a free depth offset, plus a penalty for
   template pixels over empty background, computed for all positions at once with FFT correlations
   (normalised cross-correlation in the sense of Lewis, "Fast Normalized Cross-Correlation", 1995).
   Because it compares shape, not "the frontmost point", it finds the face on a full head whose
   chest, hair cap or ears stick out further than the nose, and it tells a head facing -Y from one
   facing +Y / +-X / lying face-up / upside down (:mod:`.orientation` runs it for the 24 axis
   orientations and tilted variants; ``FACINGS`` below are the tilts and the old named hypotheses). See-through openings (eyes, mouth of a mesh with a
   back of the head behind them) are removed from the depth image by a grey-value opening, so they
   cost like empty background instead of dominating the squared differences.
2. **Scaled rigid ICP**, point-to-plane (Chen & Medioni 1992, linearised as in Low 2004) with a small
   point-to-point term, closest points on the target triangles, trimmed outlier rejection (Chetverikov
   et al. 2002) and rejection of incompatible normals and of mesh borders.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import fft, ndimage
from scipy.interpolate import LinearNDInterpolator

from ..core.geometry import vertex_normals
from .surface import TargetSurface, least_squares
from .template import FaceTemplate, face_template

__all__ = ["Facing", "FACINGS", "COARSE_SCALES", "Similarity", "DepthMatch", "search_orientations", "refine_search",
           "tilted_front",
           "scaled_rigid_icp", "surface_samples"]


@dataclass(frozen=True)
class Facing:
    """A hypothesis for where the head looks (``forward``) and where its top is (``up``). ``front`` marks
    the accepted orientation (facing -Y, Z up) and its slightly tilted variants."""
    name: str
    forward: tuple
    up: tuple
    advice: str
    front: bool = False

    def rotation(self) -> np.ndarray:
        """World -> canonical frame (face along -Y, top along +Z, character's left along +X)."""
        f, u = np.asarray(self.forward, float), np.asarray(self.up, float)
        return np.stack([np.cross(u, f), -f, u])


def tilted_front(name: str, axis: int, degrees: float) -> Facing:
    """-Y / Z-up turned by ``degrees`` about world axis ``axis`` (0 pitch, 1 roll, 2 yaw)."""
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    turn = np.eye(3)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    turn[i, i], turn[i, j], turn[j, i], turn[j, j] = c, -s, s, c
    return Facing(name, tuple(turn @ (0.0, -1.0, 0.0)), tuple(turn @ (0.0, 0.0, 1.0)), "", True)


# The front hypotheses cover heads tilted by up to about +-22 degrees (pitch, yaw) / +-16 (roll); the
# others are the usual import mistakes, each with the rotation that fixes it.
FACINGS = (
    Facing("-Y", (0, -1, 0), (0, 0, 1), "", True),
    *(tilted_front(f"-Y {kind} {angle:+d}", axis, angle)
      for kind, axis, step in (("pitch", 0, 15), ("yaw", 2, 15), ("roll", 1, 10)) for angle in (-step, step)),
    Facing("+Y", (0, 1, 0), (0, 0, 1),
           "the mesh seems to face +Y; rotate it to face -Y (Blender's front view), e.g. 180 degrees about Z"),
    Facing("+X", (1, 0, 0), (0, 0, 1),
           "the mesh seems to face +X; rotate it -90 degrees about Z to face -Y (Blender's front view)"),
    Facing("-X", (-1, 0, 0), (0, 0, 1),
           "the mesh seems to face -X; rotate it 90 degrees about Z to face -Y (Blender's front view)"),
    Facing("+Z", (0, 0, 1), (0, 1, 0),
           "the mesh seems to lie face-up (facing +Z, top of the head towards +Y), as after a Y-up import "
           "without axis conversion; rotate it 90 degrees about X so it faces -Y with Z up"),
    Facing("upside down", (0, -1, 0), (0, 0, -1),
           "the mesh seems to be upside down; rotate it 180 degrees about Y so the head's top is at +Z"),
)


@dataclass(frozen=True)
class Similarity:
    """``world = scale * rotation @ template + translation``."""
    scale: float
    rotation: np.ndarray
    translation: np.ndarray

    def apply(self, points: np.ndarray) -> np.ndarray:
        return self.scale * points @ self.rotation.T + self.translation


@dataclass(frozen=True)
class DepthMatch:
    """Best placement of the template's inner face in one orientation's depth image."""
    facing: Facing
    score: float            # normalised cost: ~0.1 a good face match, ~1 no face-like relief
    similarity: Similarity
    coverage: float         # share of the template's pixels that landed on the target


_COARSE_PIXELS = 64         # depth-image resolution along the target's longer side (orientation search)
_COARSE_SCALES = np.geomspace(0.16, 1.3, 11)   # template height / target extent tried in the coarse search
COARSE_SCALES = _COARSE_SCALES
_FINE_FACE_PIXELS = 60      # the template's inner face spans this many pixels in the fine search
_FINE_SCALES = np.geomspace(1 / 1.15, 1.15, 5)  # around the coarse scale
_COARSE_SAMPLES = 60_000
COARSE_SAMPLES = _COARSE_SAMPLES
_FINE_SAMPLES_PER_PIXEL = 12
_BACKGROUND_PENALTY = 0.5   # cost of a template pixel over empty background, in template-variance units
_MIN_COVERAGE = 0.55
_RIGID_SETTLED = 2e-4       # rigid ICP stops when an update moves the face by less than this (face widths)
_HOLE_OPENING = 9           # pixels; a depth peak narrower than this and ...
_HOLE_DEPTH = 6.0           # ... deeper than this many pixel sizes is a hole (see-through eye/mouth opening)


def _rotated(points: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """``points @ rotation.T`` without BLAS (large (N, 3) x (3, 3) products spawn BLAS threads for no gain)."""
    return np.einsum("ij,kj->ki", rotation, points)


def surface_samples(vertices: np.ndarray, faces: np.ndarray, areas: np.ndarray, count: int,
                    rng: np.random.Generator) -> np.ndarray:
    """``count`` points uniformly distributed over the area of the given triangles (seeded)."""
    tri = rng.choice(len(faces), size=count, p=areas / areas.sum())
    r1, r2 = rng.random(count), rng.random(count)
    root = np.sqrt(r1)
    bary = np.stack([1 - root, root * (1 - r2), root * r2], axis=1)
    return (bary[:, :, None] * vertices[faces[tri]]).sum(axis=1)


class _TemplateDepth:
    """The template's inner face as a height field ``y(x, z)`` (canonical frame), for any pixel size.

    Interpolated once on a fine grid (0.5 mm canonical) and resampled bilinearly per scale."""
    _STEP = 0.0005

    def __init__(self, template: FaceTemplate):
        v = template.vertices
        inner = v[template.match_region][:, [0, 2]]
        self._low, self._high = inner.min(axis=0), inner.max(axis=0)
        self._centre_z = 0.5 * (self._low[1] + self._high[1])
        self._half = 0.5 * (self._high - self._low)
        self.height = float(self._high[1] - self._low[1])
        xs = np.arange(self._low[0] - self._STEP, self._high[0] + 2 * self._STEP, self._STEP)
        zs = np.arange(self._low[1] - self._STEP, self._high[1] + 2 * self._STEP, self._STEP)
        gx, gz = np.meshgrid(xs, zs)
        fine = LinearNDInterpolator(v[:, [0, 2]], v[:, 1])(gx, gz)
        self._defined = np.isfinite(fine).astype(np.float64)
        self._fine = np.where(np.isfinite(fine), fine, 0.0)
        self._origin = np.array([xs[0], zs[0]])

    def image(self, scale: float, pixel: float):
        """Depth (target units, relative to the masked mean), mask, canonical (x, z) of pixel (0, 0), and
        the masked mean depth (canonical units)."""
        step = pixel / scale
        xs = np.arange(self._low[0], self._high[0] + step, step)
        zs = np.arange(self._low[1], self._high[1] + step, step)
        gx, gz = np.meshgrid(xs, zs)
        where = np.stack([(gz - self._origin[1]) / self._STEP, (gx - self._origin[0]) / self._STEP])
        depth = ndimage.map_coordinates(self._fine, where, order=1, mode="nearest")
        defined = ndimage.map_coordinates(self._defined, where, order=1, mode="constant") > 0.999
        inside = (gx / self._half[0]) ** 2 + ((gz - self._centre_z) / self._half[1]) ** 2 < 1.0
        mask = inside & defined
        mean = float(depth[mask].mean())
        depth = np.where(mask, (depth - mean) * scale, 0.0)
        return depth, mask.astype(np.float64), np.array([xs[0], zs[0]]), mean


@lru_cache(maxsize=1)
def _template_depth() -> _TemplateDepth:
    return _TemplateDepth(face_template())


def _depth_image(points: np.ndarray, pixel: float):
    """Orthographic depth image seen from -Y (frontmost y per pixel, +inf = nothing), 1-pixel gaps filled,
    see-through holes (narrow, much deeper than their surroundings) marked as nothing."""
    low = points[:, [0, 2]].min(axis=0)
    ij = np.floor((points[:, [2, 0]] - low[::-1]) / pixel).astype(np.int64)
    shape = tuple(ij.max(axis=0) + 1)
    flat = ij[:, 0] * shape[1] + ij[:, 1]
    order = np.lexsort((points[:, 1], flat))
    first = order[np.concatenate([[True], flat[order][1:] != flat[order][:-1]])]
    depth = np.full(shape[0] * shape[1], np.inf)
    depth[flat[first]] = points[first, 1]
    depth = depth.reshape(shape)
    gaps = ~np.isfinite(depth)
    depth[gaps] = ndimage.minimum_filter(depth, size=3, mode="constant", cval=np.inf)[gaps]
    opened = ndimage.grey_opening(depth, size=_HOLE_OPENING, mode="constant", cval=np.inf)
    with np.errstate(invalid="ignore"):
        depth[depth - opened > _HOLE_DEPTH * pixel] = np.inf
    return depth, low


def _match_in_view(points: np.ndarray, pixel: float, scales, template_depth: _TemplateDepth):
    """Best (score, scale, template->view shift, coverage) over all positions and the given scales."""
    depth, low = _depth_image(points, pixel)
    valid = np.isfinite(depth)
    reference = float(np.median(depth[valid]))
    d = np.where(valid, depth - reference, 0.0)
    images = [template_depth.image(s, pixel) for s in scales]
    pad = max(max(img[0].shape) for img in images)
    canvas = (depth.shape[0] + 2 * pad, depth.shape[1] + 2 * pad)
    shape = tuple(fft.next_fast_len(n, real=True) for n in canvas)

    def placed(image):
        out = np.zeros(canvas)
        out[pad:pad + image.shape[0], pad:pad + image.shape[1]] = image
        return fft.rfft2(out, shape)

    f_v, f_dv, f_ddv = placed(valid.astype(float)), placed(d), placed(d * d)
    best = (np.inf, None, None, 0.0)
    for scale, (t, m, origin, mean_depth) in zip(scales, images):
        f_m, f_tm, f_ttm = (np.conj(fft.rfft2(a, shape)) for a in (m, t * m, t * t * m))
        rows, cols = canvas[0] - m.shape[0] + 1, canvas[1] - m.shape[1] + 1

        def corr(a, b):
            return fft.irfft2(a * b, shape)[:rows, :cols]

        n_valid = corr(f_v, f_m)
        s_d, s_dd, s_dt = corr(f_dv, f_m), corr(f_ddv, f_m), corr(f_dv, f_tm)
        s_t, s_tt = corr(f_v, f_tm), corr(f_v, f_ttm)
        total = m.sum()
        variance = float((t * t * m).sum() / total)
        ok = n_valid > _MIN_COVERAGE * total
        n = np.where(ok, n_valid, 1.0)
        ssd = s_dd - 2 * s_dt + s_tt - (s_d - s_t) ** 2 / n
        score = np.where(ok, ssd / (n * variance) + _BACKGROUND_PENALTY * (1 - n_valid / total), np.inf)
        at = np.unravel_index(np.argmin(score), score.shape)
        if score[at] < best[0]:
            offset = float((s_d[at] - s_t[at]) / n[at]) + reference - scale * mean_depth
            # template pixel (0, 0) sits on canvas pixel `at`, i.e. on depth-image pixel `at - pad`
            x0 = low[0] + (at[1] - pad + 0.5) * pixel
            z0 = low[1] + (at[0] - pad + 0.5) * pixel
            shift = np.array([x0 - scale * origin[0], offset, z0 - scale * origin[1]])
            best = (float(score[at]), float(scale), shift, float(n_valid[at] / total))
    return best


def _depth_match(facing: Facing, to_view: np.ndarray, found) -> DepthMatch | None:
    score, scale, shift, coverage = found
    if scale is None:
        return None
    # template -> view frame is scale * v + shift; view -> world is to_view.T
    return DepthMatch(facing, score, Similarity(scale, to_view.T, shift @ to_view), coverage)


def search_orientations(vertices: np.ndarray, faces: np.ndarray, areas: np.ndarray, template: FaceTemplate,
                        rng: np.random.Generator, facings=FACINGS, ladder=None,
                        pixels: int = _COARSE_PIXELS, samples: np.ndarray | None = None) -> list[DepthMatch]:
    """Coarse depth-image search (whole mesh, all scales of ``ladder``, template height / target extent,
    default ``_COARSE_SCALES``) in each orientation hypothesis, ``pixels`` along the longer side; on
    ``samples`` (surface points) when given, else on ``_COARSE_SAMPLES`` new ones drawn with ``rng``."""
    if samples is None:
        samples = surface_samples(vertices, faces, areas, _COARSE_SAMPLES, rng)
    template_depth = _template_depth()
    matches = []
    for facing in facings:
        to_view = facing.rotation()
        points = _rotated(samples, to_view)
        extent = np.ptp(points[:, [0, 2]], axis=0).max()
        scales = extent / template_depth.height * (_COARSE_SCALES if ladder is None else np.asarray(ladder))
        match = _depth_match(facing, to_view, _match_in_view(points, extent / pixels, scales,
                                                             template_depth))
        if match is not None:
            matches.append(match)
    return matches


def refine_search(vertices: np.ndarray, faces: np.ndarray, areas: np.ndarray, template: FaceTemplate,
                  coarse: DepthMatch, rng: np.random.Generator) -> DepthMatch:
    """Repeat the search at face resolution, in a window around the coarse match, at nearby scales."""
    template_depth = _template_depth()
    to_view = coarse.facing.rotation()
    placed = coarse.similarity.apply(template.vertices) @ to_view.T
    centre = placed.mean(axis=0)
    half = 0.8 * np.ptp(placed, axis=0).max()
    view_vertices = _rotated(vertices, to_view)
    near = (np.abs(view_vertices[:, [0, 2]] - centre[[0, 2]]) < half).all(axis=1)
    window = near[faces].any(axis=1)
    if window.sum() < 8:
        return coarse
    pixel = coarse.similarity.scale * template_depth.height / _FINE_FACE_PIXELS
    count = int(min(max(_FINE_SAMPLES_PER_PIXEL * (2 * half / pixel) ** 2, 20_000), 400_000))
    points = surface_samples(view_vertices, faces[window], areas[window], count, rng)
    points = points[(np.abs(points[:, [0, 2]] - centre[[0, 2]]) < half).all(axis=1)]
    found = _match_in_view(points, pixel, coarse.similarity.scale * _FINE_SCALES, template_depth)
    match = _depth_match(coarse.facing, to_view, found)
    return match if match is not None and match.score <= coarse.score * 1.5 else coarse


def _rotation_from_vector(omega: np.ndarray) -> np.ndarray:
    """Rotation by the angle ``|omega|`` about ``omega`` (Rodrigues' formula)."""
    angle = float(np.linalg.norm(omega))
    if angle < 1e-15:
        return np.eye(3)
    k = omega / angle
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx


def correspondence_mask(hit, normals: np.ndarray, max_angle_degrees: float, distance_factor: float,
                        min_distance: float, keep_fraction: float = 1.0) -> np.ndarray:
    """Usable template->surface correspondences: not on a border, compatible normals, not too far
    (``distance_factor`` x median, at least ``min_distance``), then the best ``keep_fraction`` (trimming)."""
    ok = ~hit.on_border & ((normals * hit.normals).sum(1) > np.cos(np.radians(max_angle_degrees)))
    if ok.sum() < 8:
        return ok
    limit = max(distance_factor * float(np.median(hit.distances[ok])), min_distance)
    ok &= hit.distances <= limit
    if keep_fraction < 1.0 and ok.sum() > 8:
        cut = np.quantile(hit.distances[ok], keep_fraction)
        ok &= hit.distances <= cut
    return ok


def scaled_rigid_icp(template: FaceTemplate, surface: TargetSurface, start: Similarity, *,
                     iterations: int = 30, keep_fraction: float = 0.8, max_angle_degrees: float = 60.0,
                     point_weight: float = 0.1):
    """Refine a similarity transform of the template onto the surface (see module docstring).

    Returns ``(similarity, surface, flipped)``; the surface comes back with flipped normals (and
    ``flipped`` True) when the target's normals point inwards (detected from the first correspondences).
    """
    base_normals = vertex_normals(template.vertices, template.faces)
    similarity = start
    flipped = False
    for iteration in range(iterations):
        points = similarity.apply(template.vertices)
        normals = base_normals @ similarity.rotation.T
        hit = surface.closest(points)
        if iteration == 0:
            near = hit.distances <= np.quantile(hit.distances, 0.5)
            if np.median((normals[near] * hit.normals[near]).sum(1)) < 0:
                surface, flipped = surface.flipped(), True
                hit.normals = -hit.normals
        ok = correspondence_mask(hit, normals, max_angle_degrees, 3.0, 0.01 * similarity.scale * template.width,
                                 keep_fraction)
        if ok.sum() < 12:
            break
        p, q, n = points[ok], hit.points[ok], hit.normals[ok]
        centre = p.mean(axis=0)
        rel = p - centre
        plane_rows = np.column_stack([(n * rel).sum(1), np.cross(rel, n), n])
        plane_rhs = (n * (q - p)).sum(1)
        skew = np.zeros((len(rel), 3, 3))
        skew[:, 0, 1], skew[:, 0, 2] = rel[:, 2], -rel[:, 1]
        skew[:, 1, 0], skew[:, 1, 2] = -rel[:, 2], rel[:, 0]
        skew[:, 2, 0], skew[:, 2, 1] = rel[:, 1], -rel[:, 0]
        point_rows = np.concatenate([rel[:, :, None], skew, np.broadcast_to(np.eye(3), skew.shape)], axis=2)
        rows = np.vstack([plane_rows, point_weight * point_rows.reshape(-1, 7)])
        rhs = np.concatenate([plane_rhs, point_weight * (q - p).ravel()])
        size = similarity.scale * template.width
        rows[:, :4] /= size                    # column scaling: all unknowns in comparable units
        solution = least_squares(rows, rhs)
        sigma, omega, tau = float(solution[0] / size), solution[1:4] / size, solution[4:]
        turn = _rotation_from_vector(omega)
        similarity = Similarity((1 + sigma) * similarity.scale, turn @ similarity.rotation,
                                centre + (1 + sigma) * turn @ (similarity.translation - centre) + tau)
        if abs(sigma) + np.linalg.norm(omega) + np.linalg.norm(tau) / size < _RIGID_SETTLED:
            break
    return similarity, surface, flipped
