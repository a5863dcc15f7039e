#!/usr/bin/env python3
"""Run the installed extension's ``faces_hands`` command function inside the bpy module.

Usage (through ./fh): fh_launch.py --user-dir DIR -- <subcommand> [args...]
Blender prints start-up chatter on stdout while ``bpy`` loads; it is kept off the command's output.
"""
from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import blender_env  # noqa: E402


def main() -> int:
    argv = sys.argv[1:]
    if len(argv) < 2 or argv[0] != "--user-dir":
        print("usage: fh_launch.py --user-dir DIR -- <subcommand> ...", file=sys.stderr)
        return 2
    user_dir = Path(argv[1]).resolve()
    rest = argv[2:]
    if rest and rest[0] == "--":
        rest = rest[1:]
    extension = blender_env.enable(user_dir, quiet=True)  # Blender's start-up lines go to stderr
    try:
        return extension.operators.cli.main(rest)
    finally:
        _remove_session_folder()


def _remove_session_folder() -> None:
    """Blender's per-session temporary folder (``blender_XXXXXX``), which its teardown would remove; the
    launcher skips that teardown (``os._exit``), so it removes the folder itself."""
    import bpy  # noqa: PLC0415 - loaded by blender_env.enable
    folder = Path(bpy.app.tempdir)
    if folder.name.startswith("blender_") and folder.is_dir():
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    code = main()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)  # skip bpy's slow interpreter teardown
