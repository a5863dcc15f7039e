# SPDX-License-Identifier: GPL-3.0-or-later
"""The head moving as a whole with the speech (thesis 4.2.1, 4.3.5: raised at pitch maxima, tilted,
turned away at the start of a turn): a take's head channels become the face rig object's *delta*
rotation about a neck pivot, so the artist's own location/rotation keys are never touched. The eyes,
teeth and tongue are parented to the rig object and follow; exports carry it as the root node's
rotation and translation in the take's clip.

A character (a rig with the head controls of ``character.head``) turns its head on its neck instead: the
channels go to its behaviour layer (``fh.behavior.head_pitch/yaw/roll``), whose mixed values drive the
armature's neck and head bones; exports carry them as those bones' rotation.

Blender applies the delta rotation after the object's own rotation (``matrix = D @ R``), so turning by
``D`` about the pivot ``c`` (the object's own coordinates) needs ``delta_location = c' - D c'`` with
``c' = R S c``.
"""
from __future__ import annotations

import numpy as np

from ..adapters.timing import seconds_to_frames
from ...faces_hands_addon.character.head import HEAD_TRACK_LAYER

HEAD_PATHS = ("delta_rotation_euler", "delta_location")
HEAD_LAYER = HEAD_TRACK_LAYER          # the behaviour layer: where a character's head turn goes


def _on_bones(obj) -> bool:
    """Does ``obj`` turn its head on an armature's bones (a character), not as a whole?"""
    from ...faces_hands_addon.character.head import HEAD_CONTROLS
    from ..adapters.rig_store import rig_controls
    names = {name for name, _, _ in rig_controls(obj)}
    return all(control in names for control in HEAD_CONTROLS)


def head_paths(obj) -> tuple[str, ...]:
    """The data paths a take's head motion writes on ``obj`` (what replacing a take removes)."""
    if _on_bones(obj):
        from ...faces_hands_addon.character.head import HEAD_CONTROLS
        from ..adapters.controls import data_path
        return tuple(data_path(control, HEAD_LAYER) for control in HEAD_CONTROLS)
    return HEAD_PATHS


def neck_pivot(obj) -> np.ndarray:
    """A point at the back of the head, low near the jaw's hinge, in the object's own coordinates (the head
    faces -Y with Z up): the middle in X, the back in Y, 15 % of the height above the lowest point."""
    co = np.empty(len(obj.data.vertices) * 3)
    obj.data.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    low, high = co.min(axis=0), co.max(axis=0)
    return np.array([(low[0] + high[0]) / 2, high[1], low[2] + 0.15 * (high[2] - low[2])])


EULER_ORDERS = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")


def _own_rotation_scale(obj) -> np.ndarray:
    """``R S`` of the object's own transform (without its delta)."""
    import mathutils
    mode = obj.rotation_mode
    if mode == "QUATERNION":
        rotation = obj.rotation_quaternion.to_matrix()
    elif mode == "AXIS_ANGLE":
        angle, *axis = obj.rotation_axis_angle
        rotation = mathutils.Matrix.Rotation(angle, 3, axis)
    else:
        rotation = obj.rotation_euler.to_matrix()
    return np.array(rotation) @ np.diag(np.array(obj.scale))


def _delta_location(obj, rx, ry, rz) -> np.ndarray:
    """The delta location (one row per angle triple) that keeps the neck pivot in place."""
    import mathutils
    order = obj.rotation_mode if obj.rotation_mode in EULER_ORDERS else "XYZ"
    turn = np.array([np.array(mathutils.Euler(angles, order).to_matrix()) for angles in zip(rx, ry, rz)])
    pivot = _own_rotation_scale(obj) @ neck_pivot(obj)
    return pivot[None, :] - turn @ pivot


def _pose_head_bones(obj, controls: dict) -> None:
    """:func:`pose_head` of a character: the artist's layer of its head controls (the take's curves on the
    behaviour layer muted meanwhile), back to rest for empty ``controls``."""
    from ...faces_hands_addon.character.head import TRACK_CONTROLS
    from ..adapters.controls import prop_name
    from ..adapters.fcurves import existing_channelbag
    bag = existing_channelbag(obj)
    paths = set(head_paths(obj))
    for fcurve in (bag.fcurves if bag is not None else ()):
        if fcurve.data_path in paths:
            fcurve.mute = bool(controls)
    for track, control in TRACK_CONTROLS.items():
        obj[prop_name(control)] = float(controls.get(track, 0.0))
        if not controls:
            obj[prop_name(control, HEAD_LAYER)] = 0.0
    obj.update_tag()


def pose_head(obj, controls: dict) -> None:
    """Hold the head at one pose for a still (a contact-sheet cell): ``controls``' ``head.pitch/yaw/roll``
    as the delta transform, with the take's head F-curves muted meanwhile; empty ``controls``: the curves
    play again and the delta goes back to rest."""
    from ..adapters.fcurves import existing_channelbag
    if _on_bones(obj):
        _pose_head_bones(obj, controls)
        return
    if obj.rotation_mode not in EULER_ORDERS:
        return
    bag = existing_channelbag(obj)
    for fcurve in (bag.fcurves if bag is not None else ()):
        if fcurve.data_path in HEAD_PATHS:
            fcurve.mute = bool(controls)
    angles = [float(controls.get(name, 0.0)) for name in ("head.pitch", "head.roll", "head.yaw")]
    rx, ry, rz = -angles[0], angles[1], angles[2]
    obj.delta_rotation_euler = (rx, ry, rz)
    obj.delta_location = tuple(_delta_location(obj, [rx], [ry], [rz])[0])


def head_curves(obj, head, scene, start_frame: float) -> dict:
    """``(data_path, index) -> (frames, values)`` of the delta rotation and location that turn ``obj`` by
    the take's ``head`` tracks (``head.pitch`` + raises the chin, ``head.yaw`` + turns to the character's
    left, ``head.roll`` + tilts the top to its left); empty without head tracks, or for an object whose
    rotation is a quaternion or axis-angle (its delta is then a quaternion, which this does not write). A
    character gets the tracks as its behaviour layer's head controls (module docstring)."""
    tracks = {t.name: t for t in head}
    if tracks and _on_bones(obj):
        from ...faces_hands_addon.character.head import TRACK_CONTROLS
        from ..adapters.controls import data_path
        return {data_path(TRACK_CONTROLS[name], HEAD_LAYER): (seconds_to_frames(t.times, scene, start_frame), t.values)
                for name, t in tracks.items() if name in TRACK_CONTROLS}
    if not tracks or obj.rotation_mode not in EULER_ORDERS:
        return {}
    times = np.unique(np.concatenate([t.times for t in tracks.values()]))

    def angle(name):
        return tracks[name].sample(times) if name in tracks else np.zeros_like(times)
    # facing -Y: chin up is a negative turn about X; left (+X) is positive about Z; top to +X is positive about Y
    rx, ry, rz = -angle("head.pitch"), angle("head.roll"), angle("head.yaw")
    delta_location = _delta_location(obj, rx, ry, rz)
    frames = seconds_to_frames(times, scene, start_frame)
    curves = {}
    for index, values in enumerate((rx, ry, rz)):
        curves["delta_rotation_euler", index] = (frames, values)
    for index in range(3):
        curves["delta_location", index] = (frames, delta_location[:, index])
    return curves


def reset_head(obj) -> None:
    """The delta transform (a character: its behaviour layer's head controls) back to rest, after its
    F-curves are removed."""
    if _on_bones(obj):
        from ...faces_hands_addon.character.head import HEAD_CONTROLS
        from ..adapters.controls import prop_name
        for control in HEAD_CONTROLS:
            obj[prop_name(control, HEAD_LAYER)] = 0.0
        obj.update_tag()
        return
    obj.delta_rotation_euler = (0.0, 0.0, 0.0)
    obj.delta_location = (0.0, 0.0, 0.0)
