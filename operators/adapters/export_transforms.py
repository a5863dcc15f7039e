# SPDX-License-Identifier: GPL-3.0-or-later
"""Object transforms of an export's temporary copies as plain per-frame keys, so a file shows every part
where the scene has it (``export``).

Blender's exporters read an animated object's own F-curves, and get three things wrong that a face rig meets:
the glTF exporter, writing from keys, composes an animated *delta* rotation (a take's head motion) with a
static object rotation (a head imported Y-up carries 90 degrees about X) wrongly (42 mm off on a 0.1 m
head); keys relative to a parent that is not exported (a rig under an Empty or a character's bone) are
written as if they were world keys; and Euler keys between frames interpolate differently from the
quaternions glTF plays. So every copy whose transform moves gets, on its private action, one LINEAR key per
exported frame of location, rotation quaternion and scale: the root's world matrix at that frame (its
parent stays behind), a part's matrix relative to its exported parent (parent inverse included, then reset).
A matrix with shear (a non-uniform scale above a rotation) has no exact location/rotation/scale; it is
written as the nearest one, as Blender itself does when it sets such a matrix.
"""
from __future__ import annotations

import numpy as np
from mathutils import Matrix

from . import fcurves

__all__ = ["TRANSFORM_PATHS", "transform_curves", "moves", "moved_by_others", "ancestors_move", "world_track", "local_track",
           "key_track"]

TRANSFORM_PATHS = ("location", "rotation_euler", "rotation_quaternion", "rotation_axis_angle", "scale",
                   "delta_location", "delta_rotation_euler", "delta_rotation_quaternion", "delta_scale")
_REST = {"delta_location": (0.0, 0.0, 0.0), "delta_rotation_euler": (0.0, 0.0, 0.0),
         "delta_rotation_quaternion": (1.0, 0.0, 0.0, 0.0), "delta_scale": (1.0, 1.0, 1.0)}


def transform_curves(obj) -> list:
    """The unmuted F-curves of ``obj``'s own action that animate its transform."""
    bag = fcurves.existing_channelbag(obj)
    return [c for c in (bag.fcurves if bag is not None else ()) if c.data_path in TRANSFORM_PATHS and not c.mute]


def moves(obj) -> bool:
    """Does an F-curve animate ``obj``'s transform?"""
    return bool(transform_curves(obj))


def moved_by_others(obj) -> bool:
    """Do drivers or constraints move ``obj``?"""
    anim = obj.animation_data
    return bool(obj.constraints) or (anim is not None and any(d.data_path in TRANSFORM_PATHS for d in anim.drivers))


def ancestors_move(obj) -> bool:
    """Can ``obj``'s parents move it over time (transform keys, drivers, constraints, a bone or vertex
    parent)?"""
    while obj.parent is not None:
        if obj.parent_type != "OBJECT":
            return True
        obj = obj.parent
        if moves(obj) or moved_by_others(obj):
            return True
    return False


def local_track(copy, frames) -> list:
    """The parent-relative matrix (parent inverse included) of ``copy`` at each of ``frames``, from its
    transform F-curves evaluated there (the copy's properties are set along the way)."""
    curves = transform_curves(copy)
    out = []
    for frame in frames:
        for curve in curves:
            getattr(copy, curve.data_path)[curve.array_index] = curve.evaluate(float(frame))
        out.append(copy.matrix_parent_inverse @ copy.matrix_basis)
    return out


def world_track(context, chain, copies, frames, shift: float) -> list:
    """World matrices at each of ``frames`` of the last object of ``chain`` (originals, each the parent of
    the next; ``copies`` theirs): evaluated by Blender frame by frame when the first one's parents move it,
    else its static parent's world matrix times each link's curves evaluated on the copies at
    ``frame + shift``."""
    if ancestors_move(chain[0]):
        scene = context.scene
        current = scene.frame_current
        out = []
        try:
            for frame in frames:
                scene.frame_set(int(frame))
                out.append(chain[-1].matrix_world.copy())
        finally:
            scene.frame_set(current)
        return out
    parent = chain[0].parent
    out = [parent.matrix_world.copy() if parent is not None else Matrix.Identity(4) for _ in frames]
    for copy in copies:
        out = [world @ local for world, local in zip(out, local_track(copy, [f + shift for f in frames]))]
    return out


def key_track(copy, frames, matrices, action_name: str) -> None:
    """Replace ``copy``'s transform curves by one LINEAR key per frame of location, quaternion and scale
    taken from ``matrices`` (parent-relative, parent inverse included: the copy's parent inverse becomes
    identity); its deltas go to rest."""
    bag = fcurves.existing_channelbag(copy)
    for curve in transform_curves(copy) if bag is not None else ():
        bag.fcurves.remove(curve)
    for name, rest in _REST.items():
        setattr(copy, name, rest)
    copy.rotation_mode = "QUATERNION"
    copy.matrix_parent_inverse = Matrix.Identity(4)
    parts = [m.decompose() for m in matrices]
    quaternions = np.array([q[:] for _, q, _ in parts])
    for i in range(1, len(quaternions)):                 # one hemisphere: no flip between neighbouring keys
        if np.dot(quaternions[i], quaternions[i - 1]) < 0:
            quaternions[i] = -quaternions[i]
    frames = np.asarray(frames, dtype=np.float64)
    curves = {}
    for path, values in (("location", np.array([t[:] for t, _, _ in parts])), ("rotation_quaternion", quaternions),
                         ("scale", np.array([s[:] for _, _, s in parts]))):
        for index in range(values.shape[1]):
            curves[path, index] = (frames, values[:, index])
    fcurves.write_curves(copy, curves, action_name, group="Transform")
    copy.matrix_basis = matrices[0]
