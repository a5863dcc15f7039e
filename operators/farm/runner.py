# SPDX-License-Identifier: GPL-3.0-or-later
"""Rows run in this Blender process: the rig built (or loaded) once, then every row baked from the same
state (the default character is copied from the user's cache folder when a run before kept it there,
``speech.services.built_in_rig_file``: a worker's start is then Blender's start and the engine rig's load), written into this process's staging folder and committed all or nothing
(:mod:`...faces_hands_addon.farm.resume`).

Every row reopens the rig file (milliseconds), so no row sees what an earlier one left in the scene, and
reuses the engine rig loaded once (its bakes start from rest). The whole runner, the rig's build included,
uses one BLAS thread: a threaded BLAS splits the bake's large products by its thread count, and rounds them
differently (measured: the same row's GLB differed between 1 and 2 OpenBLAS threads). So a row gives the
same bytes whatever ran before it, whatever the worker count, the chunking or the machine's core count.
"""
from __future__ import annotations

import hashlib
import shutil
import sys
import tempfile
import time
from pathlib import Path

import bpy

from ...faces_hands_addon.anim.shape_cache import engine_fingerprint
from ...faces_hands_addon.core.blas import one_blas_thread
from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.farm.resume import (RunIdentity, commit_row, file_sha256, remove_stale_staging,
                                               staging_folder)
from ...faces_hands_addon.farm.rows import JobRow
from ..adapters.blendfile import open_blend
from ..cli.interrupts import raise_pending
from ..adapters.rig_store import get_rig, is_rig
from ..speech.services import MASK, run_line, shared_default_rig

__all__ = ["RowRunner", "extension_version", "run_identity", "peak_rss_mb"]


def extension_version() -> str:
    """The version in the installed extension's manifest."""
    import tomllib
    manifest = Path(__file__).resolve().parents[2] / "blender_manifest.toml"
    try:
        return str(tomllib.loads(manifest.read_text(encoding="utf-8"))["version"])
    except (OSError, KeyError, ValueError):
        return "unknown"


def run_identity(rig: str | None, fps: float) -> RunIdentity:
    """What every row's key shares (``resume.row_key``): version, engine, rig (its bytes' SHA-256), fps."""
    return RunIdentity(extension_version(), engine_fingerprint(),
                       file_sha256(rig) if rig not in (None, MASK) else (rig or "default"),
                       float(fps))


def peak_rss_mb() -> float | None:
    """This process's peak resident memory in MB (None where the platform does not say)."""
    try:
        import resource
    except ImportError:
        return None
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return round(peak / (1024 * 1024) if sys.platform == "darwin" else peak / 1024, 1)


def _quiet(fraction: float, message: str = "") -> None:  # noqa: ARG001 - the progress signature
    raise_pending()


class RowRunner:
    """Runs rows into ``out_dir``; ``rig``: a .blend with a face rig or a character, None for the default
    character or ``"mask"`` for the face-only head (either built once, here)."""

    def __init__(self, out_dir: Path, rig: str | None, fps: float, progress=None):
        self._blas = one_blas_thread()              # applies at once; put back by close()
        self.out_dir, self.fps = Path(out_dir), float(fps)
        self.version = extension_version()
        remove_stale_staging(self.out_dir)
        self.staging = staging_folder(self.out_dir)
        self.staging.mkdir(parents=True, exist_ok=True)
        self._tmp = tempfile.mkdtemp(prefix="fh-farm-")
        self.rig_path = rig if rig not in (None, MASK) else shared_default_rig(self._tmp, self.fps,
                                                                                progress or _quiet, rig)
        open_blend(self.rig_path)
        self.engine_rig = get_rig(next(o for o in bpy.data.objects if is_rig(o, "face") or is_rig(o, "character")))

    def run(self, row: JobRow, key: str, inputs: dict) -> dict:
        """Bake ``row`` and commit its files; returns its wall and CPU seconds (``seconds``, ``cpu_s``: the
        CPU time is what a shared machine's load does not inflate). A bad row raises :class:`UserError` and
        leaves its outputs as they were."""
        started, cpu = time.perf_counter(), time.process_time()
        stage = self.staging / f"line-{row.line}-{hashlib.sha256(row.out.encode()).hexdigest()[:8]}"
        shutil.rmtree(stage, ignore_errors=True)
        stage.mkdir(parents=True)
        try:
            with one_blas_thread():     # also limits a BLAS library loaded since the runner started (scipy's)
                run_line(_speech_spec(row, stage), self.rig_path, self.fps, _quiet, engine_rig=self.engine_rig)
            raise_pending()
            staged = {name: stage / name for name in row.outputs()}
            commit_row(self.out_dir, row, key, inputs, staged, self.staging, self.version)
        finally:
            shutil.rmtree(stage, ignore_errors=True)
        return {"seconds": round(time.perf_counter() - started, 3), "cpu_s": round(time.process_time() - cpu, 3)}

    def close(self) -> None:
        self._blas.restore_original_limits()
        shutil.rmtree(self.staging, ignore_errors=True)
        shutil.rmtree(self._tmp, ignore_errors=True)


def _speech_spec(row: JobRow, stage: Path) -> dict:
    """The speech service's take spec for ``row``, every output in the staging folder ``stage``."""
    from ...faces_hands_addon.emotion import parse_emotion
    if row.action not in ("speak", "lipsync"):
        raise UserError(f"action {row.action!r} cannot run here")
    optional = {name: (stage / value if value else None) for name, value in
                (("live_link", row.live_link), ("cues", row.cues))}
    return {"out": str(stage / row.out), "text": row.text, "audio": row.audio or None,
            "transcript": row.transcript or None, "voice": row.voice, "rate": row.rate,
            "animation": row.animation, "view": "front", "style": row.style or None, "seed": row.seed,
            "emotion": parse_emotion(row.emotion), "sheet": None, **optional,
            "outputs": [stage / name for name in row.outputs()]}
