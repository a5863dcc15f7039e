# SPDX-License-Identifier: GPL-3.0-or-later
"""The hand's editable data (``presets/hand/*.json``, the artist's copy in the user folder wins): joints and
limits (Table 6.4), pseudo muscles (Table A.1), geometric muscles (Fig. 6.15), poses and motions, and the
format of the photo feature-point files of 6.2.3. Every reader checks meaning as well as shape and names
the file and the entry when something is wrong."""
from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from ..core.errors import UserError
from ..core.presets import ANY, NUMBER, PresetFormat, parse_preset, read_preset, read_preset_text, register_format, \
    resolve
from .skeleton import DOF_KINDS

__all__ = ["JOINTS", "MUSCLES", "GEOMETRIC", "POSES", "PHOTO_POINTS", "JointsPreset", "MuscleRow",
           "MuscleSpec", "preset_text", "joints_preset", "muscle_specs", "geometric_specs", "poses_preset", "require_keys", "as_array"]

JOINTS = register_format(PresetFormat("faces_hands.hand_joints", 1, required=("joints", "bone_meshes"), shape={
    "joints": [{"bone": str, "parent": str, "body": str, "child": str, "flexion_axis": str, "dofs": {str: [NUMBER]},
                "coupled": {str: NUMBER}}],
    "bone_meshes": {str: [str]}, "capsule_stiffness_nm_per_rad": NUMBER, "friction": NUMBER,
    "finger_flexion_tilt": NUMBER}))
MUSCLES = register_format(PresetFormat("faces_hands.hand_muscles", 1, required=("muscles",), shape={
    "muscles": [{"name": str, "group": str, "l0_mm": NUMBER, "f_max_n": NUMBER, "force_source": str,
                 "rows": [[ANY]], "note": str}]}))
GEOMETRIC = register_format(PresetFormat("faces_hands.hand_geometric_muscles", 1, required=("muscles",), shape={
    "muscles": [{"name": str, "pseudo": str, "path": [[ANY]], "bones": [str], "width_mm": NUMBER,
                 "thickness_mm": [NUMBER], "skin_distance_mm": NUMBER, "rows": NUMBER, "columns": NUMBER,
                 "bulge": NUMBER}]}))
POSES = register_format(PresetFormat("faces_hands.hand_poses", 1, required=("poses",), shape={
    "poses": {str: {"description": str, "contractions": {str: NUMBER}, "squeeze": {str: NUMBER}}},
    "motions": {str: {"description": str, "keys": [[ANY]]}}}))
PHOTO_POINTS = register_format(PresetFormat("faces_hands.hand_photo_points", 1, required=("points", "ruler"), shape={
    "points": {str: [NUMBER]}, "ruler": [[NUMBER]], "ruler_mm": NUMBER, "image": str, "side": str}))


def require_keys(entry: dict, keys: tuple[str, ...], where: str) -> None:
    """A UserError naming the first of ``keys`` that ``entry`` lacks."""
    missing = [key for key in keys if key not in entry]
    if missing:
        raise UserError(f"{where}: missing \"{missing[0]}\" (needs {', '.join(keys)})")


def preset_text(name: str) -> str:
    """The text of ``presets/hand/<name>`` (the user's copy if there is one), for caching keys."""
    return read_preset_text(resolve(f"hand/{name}"))


@dataclass(frozen=True)
class JointsPreset:
    joints: list[dict]
    bone_meshes: dict[str, list[str]]
    capsule_stiffness: float
    friction: float
    finger_flexion_tilt: float = 1.0    # share of MyoHand's finger flexion-axis tilt kept (:mod:`.reference`)


def joints_preset(text: str | None = None, source: str = "hand/joints.json") -> JointsPreset:
    """Table 6.4 and the joint hierarchy, checked: known DOF kinds, ordered limits, parents before children."""
    doc = parse_preset(text, source, JOINTS.name) if text is not None else read_preset("hand/joints.json", JOINTS.name)[0]
    seen = {"forearm"}
    for joint in doc["joints"]:
        where = f"{source}: joint {joint.get('bone')!r}"
        require_keys(joint, ("bone", "parent", "body", "child", "flexion_axis", "dofs"), where)
        if joint["parent"] not in seen:
            raise UserError(f"{where}: its parent {joint['parent']!r} must come earlier in the list")
        seen.add(joint["bone"])
        for kind, limits in joint["dofs"].items():
            if kind not in DOF_KINDS:
                raise UserError(f"{where}: unknown DOF {kind!r}; use {', '.join(DOF_KINDS)}")
            if len(limits) != 2 or not limits[0] <= limits[1] or not -180 <= limits[0] <= limits[1] <= 180:
                raise UserError(f"{where}: {kind} limits must be [lower, upper] degrees with lower <= upper")
        for kind in joint.get("coupled", {}):
            if kind != "rotation" or "rotation" not in joint["dofs"] or "flexion" not in joint["dofs"]:
                raise UserError(f"{where}: only a rotation DOF can follow flexion ('coupled': {{'rotation': ratio}})")
    missing = [b for b in seen if b not in doc["bone_meshes"]]
    if missing:
        raise UserError(f"{source}: bone_meshes lists no meshes for {', '.join(sorted(missing))}")
    friction = float(doc.get("friction", 0.015))
    capsule = float(doc.get("capsule_stiffness_nm_per_rad", 0.0))
    if friction <= 0 or capsule < 0:
        raise UserError(f"{source}: friction must be > 0 and capsule_stiffness_nm_per_rad >= 0")
    tilt = float(doc.get("finger_flexion_tilt", 1.0))
    if not 0.0 <= tilt <= 1.0:
        raise UserError(f"{source}: finger_flexion_tilt must be a share in [0, 1] (1: MyoHand's axes as they are)")
    return JointsPreset(doc["joints"], doc["bone_meshes"], capsule, friction, tilt)


@dataclass(frozen=True)
class MuscleRow:
    bone: str
    dof: str
    sign: float
    arm: float          # metres


@dataclass(frozen=True)
class MuscleSpec:
    """One pseudo muscle of Table A.1 (SI units)."""
    name: str
    group: str
    rest_length: float  # l0, metres
    max_force: float    # F_max, newtons
    force_source: str
    rows: tuple[MuscleRow, ...]


def muscle_specs(text: str | None = None, source: str = "hand/muscles.json") -> list[MuscleSpec]:
    """The pseudo muscles (Table A.1), lengths in metres, forces in newtons."""
    doc = parse_preset(text, source, MUSCLES.name) if text is not None else read_preset("hand/muscles.json", MUSCLES.name)[0]
    out, names = [], set()
    for entry in doc["muscles"]:
        where = f"{source}: muscle {entry.get('name')!r}"
        require_keys(entry, ("name", "group", "l0_mm", "f_max_n", "rows"), where)
        if entry["name"] in names:
            raise UserError(f"{where} appears twice")
        names.add(entry["name"])
        if entry["l0_mm"] <= 0 or entry["f_max_n"] <= 0:
            raise UserError(f"{where}: l0_mm and f_max_n must be > 0")
        rows = []
        for row in entry["rows"]:
            ok = (isinstance(row, list) and len(row) == 4 and isinstance(row[0], str) and row[1] in DOF_KINDS
                  and row[2] in (1, -1) and isinstance(row[3], (int, float)) and row[3] > 0)
            if not ok:
                raise UserError(f"{where}: a row must be [bone, flexion|abduction|rotation, 1|-1, arm_mm > 0], "
                                f"got {json.dumps(row)}")
            rows.append(MuscleRow(row[0], row[1], float(row[2]), float(row[3]) / 1000.0))
        if not rows:
            raise UserError(f"{where} moves no joint; give it at least one row")
        out.append(MuscleSpec(entry["name"], entry["group"], entry["l0_mm"] / 1000.0, float(entry["f_max_n"]),
                              entry.get("force_source", ""), tuple(rows)))
    return out


def geometric_specs(text: str | None = None, source: str = "hand/geometric_muscles.json") -> list[dict]:
    """The geometric muscles of Fig. 6.15 as dicts (checked further by :mod:`.geometric`)."""
    if text is None:
        return read_preset("hand/geometric_muscles.json", GEOMETRIC.name)[0]["muscles"]
    return parse_preset(text, source, GEOMETRIC.name)["muscles"]


def poses_preset(text: str | None = None, source: str = "hand/poses.json") -> dict:
    """Poses (contractions) and motions (timed keys of poses) as read; checked by :mod:`.motion`."""
    if text is None:
        return read_preset("hand/poses.json", POSES.name)[0]
    return parse_preset(text, source, POSES.name)


def as_array(values, what: str, shape: tuple[int, ...]) -> np.ndarray:
    array = np.asarray(values, dtype=np.float64)
    if array.shape != shape or not np.all(np.isfinite(array)):
        raise UserError(f"{what} must be {shape} finite numbers")
    return array
