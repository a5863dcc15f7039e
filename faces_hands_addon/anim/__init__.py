# SPDX-License-Identifier: GPL-3.0-or-later
"""Engine-side animation tracks: a control name -> times (s) and values.

Operators turn a :class:`TrackSet` into F-curves at the scene's fps and start frame; the engine never
knows about frames or Blender (CONTRIBUTING.md, "Animation tracks").
"""
from .tracks import Track, TrackSet

__all__ = ["Track", "TrackSet"]
