# SPDX-License-Identifier: GPL-3.0-or-later
"""Bytecode for the modules a session loaded from the extension and its bundled wheels.

Blender runs Python with ``sys.dont_write_bytecode`` set, and it installs an extension's wheels by
unpacking them, without the compile step pip does. So every session compiled the sources of scipy,
numba and the extension again: on 23 s of speech, ``./fh speak`` took 22.6 s without ``__pycache__``
files and 19.5 s with them (same machine, same run). Python still *reads* bytecode with writing switched
off, so :func:`write_missing_bytecode` writes, once, the ``__pycache__`` files of the modules the session
has loaded from the given folders; later sessions load them. Files are written atomically (two Blender
processes may do it at once) and checked against the source's time stamp and size, as Python does.

Only modules inside a package folder of a *wheel* folder are compiled: Blender uninstalls a wheel by
removing its top-level folders, which takes their ``__pycache__`` along, while a root ``__pycache__``
beside single-file modules would stay behind. The extension's own folder is removed as a whole.
"""
from __future__ import annotations

import importlib.util
import py_compile
import sys
from pathlib import Path


def missing_bytecode(extension_roots, wheel_roots) -> list[tuple[str, str]]:
    """(source, bytecode path) of every loaded module under the roots whose bytecode is missing."""
    extension_roots = [Path(r).resolve() for r in extension_roots]
    wheel_roots = [Path(r).resolve() for r in wheel_roots]
    found = []
    for module in list(sys.modules.values()):
        source = getattr(module, "__file__", None)
        if not source or not source.endswith(".py"):
            continue
        path = Path(source).resolve()
        inside = any(root in path.parents for root in extension_roots) or \
            any(root in path.parents and path.parent != root for root in wheel_roots)
        if not inside:
            continue
        cached = importlib.util.cache_from_source(str(path))
        if not Path(cached).exists():
            found.append((str(path), cached))
    return sorted(set(found))


def write_missing_bytecode(extension_roots, wheel_roots) -> int:
    """Compile the loaded modules' missing bytecode (:func:`missing_bytecode`); returns how many files
    were written. A folder that cannot be written or a source that does not compile is skipped."""
    written = 0
    for source, cached in missing_bytecode(extension_roots, wheel_roots):
        try:
            py_compile.compile(source, cfile=cached, doraise=True,
                               invalidation_mode=py_compile.PycInvalidationMode.TIMESTAMP)
        except (OSError, py_compile.PyCompileError):
            continue
        written += 1
    return written
