# SPDX-License-Identifier: GPL-3.0-or-later
"""The list of ``faces_hands`` subcommands (each module: NAME, HELP, add_arguments, run)."""
from . import cmd_demo, cmd_info

MODULES = [cmd_info, cmd_demo]
