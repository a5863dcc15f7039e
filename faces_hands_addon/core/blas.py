# SPDX-License-Identifier: GPL-3.0-or-later
"""One BLAS thread, for work whose result must not depend on how many cores the machine has, and for loops
of tiny problems where a threaded BLAS spends longer waking its threads than computing (the per-frame
weight fit, :mod:`..anim.weights`).

A multi-threaded BLAS splits its sums differently for different thread counts, so a product or a solve
rounds differently on a 2-core and a 16-core machine. Most results only move in the last bits, but a
search that makes discrete choices from such numbers (the landmark location and head fitting of thesis
3.1.2) can take another path: the MakeHuman test head's landmarks moved by up to 8.8 mm between one and
two BLAS threads on the same machine. Work of that kind runs inside :func:`one_blas_thread`.

The limit is the process's (BLAS libraries have one thread count each), so it is shared by every thread:
it is applied when the first holder enters and put back only when the last one leaves. A bake fits its
weights on a second thread while the first simulates; when each thread set and restored the count on its
own, one thread's exit gave the other, still fitting, two threads again, and a jobs row's GLB differed in
3 weights (1.4e-9) between two runs of the same manifest. Every entry also looks for BLAS libraries loaded
since the last one (scipy brings its own OpenBLAS, loaded after numpy's): each is limited as it appears.
"""
from __future__ import annotations

import threading

from threadpoolctl import ThreadpoolController

__all__ = ["one_blas_thread"]

_LOCK = threading.Lock()
_HELD = {"count": 0, "limiters": [], "paths": set()}


class one_blas_thread:  # noqa: N801 - used like a function: ``with one_blas_thread():``
    """Hold the process at one BLAS thread from construction until :meth:`release` (or the end of the
    ``with`` block); the libraries' own counts are back once no holder is left."""

    def __init__(self) -> None:
        self._held = True
        with _LOCK:
            # every entry: the libraries loaded since the last one are limited too (module docstring)
            blas = ThreadpoolController().select(user_api="blas")
            new = [lib.filepath for lib in blas.lib_controllers if lib.filepath not in _HELD["paths"]]
            if new:
                _HELD["limiters"].append(blas.select(filepath=new).limit(limits=1))
                _HELD["paths"].update(new)
            _HELD["count"] += 1

    def __enter__(self) -> "one_blas_thread":
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def release(self) -> None:
        """Leave the hold (once); the last holder to leave puts every library's count back."""
        with _LOCK:
            if not self._held:
                return
            self._held = False
            _HELD["count"] -= 1
            if _HELD["count"] == 0:
                for limiter in reversed(_HELD["limiters"]):     # the first one saved the counts of before
                    limiter.restore_original_limits()
                _HELD["limiters"].clear()
                _HELD["paths"].clear()

    restore_original_limits = release   # threadpoolctl's name, for a holder kept outside a ``with``
