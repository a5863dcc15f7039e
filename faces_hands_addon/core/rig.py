# SPDX-License-Identifier: GPL-3.0-or-later
"""The rig protocol every subsystem implements (a face, a hand, ...), and the one registry that saves and
loads rigs of every kind.

A rig is an animatable simulation: named controls (:class:`..controls.ControlSpec`), a rest pose,
``step(layer_values, dt) -> Pose``, which mixes the control layers (:func:`..anim.layers.mix`, thesis
4.3.5), advances the simulation by ``dt`` seconds and returns the pose as plain arrays, and
``settled(layer_values, max_time, dt) -> Pose``, the static shape reached from rest. :class:`Rig` lists
exactly what the bakes, the live preview, jobs and export call (:data:`PROTOCOL_METHODS`); a rig's own
helpers (a face's ``relax``, a hand's ``pose_joints``) stay inside its subsystem. Blender code never looks
inside a rig: it writes :class:`Pose` positions into shape keys and transforms onto objects.

Saved rigs are ``.npz`` archives (``np.savez_compressed``, never pickles) with a JSON ``meta_json`` entry
whose ``"format"`` names the rig kind (``"faces_hands.face_rig/1"``); :func:`load_rig` dispatches on it
through :func:`register_rig_kind`. :func:`rig_identity` names stored rig data cheaply (a hash computed once,
when the rig is stored), so a live preview never re-hashes a rig per tick.
"""
from __future__ import annotations

import hashlib
import importlib
import json
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Mapping, Protocol, runtime_checkable

import numpy as np

from .controls import ControlSpec
from .errors import UserError

__all__ = ["Pose", "Rig", "register_rig_kind", "rig_kinds", "save_rig", "load_rig", "rig_format",
           "rig_identity", "write_rig_archive", "read_rig_archive", "load_rig_bytes", "MAX_RIG_BYTES",
           "PROTOCOL_METHODS", "BONE_ROLE"]

#: refuse stored rig data that unpacks to more than this (a corrupt or hostile file)
MAX_RIG_BYTES = 4_000_000_000

LayerValues = Mapping[str, Mapping[str, float]]


#: Pose.transforms roles naming an armature bone: ``"bone:<name>"`` -> that pose bone's ``matrix_basis``
BONE_ROLE = "bone:"


@dataclass
class Pose:
    """A rig's pose at one instant, in the rig's output coordinates (no Blender types): ``positions`` of
    the deforming parts (role -> (N, 3) float32, e.g. ``"skin"``) and ``transforms`` of the rigid parts
    (role -> 4x4 float64, e.g. ``"jaw"``, ``"eye_L"``) and of armature bones (:data:`BONE_ROLE` + name ->
    the pose bone's ``matrix_basis``, e.g. a character's ``"bone:head"``)."""
    positions: dict[str, np.ndarray] = field(default_factory=dict)
    transforms: dict[str, np.ndarray] = field(default_factory=dict)


@runtime_checkable
class Rig(Protocol):
    """What every rig offers (module docstring)."""

    kind: str                       # e.g. "face"; the saved archive's format names the exact variant
    identity: str                   # names the stored data it was saved as / loaded from (set by the store)

    def control_specs(self) -> dict[str, ControlSpec]: ...

    def step(self, layer_values: LayerValues, dt: float) -> Pose:
        """Mix the layers (``anim.layers.mix``), advance one frame of ``dt`` seconds, return the pose."""

    def settled(self, layer_values: LayerValues, max_time: float, dt: float) -> Pose:
        """The pose reached from rest with the mixed ``layer_values`` after at most ``max_time`` seconds
        (a static shape: it does not depend on what the rig did before)."""

    def reset(self) -> None:
        """Controls at their defaults, the simulation at rest."""

    def rest_pose(self) -> Pose: ...

    def worker_copy(self) -> "Rig":
        """An independent rig sharing the read-only data (bakes settle on several threads)."""

    def save(self, path: str | Path) -> None: ...

    @classmethod
    def load(cls, path: str | Path) -> "Rig": ...


#: what bakes, live preview, jobs and export may call on a rig: the protocol, no more
PROTOCOL_METHODS = ("control_specs", "step", "settled", "reset", "rest_pose", "worker_copy", "save", "load")


_kinds: dict[str, Callable[[Path], Rig] | str] = {}


def register_rig_kind(format_name: str, loader: Callable[[Path], Rig] | str) -> None:
    """Make :func:`load_rig` read archives whose ``meta.format`` is ``format_name`` with ``loader(path)``.
    ``loader`` may be ``"package.module:Class.load"``: the module is imported only when such a rig is
    loaded, so registering a kind costs nothing."""
    _kinds[format_name] = loader


def _loader(format_name: str | None) -> Callable[[Path], Rig] | None:
    loader = _kinds.get(format_name)
    if isinstance(loader, str):
        module_name, _, attributes = loader.partition(":")
        loader = importlib.import_module(module_name)
        for attribute in attributes.split("."):
            loader = getattr(loader, attribute)
        _kinds[format_name] = loader
    return loader


def rig_kinds() -> list[str]:
    return sorted(_kinds)


def write_rig_archive(path: str | Path, meta: dict, arrays: Mapping[str, np.ndarray]) -> None:
    """Write a rig archive: ``meta`` (JSON, sorted keys) + arrays, as an ``.npz`` that ``np.load`` reads.
    Entries carry a fixed time stamp, so the same rig gives the same bytes (``np.savez`` stamps the clock)."""
    entries = {"meta_json": np.frombuffer(json.dumps(meta, sort_keys=True).encode("utf-8"), np.uint8)}
    entries.update(arrays)
    with zipfile.ZipFile(Path(path), "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name, value in entries.items():
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            with archive.open(info, "w", force_zip64=True) as handle:
                np.lib.format.write_array(handle, np.asanyarray(value), allow_pickle=False)


def _checked_sizes(path: Path) -> None:
    try:
        with zipfile.ZipFile(path) as archive:
            total = sum(info.file_size for info in archive.infolist())
    except (OSError, zipfile.BadZipFile) as error:
        raise UserError(f"{path}: not a Faces & Hands rig ({error})") from None
    if total > MAX_RIG_BYTES:
        raise UserError(f"{path}: the stored rig unpacks to {total:,} bytes (at most {MAX_RIG_BYTES:,}); "
                        "the file is damaged")


def rig_format(path: str | Path) -> str | None:
    """The ``format`` of a rig archive, or None for anything that is not one."""
    try:
        with np.load(Path(path), allow_pickle=False) as data:
            return json.loads(bytes(data["meta_json"]).decode("utf-8")).get("format")
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile):
        return None


def read_rig_archive(path: str | Path, expected_format: str, what: str, names: tuple[str, ...] = (),
                     prefixes: tuple[str, ...] = ()) -> tuple[dict, dict[str, np.ndarray]]:
    """Metadata and the named arrays (plus every array whose name starts with one of ``prefixes``) of a
    rig archive, checking its format and size first. Never unpickles anything; bad files raise UserError."""
    path = Path(path)
    _checked_sizes(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(bytes(data["meta_json"]).decode("utf-8"))
            if meta.get("format") != expected_format:
                raise UserError(f"{path}: not a Faces & Hands {what} (format {meta.get('format')!r})")
            wanted = set(names)
            if prefixes:
                wanted |= {k for k in data.files if k.startswith(prefixes)}
            arrays = {key: data[key] for key in sorted(wanted)}
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile) as error:
        raise UserError(f"{path}: cannot read the {what} ({error})") from None
    for key, value in arrays.items():
        if value.dtype.kind == "f" and not np.all(np.isfinite(value)):
            raise UserError(f"{path}: the stored {what} holds non-finite numbers in {key!r}; it is damaged")
    return meta, arrays


def load_rig(path: str | Path) -> Rig:
    """Load a saved rig of any registered kind."""
    path = Path(path)
    _checked_sizes(path)
    found = rig_format(path)
    loader = _loader(found)
    if loader is None:
        raise UserError(f"{path}: not a rig this extension can read (format {found!r}; known: "
                        f"{', '.join(rig_kinds()) or 'none'})")
    return loader(path)


def save_rig(rig: Rig) -> bytes:
    """The bytes of ``rig.save`` (what a Blender object stores); sets ``rig.identity`` to their name."""
    with tempfile.TemporaryDirectory(prefix="fh-rig-") as tmp:
        path = Path(tmp) / "rig.npz"
        rig.save(path)
        data = path.read_bytes()
    rig.identity = rig_identity(data)
    return data


def load_rig_bytes(data: bytes, identity: str | None = None) -> Rig:
    """:func:`load_rig` from stored bytes; ``rig.identity`` is ``identity`` (or computed once here)."""
    with tempfile.TemporaryDirectory(prefix="fh-rig-") as tmp:
        path = Path(tmp) / "rig.npz"
        path.write_bytes(bytes(data))
        rig = load_rig(path)
    rig.identity = identity or rig_identity(data)
    return rig


def rig_identity(data: bytes) -> str:
    """A short name of stored rig data (SHA-256 prefix): equal data, equal identity."""
    return hashlib.sha256(bytes(data)).hexdigest()[:32]

