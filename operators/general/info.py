# SPDX-License-Identifier: GPL-3.0-or-later
"""``faces_hands info``: versions, bundled packages and default assets (a quick health check)."""
from __future__ import annotations

import importlib

import bpy

class Info:
    NAME = "info"
    HELP = "print versions of Blender, the extension, its bundled packages and default assets"

    @staticmethod
    def add_arguments(parser) -> None:
        pass

    @staticmethod
    def run(args, progress) -> int:
        return _print_info()


def _print_info() -> int:
    from ...faces_hands_addon import assets
    print(f"Blender {bpy.app.version_string}")
    for package in ("numpy", "scipy", "soundfile", "espeakng_loader", "pocketsphinx"):
        try:
            module = importlib.import_module(package)
            print(f"{package} {getattr(module, '__version__', '(no version attribute)')}")
        except ImportError as error:
            print(f"{package} MISSING ({error})")
    face = assets.canonical_face()
    print(f"asset canonical face: {len(face.vertices)} vertices, {len(face.faces)} triangles")
    for name in ("skull", "jaw"):
        mesh = getattr(assets, name)()
        print(f"asset {name}: {len(mesh.vertices)} vertices, {len(mesh.faces)} triangles")
    return 0
