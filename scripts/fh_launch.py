#!/usr/bin/env python3
"""Run the installed extension's ``faces_hands`` command function inside the bpy module.

Usage (through ./fh): fh_launch.py --user-dir DIR -- <subcommand> [args...]
Blender prints start-up chatter on stdout while ``bpy`` loads; it is kept off the command's output.
"""
from __future__ import annotations

import os
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
    return extension.operators.cli.main(rest)


if __name__ == "__main__":
    code = main()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)  # skip bpy's slow interpreter teardown
