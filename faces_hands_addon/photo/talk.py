# SPDX-License-Identifier: GPL-3.0-or-later
"""A talking photograph (thesis 3.2.5 with 4.3: "the extracted face model can be modified and rendered back
into the original image"): the head made from the photo speaks a take -- speech, behaviour and emotion
layers mixed by its face rig (the same per-frame bake as any face) -- and every frame is rendered into the
photo with its camera and illumination (:mod:`.into_photo`). The head stays where the photo has it: the
take's head motion is left out unless asked for, because hair, ears and neck are the photo's and do not turn.
"""
from __future__ import annotations

import math

import numpy as np

from ..anim.bakes import CacheBake
from ..anim.take import Take
from ..face.expressions import load_expressions
from .appearance import srgb_to_linear
from .into_photo import PhotoProjector, label_colours, posed_parts, render_pose

__all__ = ["TalkingPhoto"]


class TalkingPhoto:
    """Frames of ``result`` (a :class:`.pipeline.PhotoHead` with its rig) speaking ``take`` at ``fps`` inside
    ``pixels_srgb``: :meth:`step` simulates a frame at a time (progress in [0, 1]), then :meth:`frames`
    renders them in order."""

    def __init__(self, result, pixels_srgb: np.ndarray, take: Take, fps: float):
        if result.rig is None:
            raise ValueError("the head needs its face rig")
        self.result, self.pixels, self.fps = result, np.asarray(pixels_srgb, np.float32), float(fps)
        count = int(math.ceil(take.duration * self.fps)) + 1
        self.bake = CacheBake(result.rig, take, range(count), self.fps, 0.0, load_expressions("visemes"))
        self.count = count
        self.label = f"simulating {count} frames"

    def step(self) -> float:
        return self.bake.step()

    def frames(self):
        """(frame, composite (H, W, 3) sRGB) for every simulated frame, in order."""
        result = self.result
        linear = srgb_to_linear(self.pixels)
        texture = srgb_to_linear(result.texture.srgb)
        colours = label_colours(result, linear)
        rest_parts = posed_parts(result, colours)
        projector = PhotoProjector(result, linear, result.mesh.vertices(result.vertices), rest_parts)
        for index, shape in enumerate(self.bake.shapes):
            skin = np.asarray(shape.pose.positions["skin"], np.float64)
            parts = posed_parts(result, colours, shape.pose.transforms)
            yield index, render_pose(result, self.pixels, texture, skin, parts, projector)

    def mouth_opening(self) -> np.ndarray:
        """Per frame, the gap between the inner lips' middle points (landmarks 13 and 14) in metres: where the
        mouth is open and closed (for checking frames)."""
        out = []
        for shape in self.bake.shapes:
            skin = np.asarray(shape.pose.positions["skin"], np.float64)
            landmarks = self.result.mesh.landmarks
            out.append(float(np.linalg.norm(skin[landmarks[13]] - skin[landmarks[14]])))
        return np.asarray(out)
