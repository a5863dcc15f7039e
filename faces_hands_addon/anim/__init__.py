# SPDX-License-Identifier: GPL-3.0-or-later
"""Engine-side animation: tracks (a control name -> times (s) and values), control layers and the rule
that mixes them, frame rates.

Operators turn a :class:`TrackSet` into F-curves at the scene's fps and start frame; the engine never
knows about Blender (CONTRIBUTING.md, "Animation tracks").
"""
from .layers import LAYERS, LayerTable, mix
from .tracks import Track, TrackSet

__all__ = ["Track", "TrackSet", "LAYERS", "LayerTable", "mix"]
