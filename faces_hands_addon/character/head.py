# SPDX-License-Identifier: GPL-3.0-or-later
"""The head turning on the neck (thesis 4.2.1, 4.3.5: raised at pitch maxima, tilted, turned away at the
start of a turn): the behaviour layer's head channels become three controls of the character,
``head_pitch`` (+ raises the chin), ``head_yaw`` (+ turns to the character's left) and ``head_roll`` (+ tilts
the top of the head to its left), in radians, mixed like every control (:func:`..anim.layers.mix`), and
spread over the armature's neck and head bones (:data:`HEAD_CHAINS`: each bone turns by its share).

Each bone's pose is an Euler rotation (order XYZ, Blender's default) whose three angles are weighted sums of
the mixed controls (:func:`bone_terms`): the share of the world-axis rotation vector expressed in the bone's
rest frame. The same sums are written as Blender drivers (:func:`..anim.layers.weighted_driver`), so the
live preview, the drivers and the export cannot disagree; for the head's small angles (at most 0.35 rad per
channel) the Euler angles match the exact rotation to second order.
"""
from __future__ import annotations

import numpy as np

from ..anim.layers import mix, weighted_sum
from ..behavior.events import HEAD_LIMIT_RAD
from ..core.controls import ControlSpec
from .skeleton import CharacterSkeleton

__all__ = ["HEAD_CONTROLS", "HEAD_CHAINS", "TRACK_CONTROLS", "head_specs", "chain_terms", "bone_terms", "bone_eulers",
           "euler_matrix", "chain_of", "head_turns", "HEAD_TRACK_LAYER"]

HEAD_CONTROLS = ("head_pitch", "head_yaw", "head_roll")
#: the behaviour's head tracks (``speech.takes``) -> the character's controls
TRACK_CONTROLS = {"head.pitch": "head_pitch", "head.yaw": "head_yaw", "head.roll": "head_roll"}
#: the control layer a take's head tracks drive on a character
HEAD_TRACK_LAYER = "behavior"
#: the bones that turn the head, from the neck up, with their share of the turn (a chain's shares add up to
#: the whole turn of the head); a Rigify character turns its generated control rig's neck and head controls,
#: whose head does not inherit the neck's turn (Rigify's head follows the torso): it gets the whole turn
HEAD_CHAINS = {
    "game_engine": (("neck_01", 0.4), ("head", 0.6)),
    "default": (("neck01", 0.15), ("neck02", 0.15), ("neck03", 0.15), ("head", 0.55)),
    "rigify": (("neck", 0.4), ("head", 1.0)),
    "rigify_meta": (("spine.004", 0.2), ("spine.005", 0.2), ("spine.006", 0.6)),
    "mixamo": (("mixamorig:Neck", 0.4), ("mixamorig:Head", 0.6)),
    "vrm": (("neck", 0.4), ("head", 0.6)),
}
#: world rotation vector (x, y, z) per unit of (pitch, yaw, roll): facing -Y, chin up is a negative turn
#: about X, a turn to the left (+X) positive about Z, the top tilting to +X positive about Y
CONTROL_AXES = np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
WIDE = 10.0                        # rad: the driver's clamp, never reached (each control is clamped first)


def head_specs() -> dict[str, ControlSpec]:
    """The head's three controls (radians, thesis 4.2.1)."""
    text = {"head_pitch": "head rotation about the horizontal axis on the neck: + raises the chin (4.2.1)",
            "head_yaw": "head turn on the neck about the vertical axis: + turns to the character's left",
            "head_roll": "sideways head tilt on the neck: + tilts the top of the head to the character's left"}
    return {name: ControlSpec(name, -HEAD_LIMIT_RAD, HEAD_LIMIT_RAD, 0.0, "head", "direct", text[name], "rad")
            for name in HEAD_CONTROLS}


def chain_of(skeleton: CharacterSkeleton, generated_rigify: bool = True) -> tuple[tuple[str, float], ...]:
    """The head chain of ``skeleton`` (the meta-rig's own bones when no Rigify rig was generated)."""
    key = skeleton.name if skeleton.name != "rigify" or generated_rigify else "rigify_meta"
    return HEAD_CHAINS[key]


def chain_terms(chain, frames) -> dict[str, list[list[tuple[str, float]]]]:
    """bone -> for each Euler angle (X, Y, Z) the (control, weight) terms of its weighted sum (module
    docstring) for the bones of ``chain`` whose rest frames (3x3, the space the head controls turn in) are
    ``frames[bone]``."""
    out = {}
    for bone, share in chain:
        coefficients = share * np.asarray(frames[bone]).T @ CONTROL_AXES.T      # (3 local axes) x (pitch, yaw, roll)
        out[bone] = [[(control, float(coefficients[axis, k])) for k, control in enumerate(HEAD_CONTROLS)
                      if abs(coefficients[axis, k]) > 1e-9] for axis in range(3)]
    return out


def bone_terms(skeleton: CharacterSkeleton, chain=None, rest: dict | None = None) -> dict:
    """:func:`chain_terms` of the skeleton's head chain (or ``chain``) with the skeleton's rest frames (or
    ``rest``: bone -> 3x3, e.g. a generated Rigify rig's controls)."""
    chain = chain or chain_of(skeleton, generated_rigify=False)
    frames = rest if rest is not None else {bone: skeleton.rest[skeleton.index(bone), :3, :3] for bone, _ in chain}
    return chain_terms(chain, frames)


def bone_eulers(values: dict[str, float], terms: dict) -> dict[str, np.ndarray]:
    """Each chain bone's Euler angles (XYZ, radians) for mixed control ``values``."""
    return {bone: np.array([weighted_sum(axis, values, -WIDE, WIDE) for axis in axes]) for bone, axes in terms.items()}


def head_turns(table, specs, terms: dict, head=(), fps: float = 30.0, start_frame: float = 0.0) -> dict[str, np.ndarray]:
    """bone -> (F, 3) Euler angles at each frame of the layer table ``table`` (``anim.layers.LayerTable``)
    with a take's ``head`` tracks (``head.pitch/yaw/roll``, seconds from ``start_frame`` at ``fps``) added
    to the :data:`HEAD_TRACK_LAYER` layer, where a take puts them on a character; the layers mixed as every
    control is (:func:`..anim.layers.mix`, the drivers' sum): the head's turn as a take's export writes it,
    from the take itself."""
    times = (np.asarray(table.frames, np.float64) - float(start_frame)) / float(fps)
    added = {TRACK_CONTROLS[t.name]: t.sample(times) for t in head if t.name in TRACK_CONTROLS}
    rows = []
    for index in range(len(table)):
        layers = table.at(index)
        layer = layers.setdefault(HEAD_TRACK_LAYER, {})
        for control, values in added.items():
            layer[control] = layer.get(control, 0.0) + float(values[index])
        values = mix(layers, specs)
        rows.append(bone_eulers({name: values[name] for name in HEAD_CONTROLS}, terms))
    return {bone: np.stack([row[bone] for row in rows]) for bone in terms}


def euler_matrix(angles: np.ndarray) -> np.ndarray:
    """4x4 of Blender's XYZ Euler rotation (X first, then Y, then Z: ``Rz @ Ry @ Rx``)."""
    x, y, z = (float(a) for a in angles)
    cx, sx, cy, sy, cz, sz = np.cos(x), np.sin(x), np.cos(y), np.sin(y), np.cos(z), np.sin(z)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    out = np.eye(4)
    out[:3, :3] = rz @ ry @ rx
    return out
