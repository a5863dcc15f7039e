#!/usr/bin/env python3
"""A ``blender`` command for machines without a Blender binary: the parts of Blender's command line a farm
job of the extension uses, run by Blender's Python module (the ``bpy`` wheel) in this Python.

* ``--version``: ``Blender <version>`` as Blender prints it.
* ``[-b] [--factory-startup] [--python-exit-code N] --python FILE [-- ARGS]``: run FILE in ``bpy`` with
  Blender's ``sys.argv`` (a raised error exits with N, as Blender does).
* ``--command extension ARGS`` / ``-c extension ARGS``: Blender's own extension command
  (``bl_pkg.cli_extension``, e.g. ``install-file --repo user_default --enable ZIP``).
* ``[-b] -c faces_hands ARGS``: the installed extension's command line, as ``blender -b -c faces_hands``.

The user folder is ``BLENDER_USER_RESOURCES`` as for Blender; with ``--factory-startup`` and none set, a
throwaway one (a real Blender configuration is never touched). Dev tooling: tests and benchmarks run the
OpenJD bundles of ``faces_hands jobs --openjd`` with it (``write_wrapper`` makes an executable for them).
"""
from __future__ import annotations

import os
import runpy
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import blender_env  # noqa: E402


def write_wrapper(path: Path, python: str | None = None) -> Path:
    """An executable ``path`` that runs this stand-in with ``python`` (default: this interpreter)."""
    path.write_text(f'#!/bin/sh\nexec "{python or sys.executable}" "{Path(__file__).resolve()}" "$@"\n')
    path.chmod(0o755)
    return path


def _user_dir(throwaway: bool) -> Path:
    folder = os.environ.get("BLENDER_USER_RESOURCES")
    if folder:
        return Path(folder)
    if throwaway:
        return Path(tempfile.mkdtemp(prefix="fh-standin-user-"))
    raise SystemExit("blender stand-in: set BLENDER_USER_RESOURCES (no real Blender folder is used)")


def _bpy(user_dir: Path):
    blender_env.use_user_dir(user_dir)
    stdout = os.dup(1)
    os.dup2(2, 1)                                   # Blender's start-up lines, as Blender prints them
    try:
        import bpy
    finally:
        sys.stdout.flush()
        os.dup2(stdout, 1)
        os.close(stdout)
    return bpy


def _python(args: list[str]) -> int:
    script = args[args.index("--python") + 1]
    code = int(args[args.index("--python-exit-code") + 1]) if "--python-exit-code" in args else 0
    _bpy(_user_dir("--factory-startup" in args))
    sys.argv = ["blender", *args]
    try:
        runpy.run_path(script, run_name="__main__")
    except SystemExit as exit_request:
        if exit_request.code not in (None, 0):
            print(exit_request.code, file=sys.stderr)
            return code or 1
    except Exception:  # noqa: BLE001 - Blender prints the traceback and exits with --python-exit-code
        import traceback
        traceback.print_exc()
        return code
    return 0


def _command(name: str, rest: list[str]) -> int:
    if name == "extension":
        bpy = _bpy(_user_dir(False))
        import addon_utils
        bl_pkg = sys.modules.get("bl_pkg") or addon_utils.enable("bl_pkg", default_set=False)
        return int(bl_pkg.cli_extension(rest) or 0) if bpy else 1
    if name == "faces_hands":
        extension = blender_env.enable(_user_dir(False), quiet=True)
        return int(extension.operators.cli.main(rest) or 0)
    print(f"blender stand-in: no command {name!r}", file=sys.stderr)
    return 1


def main(argv: list[str]) -> int:
    own = argv[:argv.index("--")] if "--" in argv else argv      # what follows "--" is the script's
    if "--version" in own or "-v" in own:
        import importlib.metadata
        print(f"Blender {importlib.metadata.version('bpy')}")
        return 0
    for flag in ("-c", "--command"):
        if flag in own:
            index = argv.index(flag)
            return _command(argv[index + 1], argv[index + 2:])
    if "--python" in own:
        return _python(argv)
    print("blender stand-in: give --version, --python FILE or -c COMMAND", file=sys.stderr)
    return 2


if __name__ == "__main__":
    code = main(sys.argv[1:])
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)     # skip bpy's slow interpreter teardown, as fh_launch.py does
