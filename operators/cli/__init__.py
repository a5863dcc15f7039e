# SPDX-License-Identifier: GPL-3.0-or-later
"""The ``faces_hands`` command line (``blender -b -c faces_hands ...`` and ``./fh``): ``command_line`` is the
shell around the subsystems' ``COMMANDS``, ``rig_command`` the one base of the commands that work on a rig,
``interrupts`` Ctrl-C / SIGTERM handling."""
from .command_line import blender_cli_entry, main

__all__ = ["main", "blender_cli_entry"]
