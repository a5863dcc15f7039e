# SPDX-License-Identifier: GPL-3.0-or-later
"""Bytecode written for loaded modules of the extension and its wheels (core.bytecode), as Blender
writes none: only modules under the given roots, never a wheel root's single-file modules, once."""
from __future__ import annotations

import importlib
import importlib.util
import sys
from pathlib import Path

from faces_hands_addon.core import bytecode


def _package(root: Path, name: str) -> Path:
    (root / name).mkdir(parents=True)
    (root / name / "__init__.py").write_text("from . import inner\n")
    (root / name / "inner.py").write_text("VALUE = 42\n")
    return root / name


def test_loaded_modules_get_bytecode_once_and_load_from_it(tmp_path, monkeypatch):
    extension, wheels, elsewhere = tmp_path / "ext", tmp_path / "site", tmp_path / "other"
    _package(extension, "fh_bc_ext")
    _package(wheels, "fh_bc_wheel")
    _package(elsewhere, "fh_bc_other")
    (wheels / "fh_bc_single.py").write_text("X = 1\n")
    for folder in (extension, wheels, elsewhere):
        monkeypatch.syspath_prepend(str(folder))
    monkeypatch.setattr(sys, "dont_write_bytecode", True)          # as in Blender
    names = ["fh_bc_ext", "fh_bc_wheel", "fh_bc_other", "fh_bc_single"]
    try:
        for name in names:
            importlib.import_module(name)
        assert not list(tmp_path.rglob("*.pyc"))
        missing = bytecode.missing_bytecode([extension], [wheels])
        assert sorted(Path(source).relative_to(tmp_path).as_posix() for source, _ in missing) == [
            "ext/fh_bc_ext/__init__.py", "ext/fh_bc_ext/inner.py",
            "site/fh_bc_wheel/__init__.py", "site/fh_bc_wheel/inner.py"]
        assert bytecode.write_missing_bytecode([extension], [wheels]) == 4
        assert bytecode.write_missing_bytecode([extension], [wheels]) == 0
        assert not list((elsewhere).rglob("*.pyc")) and not (wheels / "__pycache__").exists()
        cached = Path(importlib.util.cache_from_source(str(wheels / "fh_bc_wheel" / "inner.py")))
        assert cached.is_file()
        for name in names:
            sys.modules.pop(name, None)
        sys.modules.pop("fh_bc_wheel.inner", None)
        module = importlib.import_module("fh_bc_wheel.inner")
        assert module.VALUE == 42 and module.__cached__ == str(cached)
    finally:
        for name in list(sys.modules):
            if name.startswith("fh_bc_"):
                sys.modules.pop(name)


def test_unwritable_or_vanished_sources_are_skipped(tmp_path, monkeypatch):
    folder = _package(tmp_path / "ext", "fh_bc_gone")
    monkeypatch.syspath_prepend(str(tmp_path / "ext"))
    try:
        importlib.import_module("fh_bc_gone")
        for path in folder.iterdir():
            path.unlink()
        folder.rmdir()
        assert bytecode.write_missing_bytecode([tmp_path / "ext"], []) == 0
    finally:
        for name in list(sys.modules):
            if name.startswith("fh_bc_"):
                sys.modules.pop(name)
