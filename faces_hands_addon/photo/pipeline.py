# SPDX-License-Identifier: GPL-3.0-or-later
"""Photographs -> a textured head of the person (thesis 3.2.4), in fixed stages run for every photo before
the next: landmarks (detected, or placed by the user), the shape and cameras fitted to all photos together
(:mod:`.fit`), the colours analysed by synthesis (:mod:`.appearance`), the texture baked (:mod:`.texture`).

Bad pictures are refused here with what was found: no face; a face whose eyes are closer than
:data:`MIN_INTER_OCULAR` pixels (too small to fit); a face turned further than :data:`MAX_YAW` from the
camera (the landmark model does not see the far side); several faces are reported and the largest is used
unless another is chosen (1 = the largest).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.errors import UserError
from .appearance import AppearanceFit, fit_appearance, srgb_to_linear
from .camera import yaw_pitch_roll
from .fit import FitSettings, ShapeFit, View, fit_views
from .head_model import HeadModel
from .silhouette import EdgeMap
from .texture import Texture, bake_texture, texture_size

__all__ = ["Photo", "PhotoHead", "HeadBuild", "find_landmarks", "head_from_photos", "MIN_INTER_OCULAR", "MAX_YAW", "WARN_YAW"]

MIN_INTER_OCULAR = 80.0       # px between the iris centres
MAX_YAW = 60.0                # degrees; beyond, the far side's landmarks are guesses
WARN_YAW = 35.0
MIN_PRESENCE = 0.5


@dataclass
class Photo:
    """One input picture: ``pixels`` (H, W, 3) sRGB float32 (oriented), ``name`` for messages,
    ``focal_35mm`` from EXIF (0: unknown), ``landmarks`` (478, 3) when placed by the user (else detected),
    ``face`` which face to use (1 = the largest), ``role`` "front" or "profile"."""
    pixels: np.ndarray
    name: str
    focal_35mm: float = 0.0
    landmarks: np.ndarray | None = None
    face: int = 1
    role: str = "front"


@dataclass
class PhotoHead:
    """The result: the fitted ``shape`` (cameras, coefficients, vertices), per photo its ``appearance`` and
    ``landmarks`` (478, 3), the ``texture``, and ``notes`` (faces found, yaw, focal length) to report."""
    model: HeadModel
    shape: ShapeFit
    appearance: list[AppearanceFit]
    landmarks: list[np.ndarray]
    texture: Texture
    notes: list[str] = field(default_factory=list)
    mesh: object = None
    rig: object = None

    @property
    def vertices(self) -> np.ndarray:
        return self.shape.vertices

    def yaw_pitch_roll(self, view: int = 0) -> tuple[float, float, float]:
        return yaw_pitch_roll(self.shape.cameras[view].rotation)


def find_landmarks(photo: Photo, finder=None) -> tuple[np.ndarray, list[str]]:
    """The 478 landmarks of ``photo``'s chosen face and notes about what was found (module docstring)."""
    from .landmarks import FaceFinder
    finder = finder or FaceFinder()
    faces = finder.detect(photo.pixels)
    h, w = photo.pixels.shape[:2]
    if not faces:
        raise UserError(f"no face found in {photo.name} ({w}x{h}); use a photo where the face is clearly visible, "
                        "or place the landmarks by hand (Head from Photo > Edit Landmarks)")
    notes = []
    if not 1 <= photo.face <= len(faces):
        raise UserError(f"{photo.name}: --face {photo.face} does not exist; {len(faces)} face"
                        f"{'s were' if len(faces) > 1 else ' was'} found (1 = the largest)")
    if len(faces) > 1:
        sizes = ", ".join(f"{k + 1}: {f.size:.0f} px at ({(f.box[0] + f.box[2]) / 2:.0f}, "
                          f"{(f.box[1] + f.box[3]) / 2:.0f})" for k, f in enumerate(faces))
        notes.append(f"{photo.name}: {len(faces)} faces found ({sizes}); using face {photo.face}"
                     f"{' (the largest)' if photo.face == 1 else ''}; choose another with --face N")
    found = finder.landmarks(photo.pixels, faces[photo.face - 1])
    if found.presence < MIN_PRESENCE:
        raise UserError(f"{photo.name}: the face landmark model does not see a face in the detected box "
                        f"(confidence {found.presence:.2f}); use a clearer photo or place the landmarks by hand")
    return found.points, notes


def _check_size(points: np.ndarray, name: str) -> None:
    inter_ocular = float(np.linalg.norm(points[468, :2] - points[473, :2]))
    if inter_ocular < MIN_INTER_OCULAR:
        raise UserError(f"{name}: the face is too small: {inter_ocular:.0f} px between the eyes, at least "
                        f"{MIN_INTER_OCULAR:.0f} px are needed for a head; use a larger or closer photo")


class HeadBuild:
    """:func:`head_from_photos` one stage per :meth:`step` (landmarks of each photo, the fit, the colours, the
    texture, the rig), for a job with a progress bar and ESC; ``result`` when done."""

    def __init__(self, photos: list[Photo], model: HeadModel, settings: FitSettings | None = None,
                 finder=None, rig: bool = True, seed: int = 0, edits: list[tuple[str, float]] = ()):
        if not photos:
            raise UserError("no photo given")
        self.photos, self.model, self.settings, self.finder = photos, model, settings, finder
        self.notes: list[str] = []
        self.views: list[View] = []
        self.landmarks: list[np.ndarray] = []
        self.stages = [lambda p=p: self._landmarks(p) for p in photos]
        self.edits = list(edits)
        self.stages += [self._fit, self._colours, self._texture] + ([self._rig] if rig else [])
        self.done = 0
        self.shape = self.appearance = self.texture = self.result = None
        self.images: list[np.ndarray] = []
        self.seed = int(seed)
        self.label = "finding the face"

    def step(self) -> float:
        if self.done < len(self.stages):
            self.stages[self.done]()
            self.done += 1
        return self.done / len(self.stages)

    def _landmarks(self, photo: Photo) -> None:
        if photo.landmarks is None:
            points, found = find_landmarks(photo, self.finder)
            self.notes += found
        else:
            points = np.asarray(photo.landmarks, np.float64)
            if points.shape != (478, 3) or not np.isfinite(points).all():
                raise UserError(f"{photo.name}: the landmarks must be 478 finite points (got {points.shape})")
        _check_size(points, photo.name)
        h, w = photo.pixels.shape[:2]
        settings = self.settings or FitSettings()
        edges = EdgeMap.of(photo.pixels, points) if settings.silhouette else None
        self.views.append(View(points, w, h, photo.focal_35mm, np.ones(len(points)), edges))
        self.landmarks.append(points)
        self.label = "fitting the morphable model"

    def _fit(self) -> None:
        self.shape = fit_views(self.model, self.views, self.settings)
        self.notes += self.shape.notes
        main = self.photos[0]
        yaw, pitch, _ = yaw_pitch_roll(self.shape.cameras[0].rotation)
        if abs(yaw) > MAX_YAW and main.role == "front":
            raise UserError(f"{main.name}: the face is turned {abs(yaw):.0f} degrees from the camera; a head is "
                            f"made from a photo turned less than {MAX_YAW:.0f} degrees (give a side view as "
                            "--profile with a front photo)")
        if abs(yaw) > WARN_YAW:
            self.notes.append(f"{main.name}: the face is turned {abs(yaw):.0f} degrees; its far side is filled from "
                              "the near side and the model")
        self.notes.append(f"pose in {main.name}: yaw {yaw:.1f}, pitch {pitch:.1f} degrees")
        self.label = "analysing the colours"

    def _colours(self) -> None:
        self.images = [srgb_to_linear(p.pixels) for p in self.photos]
        self.appearance = [fit_appearance(self.model, self.shape.vertices, camera, image)
                           for camera, image in zip(self.shape.cameras, self.images)]
        self.label = "baking the texture"

    def _texture(self) -> None:
        face_px = float(np.linalg.norm(self.landmarks[0][454, :2] - self.landmarks[0][234, :2]))
        uvs = self.model.uvs[self.model.landmarks[[454, 234]]]
        uv_width = float(np.linalg.norm(uvs[0] - uvs[1]))
        views = [(camera, fit.lighting, image)
                 for camera, fit, image in zip(self.shape.cameras, self.appearance, self.images)]
        self.texture = bake_texture(self.shape.vertices, self.model.triangles, self.model.uvs, self.model.mirror,
                                    views, self.appearance[0].albedo, texture_size(face_px, uv_width))
        self.result = PhotoHead(self.model, self.shape, self.appearance, self.landmarks, self.texture, self.notes)
        if self.edits:
            from .edit import edited_head
            self.result = edited_head(self.result, self.edits)
        self.label = "fitting the face rig"

    def _rig(self) -> None:
        from ..face.fitted import build_fitted_rig
        from .head_mesh import rig_mesh
        mesh = rig_mesh(self.model)
        vertices = mesh.vertices(self.result.vertices)
        self.result.mesh = mesh
        self.result.rig = build_fitted_rig(vertices, mesh.triangles, landmarks=vertices[mesh.landmarks],
                                           seed=self.seed)


def head_from_photos(photos: list[Photo], model: HeadModel, settings: FitSettings | None = None,
                     progress=None, finder=None, rig: bool = False) -> PhotoHead:
    """Stages of the module docstring; ``photos[0]`` is the main (front) photo; ``rig``: also fit the face
    rig to the head (``result.rig`` on ``result.mesh``)."""
    build = HeadBuild(photos, model, settings, finder, rig)
    fraction = 0.0
    while fraction < 1.0:
        label = build.label
        fraction = build.step()
        if progress is not None:
            progress(fraction, label)
    return build.result
