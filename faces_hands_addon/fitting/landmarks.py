# SPDX-License-Identifier: GPL-3.0-or-later
"""Automatic landmark location on an arbitrary head mesh (thesis 3.1.2 "Creating New Animatable Head
Models from the Template").

"For the deformation, feature points must be placed at corresponding locations on the target skin mesh."
MEDUSA had them placed interactively; here the 468 landmarks of MediaPipe's canonical face are found
automatically by registering the canonical face onto the target:

1. depth-image search for the face in the 24 axis orientations (:mod:`.orientation`, :mod:`.align`),
   or only in the one the caller names (``forward``/``up``);
2. scaled rigid ICP of the template onto the face region (:mod:`.align`), then a global affine ICP;
3. optimal-step non-rigid ICP (Amberg et al. 2007) with a reverse (target -> template) term and a final
   point-to-plane stage (:mod:`.nicp`);
4. each fitted template vertex is projected onto the target triangles: (triangle, barycentric) per
   landmark, so markers can be re-projected after the artist drags them (:func:`.project_to_surface`);
5. the lid landmarks, which nothing holds over an eye opening, are moved onto the edges of the mesh's eye
   openings seen from the front (:mod:`.eye_openings`);
6. on a head that is its own mirror image the landmarks are made mirror images of each other
   (:mod:`.symmetry`), so the rig moves both halves alike.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .align import scaled_rigid_icp
from .nicp import affine_icp, nonrigid_icp, plane_refinement
from .orientation import choose_orientation
from .quality import FitRefused, check_fit, refusal
from ..core.blas import one_blas_thread
from ..core.geometry import checked_mesh, triangle_normals
from .eye_openings import main_piece, snap_lids
from .surface import TargetSurface, project_to_surface
from .symmetry import symmetric_landmarks, symmetry_plane
from .template import LEFT_TRAGUS, RIGHT_TRAGUS, face_template

__all__ = ["LandmarkFit", "locate_landmarks", "MAX_RMS_FRACTION", "MIN_MATCHED_FRACTION"]

MAX_RMS_FRACTION = 0.04        # a fit whose RMS distance exceeds 4 % of the face width failed
MIN_MATCHED_FRACTION = 0.5     # ... as does one where fewer than half the landmarks found the surface
MAX_RETRIES = 3                # runner-up orientations tried when the best match's fit is refused
_CROP_MARGIN = 0.4             # face-region crop around the placed template, in face widths
_FACE_SAMPLES = 2000           # target points for the reverse (target -> template) term


@dataclass(frozen=True)
class LandmarkFit:
    """The 468 landmarks located on a target mesh (all positions in the target's units and axes).

    ``positions[i]`` lies on triangle ``triangles[i]`` at ``barycentric[i]``; ``fitted_template`` is the
    registered template before that last projection and ``distances`` the gap between the two.
    ``matched[i]`` says whether landmark i had a trustworthy surface correspondence in the final
    iteration (False over eye/mouth openings, off the edge of a face mask, or where normals or distance
    disagree: such landmarks were placed by the template's stiffness and snapped to the nearest surface).
    ``rms_distance`` / ``max_distance`` are taken over the landmarks whose nearest surface point is not
    on a mesh border (so not over an opening); ``matched_fraction`` is the share of matched landmarks.
    """
    positions: np.ndarray
    triangles: np.ndarray
    barycentric: np.ndarray
    fitted_template: np.ndarray
    matched: np.ndarray
    distances: np.ndarray
    rms_distance: float
    max_distance: float
    matched_fraction: float
    face_width: float
    search_score: float
    rigid_scale: float
    rigid_rotation: np.ndarray
    rigid_translation: np.ndarray
    seed: int
    warnings: tuple = field(default=())
    orientation: dict = field(default_factory=dict)
    checks: tuple = field(default=())
    symmetric: bool = False

    @property
    def rms_fraction(self) -> float:
        """RMS distance (landmarks not over an opening) as a fraction of the face width."""
        return self.rms_distance / self.face_width

    def quality(self) -> dict:
        """A small report for the UI / logs."""
        return {"rms_distance": self.rms_distance, "max_distance": self.max_distance,
                "rms_percent_of_face_width": 100.0 * self.rms_fraction,
                "matched_fraction": self.matched_fraction, "face_width": self.face_width,
                "search_score": self.search_score, "warnings": list(self.warnings),
                "orientation": self.orientation.get("orientation"),
                "orientation_margin": self.orientation.get("margin")}


def _face_region(vertices: np.ndarray, faces: np.ndarray, placed: np.ndarray, margin: float) -> np.ndarray:
    """Triangles with a vertex inside the placed template's bounding box grown by ``margin``."""
    low, high = placed.min(axis=0) - margin, placed.max(axis=0) + margin
    inside = ((vertices >= low) & (vertices <= high)).all(axis=1)
    return np.flatnonzero(inside[faces].any(axis=1))


def _face_samples(vertices, faces, areas, surface: TargetSurface, placed: np.ndarray, rng):
    """Points spread uniformly over the target inside the placed template's reach, with their normals."""
    width = float(np.linalg.norm(placed[LEFT_TRAGUS] - placed[RIGHT_TRAGUS]))
    region = _face_region(vertices, faces, placed, 0.1 * width)
    region = region[areas[region] > 0]
    if len(region) == 0:
        return None, None
    tri = rng.choice(region, size=_FACE_SAMPLES, p=areas[region] / areas[region].sum())
    r1, r2 = rng.random(_FACE_SAMPLES), rng.random(_FACE_SAMPLES)
    root = np.sqrt(r1)
    bary = np.stack([1 - root, root * (1 - r2), root * r2], axis=1)
    points = (bary[:, :, None] * vertices[faces[tri]]).sum(axis=1)
    return points, surface.normals[tri]


def _quality_gate(positions, vertices, faces, seed: int, similarity, choice) -> list[dict]:
    """The fit-quality checks of :mod:`.quality` as dicts; raises :class:`.FitRefused` when one fails."""
    checks = check_fit(positions, vertices, faces, seed=seed)
    message = refusal(checks, choice.name)
    if message is not None:
        raise FitRefused(message, vertices, faces, positions, similarity.rotation.T, checks, choice.report())
    return [c.as_dict() for c in checks]


def _lids_on_openings(positions, hit, vertices, faces, template):
    """Step 5: the lid landmarks onto the edges of the mesh's eye openings (:mod:`.eye_openings`; nothing
    holds them over the opening), projected onto the surface; the positions, triangles and barycentrics."""
    triangles, barycentric = hit.triangles.copy(), hit.barycentric.copy()
    skin = main_piece(faces, hit.triangles)
    moved, ids = snap_lids(positions, vertices, faces[skin], template.vertices, template.contours)
    if len(ids):
        positions = positions.copy()
        positions[ids], tri, barycentric[ids] = project_to_surface(moved[ids], vertices, faces[skin])
        triangles[ids] = np.flatnonzero(skin)[tri]
    return positions, triangles, barycentric


def _mirrored(positions, triangles, barycentric, hit, vertices, faces, template, face_width):
    """Step 6: on a mirror-symmetric head, each landmark averaged with its partner's reflection and projected
    onto the main skin piece (:mod:`.symmetry`); the positions, triangles, barycentrics and whether it
    applied."""
    left = template.vertices[:, 0] > 0.0
    skin = main_piece(faces, hit.triangles)
    plane = symmetry_plane(positions, template.mirror, left, vertices, faces[skin], face_width)
    if not plane.symmetric:
        return positions, triangles, barycentric, False
    positions, tri, barycentric = project_to_surface(symmetric_landmarks(positions, template.mirror, plane),
                                                     vertices, faces[skin])
    return positions, np.flatnonzero(skin)[tri], barycentric, True


def _refuse_loose_fit(rms: float, face_width: float, matched_fraction: float, choice, shown) -> None:
    """Raise :class:`.FitRefused` when the registration stayed far from the mesh (``MAX_RMS_FRACTION`` of
    the face width) or too few landmarks found its surface (``MIN_MATCHED_FRACTION``); ``shown`` is
    (vertices, faces, landmark positions, similarity) for the refusal's preview."""
    if not (not face_width > 0 or rms > MAX_RMS_FRACTION * face_width or matched_fraction < MIN_MATCHED_FRACTION):
        return
    vertices, faces, positions, similarity = shown
    raise FitRefused(
        f"could not fit the face template to this mesh: RMS distance {100 * rms / max(face_width, 1e-30):.1f} % "
        f"of the face width (limit {100 * MAX_RMS_FRACTION:.0f} %), {100 * matched_fraction:.0f} % of the "
        f"landmarks found the surface (need {100 * MIN_MATCHED_FRACTION:.0f} %) with the face looking "
        f"{choice.name}; check that the mesh is a human face (give its axes with --forward/--up), or "
        "place the landmarks by hand", vertices, faces, positions, similarity.rotation.T,
        orientation=choice.report())


def locate_landmarks(target_vertices, target_faces, *, seed: int = 0, progress=None, forward: str | None = None,
                     up: str | None = None, check: bool = True) -> LandmarkFit:
    """Locate the 468 MediaPipe landmarks on a head mesh in any axis orientation, at any scale and position.

    ``forward``/``up`` (axis names such as ``"-Y"``, ``"+Z"``) say where the face looks and where the top
    of the head is, instead of searching all 24 orientations (:mod:`.orientation`). ``check`` runs the
    fit-quality gate (:mod:`.quality`): a fit that does not look like a face raises :class:`.FitRefused`
    (a UserError that can render a preview of where the face was looked for).
    ``target_faces`` are triangles ((M, 3) indices). ``progress(fraction, message)`` is called now and
    then. Raises :class:`UserError` for unusable meshes (no faces, NaN, degenerate, too large), a mesh
    facing another way (with the rotation to apply), or a failed fit (see ``MAX_RMS_FRACTION``).
    Deterministic for a given ``seed`` (it seeds the surface sampling of the face search), also on
    machines with other core counts: it runs on one BLAS thread (:mod:`..core.blas`).
    """
    with one_blas_thread():
        return _locate(target_vertices, target_faces, seed=seed, progress=progress, forward=forward, up=up,
                       check=check)


def _locate(target_vertices, target_faces, *, seed: int, progress, forward: str | None, up: str | None,
            check: bool) -> LandmarkFit:
    """:func:`locate_landmarks` with whatever BLAS threads the process has."""
    def report(fraction: float, message: str) -> None:
        if progress is not None:
            progress(float(fraction), message)

    vertices, faces = checked_mesh(target_vertices, target_faces)
    used = vertices[np.unique(faces)]
    centre = 0.5 * (used.min(axis=0) + used.max(axis=0))
    unit = float(np.linalg.norm(used.max(axis=0) - used.min(axis=0)))
    local = (vertices - centre) / unit                         # scale-free working coordinates
    normals, areas = triangle_normals(local, faces)
    rng = np.random.default_rng(seed)
    template = face_template()

    report(0.0, "searching for the face")
    choice = choose_orientation(local, faces, areas, template, rng, forward=forward, up=up)
    attempts = [choice] + [replace(choice, match=m, margin=1.0) for m in choice.runners_up[:MAX_RETRIES]]
    refused = None
    for attempt in attempts:
        try:
            fit = _fit_oriented(attempt, vertices, faces, local, normals, areas, unit, centre, template, rng,
                                seed, check, report)
        except FitRefused as exc:
            refused = refused or exc          # the best match's refusal is the one the user reads
            continue
        if attempt is not choice:
            fit = replace(fit, warnings=fit.warnings + (
                f"the best face match ({choice.name}) did not fit a face; fitted {attempt.name}, the next "
                "best: check the result, or give the head's axes with --forward/--up",))
        return fit
    raise refused


def _fit_oriented(choice, vertices, faces, local, normals, areas, unit, centre, template, rng, seed, check,
                  report) -> LandmarkFit:
    """Steps 2-7 of :func:`locate_landmarks` for one orientation ``choice`` (the rigid, affine, non-rigid
    and sliding fits, lids, symmetry and the quality gate); raises :class:`.FitRefused` as they do."""
    warnings = []
    match = choice.match
    report(0.25, "rigid alignment")
    placed = match.similarity.apply(template.vertices)
    width = match.similarity.scale * template.width
    region = _face_region(local, faces, placed, _CROP_MARGIN * width)
    surface = TargetSurface(local, faces, region, normals=normals)
    similarity, surface, flipped = scaled_rigid_icp(template, surface, match.similarity)
    if flipped:
        warnings.append("the mesh's normals point inwards; they were treated as flipped")

    def stage_progress(fraction: float, message: str) -> None:
        report(0.35 + 0.55 * fraction, message)

    report(0.3, "affine alignment")
    start = affine_icp(template, surface, similarity.apply(template.vertices))
    samples, sample_normals = _face_samples(local, faces, areas, surface, start, rng)
    fit = nonrigid_icp(template, surface, start, target_samples=samples, target_sample_normals=sample_normals,
                       progress=stage_progress)
    report(0.9, "sliding refinement")
    fit = plane_refinement(template, surface, fit.vertices, target_samples=samples,
                           target_sample_normals=sample_normals)
    hit = fit.hit
    positions = (hit.barycentric[:, :, None] * vertices[faces[hit.triangles]]).sum(axis=1)
    fitted = fit.vertices * unit + centre
    distances = hit.distances * unit
    matched = fit.matched
    face_width = float(np.linalg.norm(positions[LEFT_TRAGUS] - positions[RIGHT_TRAGUS]))
    matched_fraction = float(matched.mean())
    on_skin = ~hit.on_border          # landmarks over openings / off a mask's edge do not count
    rms = float(np.sqrt(np.mean(distances[on_skin] ** 2))) if on_skin.any() else float("inf")
    max_distance = float(distances[on_skin].max()) if on_skin.any() else float("inf")
    _refuse_loose_fit(rms, face_width, matched_fraction, choice, (vertices, faces, positions, similarity))
    positions, triangles, barycentric = _lids_on_openings(positions, hit, vertices, faces, template)
    positions, triangles, barycentric, symmetric = _mirrored(positions, triangles, barycentric, hit, vertices,
                                                             faces, template, face_width)
    if check:
        report(0.95, "checking the fit")
    checks = _quality_gate(positions, vertices, faces, seed, similarity, choice) if check else []
    report(1.0, "landmarks located")
    return LandmarkFit(
        positions=positions, triangles=triangles, barycentric=barycentric,
        fitted_template=fitted, matched=matched.copy(), distances=distances, rms_distance=rms,
        max_distance=max_distance, matched_fraction=matched_fraction, face_width=face_width,
        search_score=float(match.score), rigid_scale=float(similarity.scale * unit),
        rigid_rotation=similarity.rotation.copy(), rigid_translation=similarity.translation * unit + centre,
        seed=int(seed), warnings=tuple(warnings), orientation=choice.report(), checks=tuple(checks),
        symmetric=symmetric)

