# SPDX-License-Identifier: GPL-3.0-or-later
"""Jobs manifests at studio scale in Blender: ``faces_hands jobs`` (checked whole, local workers sharing
one queue, resume, one farm task's chunk, the OpenJD bundle). The engine side (manifest, checks, sidecars,
reports, the bundle) is ``faces_hands_addon.farm``; rows are baked through the speech services."""
from . import commands

CLASSES: list = []
COMMANDS = commands.COMMANDS
