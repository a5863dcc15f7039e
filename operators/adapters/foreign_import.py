# SPDX-License-Identifier: GPL-3.0-or-later
"""Files made by other programs, imported with Blender's own importers without risking the session.

The file is checked first (:func:`...faces_hands_addon.core.foreign_files.check_foreign_file`: path, size,
header and the sizes it declares). Then the importer runs in a child Blender (this Python with the ``bpy``
module, or Blender itself in the background) under a memory limit of :data:`MEMORY_LIMIT` (``RLIMIT_DATA``,
which the child sets itself before the importer runs; POSIX only, elsewhere the checks alone guard) and a
time limit; the child writes what it imported to a
.blend in a temporary folder, and this process appends those objects into the current scene. A file that
makes the importer fail, exhaust its memory or hang is a clear error here, and this session's scene and
memory never saw it.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import bpy

from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.core.foreign_files import FORMATS, check_foreign_file

__all__ = ["MEMORY_LIMIT", "TIME_LIMIT_S", "Imported", "import_foreign", "child_command"]

MEMORY_LIMIT = 1_750 * 1024 * 1024     # the child's data; its code and Blender's libraries add ~0.2 GB
TIME_LIMIT_S = 600.0
CHILD = Path(__file__).resolve().with_name("import_child.py")
MARK = "FH-IMPORTED "


@dataclass(frozen=True)
class Imported:
    """What an import made: the new objects, and the frame rate their keys count in (a glTF clip's keys
    land at its times x this rate, an FBX's at its own rate)."""
    objects: list
    fps: float


def child_command(source: Path, out: Path) -> list[str]:
    """The command line of a child that imports ``source`` and writes ``out`` (Blender's binary in the
    background when running inside Blender, else this Python, which has the ``bpy`` module)."""
    tail = ["--", str(source), source.suffix.lower(), str(out)]
    if bpy.app.binary_path:
        return [bpy.app.binary_path, "--background", "--factory-startup", "--python-exit-code", "1",
                "--python", str(CHILD), *tail]
    return [sys.executable, str(CHILD), *tail]


def _run_child(source: Path, out: Path, folder: Path) -> dict:
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(folder / "user"),      # no user add-ons or startup file
               FH_IMPORT_MEMORY=str(MEMORY_LIMIT))                           # the child limits itself
    try:
        done = subprocess.run(child_command(source, out), capture_output=True, text=True, errors="replace",
                              timeout=TIME_LIMIT_S, env=env, cwd=folder)
    except subprocess.TimeoutExpired:
        raise UserError(f"importing {source} took longer than {TIME_LIMIT_S / 60:g} minutes; "
                        "the file may be damaged") from None
    lines = [line for line in done.stdout.splitlines() if line.startswith(MARK)]
    if done.returncode != 0 or not lines or not out.is_file():
        text = done.stdout + done.stderr
        if "MemoryError" in text or "bad_alloc" in text or "memory" in text.lower() and done.returncode < 0:
            reason = f"it needs more than {MEMORY_LIMIT / 2**30:.1f} GB of memory to import"
        else:
            useful = [line.strip() for line in text.splitlines() if line.strip() and "Error" in line]
            reason = useful[-1] if useful else f"the importer stopped (exit {done.returncode})"
        raise UserError(f"cannot import {source}: {reason[:300]}")
    return json.loads(lines[-1][len(MARK):])


def import_foreign(path, what: str = "the file", formats=FORMATS) -> Imported:
    """Import ``path`` (checked, then imported in a child Blender: module docstring) into the current
    scene's collection."""
    source = check_foreign_file(path, what, formats)
    with tempfile.TemporaryDirectory(prefix="fh-import-") as tmp:
        folder = Path(tmp)
        out = folder / "imported.blend"
        made = _run_child(source, out, folder)
        with bpy.data.libraries.load(str(out), link=False) as (_, into):
            into.objects = list(made["objects"])
        objects = [o for o in into.objects if o is not None]
    collection = bpy.context.scene.collection
    for obj in objects:
        if obj.name not in collection.objects:
            collection.objects.link(obj)
        obj.use_fake_user = False
    bpy.context.view_layer.update()
    return Imported(objects, float(made["fps"]))
