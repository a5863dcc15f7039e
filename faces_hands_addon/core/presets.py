# SPDX-License-Identifier: GPL-3.0-or-later
"""Preset files: where they are, what they must look like, and one validator for all of them.

Every preset is a JSON document with a header ``{"format": "faces_hands.<kind>", "version": N, ...}``.
The extension ships its presets in ``presets/<subsystem>/<name>.json``; an artist overrides one by putting
a file with the same relative path into the *user preset folder* (the extension's user folder, set by the
add-on at start-up, see :func:`set_user_folder`), so the installed extension is never edited and an
update does not overwrite the artist's work. :func:`resolve` prefers the user's file.

:func:`parse_preset` checks, with one clear message per problem: JSON syntax (line and column), no
``NaN``/``Infinity``, the header (right format, a version this extension reads) and the shape the format
declares (:class:`PresetFormat`): required keys, objects, lists, numbers, strings. Formats register
themselves with :func:`register_format`; meaning-level checks (a muscle name that exists, a range in
order) stay with the subsystem that reads the preset.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .errors import UserError

__all__ = ["SHIPPED_FOLDER", "PresetFormat", "register_format", "set_user_folder", "user_folder", "resolve",
           "preset_names", "read_preset", "read_preset_file", "parse_preset", "read_preset_text", "NUMBER", "ANY"]

SHIPPED_FOLDER = Path(__file__).resolve().parents[2] / "presets"
MAX_PRESET_BYTES = 20_000_000

NUMBER = "number"           # a finite int or float (not a bool)
ANY = "any"

_formats: dict[str, "PresetFormat"] = {}
_user_folder: Path | None = None


@dataclass(frozen=True)
class PresetFormat:
    """A preset format: its name (``faces_hands.<kind>``), the newest version this extension reads, and the
    document's shape. ``shape`` maps top-level keys to a shape: ``NUMBER``, ``str``, ``bool``, ``ANY``, a
    dict ``{key: shape}`` (an object with those keys), ``{str: shape}`` (an object of any keys, every value of
    that shape), ``[shape]`` (a list), or a tuple of alternatives. ``required`` keys must be present."""
    name: str
    version: int
    shape: dict = field(default_factory=dict)
    required: tuple[str, ...] = ()
    oldest_version: int = 1


def register_format(fmt: PresetFormat) -> PresetFormat:
    _formats[fmt.name] = fmt
    return fmt


def set_user_folder(folder: str | os.PathLike | None) -> None:
    """Where the artist's preset overrides live (``None``: shipped presets only)."""
    global _user_folder
    _user_folder = None if folder is None else Path(folder)


def user_folder() -> Path | None:
    return _user_folder


def resolve(relative: str) -> Path:
    """The file for ``relative`` (``"face/muscles.json"``): the user's override if there is one, else the
    shipped preset; a UserError names both places when neither exists."""
    candidates = ([_user_folder / relative] if _user_folder is not None else []) + [SHIPPED_FOLDER / relative]
    for path in candidates:
        if path.is_file():
            return path
    raise UserError(f"preset {relative!r} not found (looked in {', '.join(str(c.parent) for c in candidates)})")


def preset_names(subfolder: str) -> list[str]:
    """Stems of the presets in ``subfolder`` (shipped and user), sorted."""
    folders = [SHIPPED_FOLDER / subfolder] + ([_user_folder / subfolder] if _user_folder is not None else [])
    return sorted({p.stem for folder in folders if folder.is_dir() for p in folder.glob("*.json")})


def read_preset_text(path: str | os.PathLike) -> str:
    """The text of a preset file, or a UserError (missing, unreadable, too large, not UTF-8)."""
    path = Path(path)
    try:
        if path.stat().st_size > MAX_PRESET_BYTES:
            raise UserError(f"{path}: a preset of {path.stat().st_size:,} bytes is too large "
                            f"(at most {MAX_PRESET_BYTES:,})")
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise UserError(f"preset {path} does not exist") from None
    except UnicodeDecodeError:
        raise UserError(f"{path}: not a UTF-8 text file; save the preset as UTF-8 JSON") from None
    except OSError as error:
        raise UserError(f"{path}: cannot read the preset ({error.strerror or error})") from None


def read_preset(relative: str, format_name: str) -> tuple[dict, str]:
    """Read and validate the preset ``relative`` (``"expressions/arkit.json"``; the user's override if there
    is one). Returns the document and its file name for messages."""
    return read_preset_file(resolve(relative), format_name)


def read_preset_file(path: str | os.PathLike, format_name: str) -> tuple[dict, str]:
    """Read and validate the preset file ``path``. Returns the document and its file name for messages."""
    return parse_preset(read_preset_text(path), str(path), format_name), str(path)


def _reject_constant(name: str):
    raise ValueError(f"{name} is not a number JSON allows; use a finite number")


def parse_preset(text: str, source: str, format_name: str, legacy: bool = False) -> dict:
    """Parse and validate preset ``text`` (module docstring). ``legacy=True`` accepts a document without
    a header as the format's oldest version (the text stored inside rigs saved before headers existed)."""
    fmt = _formats.get(format_name)
    if fmt is None:
        raise ValueError(f"unknown preset format {format_name!r}")
    try:
        doc = json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as error:
        raise UserError(f"{source}: not valid JSON (line {error.lineno}, column {error.colno}: {error.msg}); "
                        "fix it, or delete your copy to use the shipped preset") from None
    except ValueError as error:
        raise UserError(f"{source}: {error}") from None
    if not isinstance(doc, dict):
        raise UserError(f"{source}: a preset must be a JSON object with \"format\" and \"version\"")
    _check_header(doc, source, fmt, legacy)
    for key in fmt.required:
        if key not in doc:
            raise UserError(f"{source}: missing \"{key}\" (a {fmt.name} preset needs {', '.join(fmt.required)})")
    for key, shape in fmt.shape.items():
        if key in doc:
            _check_shape(doc[key], shape, source, key)
    return doc


def _check_header(doc: dict, source: str, fmt: PresetFormat, legacy: bool) -> None:
    found = doc.get("format")
    if found is None and legacy:
        return
    if found is None:
        raise UserError(f"{source}: no \"format\" header; the file must start with "
                        f"{{\"format\": \"{fmt.name}\", \"version\": {fmt.version}, ...}}")
    if found != fmt.name:
        raise UserError(f"{source}: this is a {found!r} preset, not {fmt.name!r}")
    version = doc.get("version")
    if isinstance(version, bool) or not isinstance(version, int):
        raise UserError(f"{source}: \"version\" must be a whole number (this extension reads "
                        f"{fmt.oldest_version}..{fmt.version})")
    if version > fmt.version:
        raise UserError(f"{source}: version {version} is newer than this extension reads ({fmt.version}); "
                        "update the extension")
    if version < fmt.oldest_version:
        raise UserError(f"{source}: version {version} is no longer read (oldest: {fmt.oldest_version})")


def _describe(shape) -> str:
    if shape is NUMBER or shape == NUMBER:
        return "a number"
    if shape is str:
        return "a string"
    if shape is bool:
        return "true or false"
    if isinstance(shape, list):
        return "a list"
    if isinstance(shape, dict):
        return "an object"
    if isinstance(shape, tuple):
        return " or ".join(_describe(s) for s in shape)
    return "a value"


def _matches(value: Any, shape) -> bool:
    if shape == ANY:
        return True
    if shape == NUMBER:
        return (isinstance(value, (int, float)) and not isinstance(value, bool)
                and math.isfinite(value))
    if shape is str or shape is bool:
        return isinstance(value, shape)
    if isinstance(shape, list):
        return isinstance(value, list)
    if isinstance(shape, dict):
        return isinstance(value, dict)
    if isinstance(shape, tuple):
        return any(_matches(value, s) for s in shape)
    raise ValueError(f"bad preset shape {shape!r}")


def _check_shape(value: Any, shape, source: str, where: str) -> None:
    """Raise a UserError naming ``where`` (``expressions.smile.jaw_open``) if ``value`` has another shape."""
    if isinstance(shape, tuple):
        for option in shape:
            if _matches(value, option):
                _check_shape(value, option, source, where)
                return
        raise UserError(f"{source}: {where} must be {_describe(shape)}, not {value!r}")
    if not _matches(value, shape):
        raise UserError(f"{source}: {where} must be {_describe(shape)}, not {value!r}")
    if isinstance(shape, list) and shape:
        for index, item in enumerate(value):
            _check_shape(item, shape[0], source, f"{where}[{index}]")
    elif isinstance(shape, dict) and shape:
        if set(shape) == {str}:
            for key, item in value.items():
                _check_shape(item, shape[str], source, f"{where}.{key}")
        else:
            for key, sub in shape.items():
                if key in value:
                    _check_shape(value[key], sub, source, f"{where}.{key}")
