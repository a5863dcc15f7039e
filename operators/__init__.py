# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender operators and the thin helpers that convert between Blender data and the engine.

``CLASSES`` and ``HANDLERS`` are what the extension root registers through ``registry``.
"""
from . import ops_face, ops_fit, ops_info, ops_speech

CLASSES = [*ops_info.CLASSES, *ops_face.CLASSES, *ops_fit.CLASSES, *ops_speech.CLASSES]
HANDLERS = []
