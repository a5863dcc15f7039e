# SPDX-License-Identifier: GPL-3.0-or-later
"""The N-panel UI (sidebar tab "Faces & Hands"): one file per subsystem on the shared base of ``base``.
Panels only draw; properties live in ``properties``.

The extension root registers ``PROPERTY_CLASSES``, ``PROPERTIES``, ``CLASSES``, ``MENUS`` and ``CLEANUPS`` through
``operators.bases.registry``.
"""
from . import emotion_picker, face, hand, main, menus, morph, morph_properties, properties, speech

PROPERTY_CLASSES = [*properties.CLASSES, *morph_properties.CLASSES]
PROPERTIES = [*properties.PROPERTIES, *morph_properties.PROPERTIES]
CLASSES = [*main.CLASSES, *face.CLASSES, *speech.CLASSES, *morph.CLASSES, *hand.CLASSES, *menus.CLASSES]
MENUS = menus.MENUS
CLEANUPS = [emotion_picker.free_previews]     # resources the panels make on demand
