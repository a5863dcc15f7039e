# SPDX-License-Identifier: GPL-3.0-or-later
"""The list of ``faces_hands`` subcommands (each: NAME, HELP, add_arguments(parser), run(args, progress))."""
from . import cmd_demo, cmd_face, cmd_info, cmd_speech

MODULES = [cmd_info, cmd_demo, cmd_face.BuildFace, cmd_face.Bake, cmd_face.Render, cmd_speech.Speak,
           cmd_speech.LipSync]
