# SPDX-License-Identifier: GPL-3.0-or-later
"""The Faces & Hands engine: numpy/scipy only, never ``bpy`` or ``mathutils``.

One package per part of the thesis (I. Albrecht, *Faces and Hands*, 2005); operators turn the
plain arrays and dataclasses it returns into Blender data, so the same code serves the N-panel,
``blender -b -c faces_hands ...`` batch bakes and the tests.
"""
from .core.errors import UserError

__all__ = ["UserError"]
