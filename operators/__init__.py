# SPDX-License-Identifier: GPL-3.0-or-later
"""Blender operators, grouped by subsystem; ``common`` holds what they share.

Each subsystem package (``face``, ``speech``, ...) exposes ``CLASSES`` (its operators) and ``COMMANDS``
(its command-line subcommands: ``NAME``, ``HELP``, ``add_arguments(parser)``, ``run(args, progress)``);
this module collects them for the extension root and for ``cli``.
"""
from . import character, face, farm, general, hand, morph, photo, speech, tracking

SUBSYSTEMS = (general, face, speech, morph, hand, character, farm, tracking, photo)
CLASSES = [cls for package in SUBSYSTEMS for cls in package.CLASSES]
COMMANDS = [command for package in SUBSYSTEMS for command in package.COMMANDS]
HANDLERS = []
