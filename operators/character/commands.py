# SPDX-License-Identifier: GPL-3.0-or-later
"""``faces_hands build-character``: the default character (MPFB2 body, armature, face rig on its head) in
batch, saved as .blend or exported as .glb / .fbx."""
from __future__ import annotations

import bpy

from ...faces_hands_addon.character.model import SKELETONS
from ..adapters.export import save_or_export
from ..adapters.outputs import check_output_path, written
from . import services


class BuildCharacter:
    NAME = "build-character"
    HELP = "build the default character (MPFB2 body, armature, face rig on its head); writes .blend, .glb or .fbx"

    @staticmethod
    def add_arguments(parser):
        parser.add_argument("--out", required=True, help="output .blend, .glb or .fbx")
        parser.add_argument("--skeleton", choices=SKELETONS, default="game_engine",
                            help="the armature: game_engine (default, 53 bones), default (MPFB2's 163 bones) or "
                                 "rigify (the meta-rig, generated into a Rigify control rig)")
        parser.add_argument("--name", default="FH Character", help="name of the character object")

    @staticmethod
    def run(args, progress) -> int:
        out = check_output_path(args.out, (".blend", ".glb", ".fbx"))
        body = services.build_character_object(progress, args.name, args.skeleton)
        print(written([save_or_export(bpy.context, body, out, ())]))
        return 0


COMMANDS = [BuildCharacter]
