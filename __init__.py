# SPDX-License-Identifier: GPL-3.0-or-later
"""Faces & Hands: communicative virtual humans for Blender (after I. Albrecht, *Faces and Hands*, 2005).

This file is the extension entry point and only registers ``operators/`` and ``panels/``, through
``operators.bases.registry`` (the one place that registers and unregisters anything). The science lives in
the Blender-free engine ``faces_hands_addon/``.
"""
import atexit

from . import operators, panels
from .operators import cli
from .operators.bases import registry
from .operators.adapters.paths import configure_presets, write_session_bytecode

_registered = False


def register():
    global _registered
    registry.register_all(
        classes=panels.PROPERTY_CLASSES + operators.CLASSES + panels.CLASSES,
        properties=panels.PROPERTIES,
        handlers=operators.HANDLERS,
        menus=panels.MENUS,
        cleanups=panels.CLEANUPS,
        cli_commands=[("faces_hands", cli.blender_cli_entry)],
    )
    configure_presets(__package__)
    atexit.register(write_session_bytecode)  # Blender writes no bytecode: the next start compiles less
    _registered = True


def unregister():
    global _registered
    registry.unregister_all()
    configure_presets(None)
    atexit.unregister(write_session_bytecode)
    _registered = False
