# SPDX-License-Identifier: GPL-3.0-or-later
"""Template -> new head (thesis 3.1.2 "Creating New Animatable Head Models from the Template"): locate
the 468 MediaPipe canonical-face landmarks on an arbitrary head mesh in any axis orientation.

Orientation search (:mod:`.orientation`), rough similarity alignment (:mod:`.align`), optimal-step non-rigid ICP (:mod:`.nicp`), projection onto the
target triangles (:mod:`.surface`), the fit-quality gate (:mod:`.quality`, :mod:`.preview`); :mod:`.testdata` makes targets with known landmarks. numpy/scipy only.
"""
from .landmarks import LandmarkFit, locate_landmarks
from .surface import project_to_surface

__all__ = ["LandmarkFit", "locate_landmarks", "project_to_surface"]
