"""Benchmarks run the extension installed by ``make install`` (``.blender-user``), like the tests:
``import _harness`` enables it inside the bpy module and makes ``faces_hands_addon`` the installed copy."""
from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
import blender_env  # noqa: E402

USER_DIR = Path(os.environ.get("FH_BENCH_USER_DIR", ROOT / ".blender-user"))
if not blender_env.extension_dir(USER_DIR).exists():
    sys.exit(f"the extension is not installed in {USER_DIR}; run `make install` (or `make bench`)")
EXTENSION = blender_env.enable(USER_DIR, quiet=True)  # Blender's start-up chatter stays off the figures
blender_env.alias_installed_engine()


def addon_module(name: str):
    """The installed extension's module ``name`` (e.g. ``operators.hand.services``): bpy-side code that
    ``faces_hands_addon`` aliasing does not cover."""
    import importlib
    return importlib.import_module(f"{EXTENSION.__name__}.{name}")
