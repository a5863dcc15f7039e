#!/usr/bin/env python3
"""Install the built extension zip into an isolated Blender user folder and enable it.

Usage: install_ext.py --user-dir .blender-user --zip dist/faces_hands-<version>.zip
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import blender_env  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--user-dir", required=True, type=Path)
    parser.add_argument("--zip", required=True, type=Path)
    args = parser.parse_args()
    user_dir = blender_env.fresh_user_dir(args.user_dir.resolve())
    blender_env.install(args.zip.resolve(), user_dir)
    print(f"installed {args.zip} into {args.user_dir}/ (isolated Blender user folder)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
