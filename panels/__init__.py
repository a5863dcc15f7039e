# SPDX-License-Identifier: GPL-3.0-or-later
"""The N-panel UI (sidebar tab "Faces & Hands"). Panels only draw; properties live in properties.py.

The extension root registers ``PROPERTY_CLASSES``, ``PROPERTIES`` and ``CLASSES`` through
``operators.registry``.
"""
from . import face_panel, main_panel, properties, speech_panel

PROPERTY_CLASSES = [*properties.CLASSES]
PROPERTIES = [*properties.PROPERTIES]
CLASSES = [*main_panel.CLASSES, *face_panel.CLASSES, *speech_panel.CLASSES]
