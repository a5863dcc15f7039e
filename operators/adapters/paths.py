# SPDX-License-Identifier: GPL-3.0-or-later
"""Where the extension keeps the artist's files: its user folder (never the installed extension's own
folder, which an update replaces). Presets the artist edits live in ``<user folder>/presets`` with the
same relative paths as the shipped ones (``face/muscles.json``); the engine prefers them."""
from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import bpy

from ...faces_hands_addon.anim.shape_cache import ShapeCache, engine_fingerprint
from ...faces_hands_addon.core import bytecode, presets
from ...faces_hands_addon.core.file_cache import FileCache, cache_key, tree_fingerprint
from ...faces_hands_addon.physics import kernel

__all__ = ["user_preset_folder", "preset_folder", "preferences", "output_folder", "default_voice",
           "configure_presets", "copy_presets", "shape_cache", "shape_cache_summary", "clear_shape_cache",
           "rig_cache", "rig_cache_key", "still_cache", "built_file_key"]

_CACHE_FOLDER: list[Path | None] = [None]
_PACKAGE: list[str | None] = [None]
NO_CACHE_VARIABLE = "FH_NO_SHAPE_CACHE"     # set to 1 to simulate every target afresh (cold benchmarks)
CACHE_DIR_VARIABLE = "FH_CACHE_DIR"         # a cache folder that outlives a farm session's user folder
NO_RIG_CACHE_VARIABLE = "FH_NO_RIG_CACHE"   # 1: build the default rigs and stills afresh (cold benchmarks)


def user_preset_folder(package: str) -> Path | None:
    """``<extension user folder>/presets`` (created), or None when the add-on is not an extension."""
    try:
        return Path(bpy.utils.extension_path_user(package, path="presets", create=True))
    except (ValueError, RuntimeError, TypeError):
        return None


def preferences(package: str | None = None):
    """The add-on preferences (``panels.preferences``), or None when the add-on is not enabled."""
    package = package or _PACKAGE[0]
    addon = bpy.context.preferences.addons.get(package) if package else None
    return addon.preferences if addon is not None else None


def preset_folder(package: str) -> Path | None:
    """The folder whose presets override the shipped ones: the preferences' Preset Folder, else the
    extension's user folder."""
    prefs = preferences(package)
    chosen = bpy.path.abspath(prefs.preset_folder) if prefs is not None and prefs.preset_folder else ""
    return Path(chosen) if chosen else user_preset_folder(package)


def output_folder() -> Path:
    """The preferences' default output folder ('//' = beside the open .blend, or the working folder)."""
    prefs = preferences()
    folder = prefs.output_folder if prefs is not None and prefs.output_folder else "//"
    if folder.startswith("//") and not bpy.data.filepath:
        folder = folder[2:] or "."
    return Path(bpy.path.abspath(folder))


def default_voice() -> str:
    prefs = preferences()
    return (prefs.voice if prefs is not None else "") or "en-us"


def configure_presets(package: str | None) -> None:
    """Point the engine's preset resolver at the preset folder of ``package`` (at registration and when the
    preference changes), or back at the shipped presets only (``None``, at unregistration); the same for
    the shape cache and the compiled simulation kernel (numba cache): under ``$FH_CACHE_DIR`` when set
    (a farm job's sessions each get a new user folder; a folder of the worker's keeps the cache warm)."""
    _PACKAGE[0] = package
    presets.set_user_folder(preset_folder(package) if package else None)
    folder = None
    if package and os.environ.get(CACHE_DIR_VARIABLE):
        folder = Path(os.environ[CACHE_DIR_VARIABLE]) / "shapes"
        folder.mkdir(parents=True, exist_ok=True)
    elif package:
        try:
            folder = Path(bpy.utils.extension_path_user(package, path="cache/shapes", create=True))
        except (ValueError, RuntimeError, TypeError):
            folder = None
    _CACHE_FOLDER[0] = folder
    # numba's compiled kernel lives beside the shape cache, never in the installed extension's folder
    kernel.set_cache_folder(folder.parent / "numba" if folder is not None else None)


def shape_cache() -> ShapeCache:
    """The cache of settled target shapes in the extension's user folder (``anim.shape_cache``)."""
    return ShapeCache(None if os.environ.get(NO_CACHE_VARIABLE) == "1" else _CACHE_FOLDER[0])


def rig_cache() -> FileCache | None:
    """The built default rigs (.blend files) beside the shape cache (``core.file_cache``), or None."""
    return _file_cache("rigs")


def still_cache() -> FileCache | None:
    """The still GLBs of rigs (``take_export``) beside the shape cache, or None."""
    return _file_cache("stills")


def _file_cache(name: str) -> FileCache | None:
    folder = _CACHE_FOLDER[0]
    if folder is None or os.environ.get(NO_RIG_CACHE_VARIABLE) == "1":
        return None
    return FileCache(folder.parent / name)


def rig_cache_key(what: str, fps: float, options: dict | None = None) -> tuple[str, dict]:
    """(key, parts) of a built rig ``what`` at ``fps`` (:func:`built_file_key`)."""
    return built_file_key(what, {"fps": float(fps), **(options or {})})


def built_file_key(what: str, options: dict) -> tuple[str, dict]:
    """(key, parts) of a file ``what`` made from ``options``: with them, everything else that decides its
    bytes, the installed extension's files (code, presets, assets; the wheels by name and size), the
    artist's preset overrides, Blender's version and build and numpy's version."""
    import numpy
    extension = Path(__file__).resolve().parents[2]
    build = bpy.app.build_hash.decode("ascii", "replace") if isinstance(bpy.app.build_hash, bytes) else ""
    parts = {"what": what, "options": dict(options), "extension": tree_fingerprint(str(extension)),
             "engine": engine_fingerprint(), "blender": f"{bpy.app.version_string} {build}".strip(),
             "numpy": numpy.__version__}
    return cache_key(parts), parts


def shape_cache_summary() -> tuple[int, int]:
    """How many settled shapes the cache holds and their size in bytes."""
    folder = _CACHE_FOLDER[0]
    entries = list(folder.glob("*.npz")) if folder is not None and folder.is_dir() else []
    return len(entries), sum(p.stat().st_size for p in entries)


def clear_shape_cache() -> int:
    """Delete every cached shape; returns how many files went."""
    folder = _CACHE_FOLDER[0]
    doomed = sorted(folder.glob("*.npz")) if folder is not None and folder.is_dir() else []
    for path in doomed:
        path.unlink(missing_ok=True)
    return len(doomed)


def copy_presets(overwrite: bool = False) -> tuple[Path, list[str]]:
    """Copy the shipped presets into the user preset folder for editing (existing copies are kept unless
    ``overwrite``). Returns the folder and the relative paths copied."""
    folder = presets.user_folder()
    if folder is None:
        from ...faces_hands_addon.core.errors import UserError
        raise UserError("this installation has no user folder for presets (install it as an extension)")
    copied = []
    for source in sorted(presets.SHIPPED_FOLDER.rglob("*")):
        if not source.is_file():
            continue
        relative = source.relative_to(presets.SHIPPED_FOLDER)
        target = folder / relative
        if target.exists() and not overwrite:
            continue
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(source, target)
        copied.append(relative.as_posix())
    return folder, copied


def write_session_bytecode() -> int:
    """Write the missing bytecode of the modules this session loaded from the installed extension and its
    wheels (engine ``core.bytecode``: Blender writes none, so each start compiled them again); returns the
    number of files written. Called when a command line run ends and when Blender quits."""
    extension = Path(__file__).resolve().parents[2]
    wheels = [entry for entry in sys.path if {"extensions", ".local"} <= set(Path(entry).parts)]
    try:
        return bytecode.write_missing_bytecode([extension], wheels)
    except OSError:
        return 0
