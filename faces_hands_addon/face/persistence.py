# SPDX-License-Identifier: GPL-3.0-or-later
"""Saving and restoring face rigs (default and fitted heads share this): the build inputs, the skin
material, the control values and the whole simulation state, so a loaded rig continues exactly where the
saved one stopped (deterministic rebuild from the inputs, then the state put back).

Archives go through :func:`..core.rig.write_rig_archive` / :func:`..core.rig.read_rig_archive` (``.npz``
with a JSON header, never pickles, size-capped, non-finite numbers refused).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.rig import read_rig_archive
from .template import TemplateInputs

__all__ = ["GUARDS", "STATE_ARRAYS", "SavedRig", "saved_state", "restore_state", "read_saved_rig"]

GUARDS = ("bone_guard", "teeth_guard")
STATE_ARRAYS = ("positions", "velocity", "anchor", "mirror", "mass_scale")
INPUT_ARRAYS = ("canonical_vertices", "canonical_faces", "skull_vertices", "skull_faces", "jaw_vertices",
                "jaw_faces")


@dataclass
class SavedRig:
    """What :func:`read_saved_rig` read from a saved rig: metadata, template inputs, state and guard arrays
    (``arrays`` also holds any ``extra`` arrays the caller asked for)."""
    meta: dict
    inputs: TemplateInputs
    arrays: dict[str, np.ndarray]
    guards: dict[str, dict[str, np.ndarray]]


def saved_state(rig, inputs: TemplateInputs) -> tuple[dict, dict[str, np.ndarray]]:
    """Metadata and arrays every saved face rig holds: the build ``inputs``, material, controls,
    simulation and guard state."""
    face = rig.face
    meta = {"material": rig.material.to_dict(), "controls": {k: float(v) for k, v in rig.controls.items()},
            "time": rig.time,
            "started": face.integrator.started, "contours": sorted(inputs.contours),
            "landmarks_json": inputs.landmarks_json, "muscles_json": inputs.muscles_json,
            "closed_lips": bool(inputs.closed_lips)}
    arrays = {name: getattr(inputs, name) for name in INPUT_ARRAYS}
    arrays.update(positions=face.network.positions, velocity=face.integrator.velocity,
                  anchor=face.network.attachments.anchor, mirror=face.network.attachments.mirror,
                  mass_scale=np.array([face.integrator.mass_scale]))
    for name in sorted(inputs.contours):
        arrays[f"contour__{name}"] = np.asarray(inputs.contours[name])
    for guard_name in GUARDS:
        for key, value in getattr(face, guard_name).state().items():
            arrays[f"{guard_name}__{key}"] = value
    return meta, arrays


def restore_state(rig, saved: SavedRig) -> None:
    """Put back controls, simulation and guard state read by :func:`read_saved_rig`."""
    rig.set_controls(saved.meta["controls"], strict=False)
    network, integrator = rig.face.network, rig.face.integrator
    network.positions[...] = saved.arrays["positions"]
    integrator.velocity[...] = saved.arrays["velocity"]
    network.set_attachment_targets(saved.arrays["anchor"], saved.arrays["mirror"])
    integrator.mass_scale = float(saved.arrays["mass_scale"][0])
    jaw = rig.jaw_transform()
    for name, state in saved.guards.items():
        guard = getattr(rig.face, name)
        guard.set_bone_transforms([np.eye(4), jaw])
        guard.set_state(state)
    integrator.started = bool(saved.meta["started"])
    rig.time = float(saved.meta["time"])


def read_saved_rig(path: str | Path, expected_format: str, what: str, extra: tuple[str, ...] = ()) -> SavedRig:
    """Read a face rig archive (format checked, never unpickles anything); bad files raise UserError."""
    meta, arrays = read_rig_archive(path, expected_format, what, INPUT_ARRAYS + STATE_ARRAYS + tuple(extra),
                                    prefixes=("contour__",) + tuple(g + "__" for g in GUARDS))
    contours = {name: arrays[f"contour__{name}"] for name in meta["contours"]}
    inputs = TemplateInputs(arrays["canonical_vertices"], arrays["canonical_faces"], contours,
                            arrays["skull_vertices"], arrays["skull_faces"], arrays["jaw_vertices"],
                            arrays["jaw_faces"], meta["landmarks_json"], meta["muscles_json"],
                            closed_lips=bool(meta.get("closed_lips", False)))   # rigs saved before: open
    guards = {g: {k.split("__", 1)[1]: arrays[k] for k in arrays if k.startswith(g + "__")} for g in GUARDS}
    return SavedRig(meta, inputs, {k: arrays[k] for k in STATE_ARRAYS + tuple(extra)}, guards)
