# SPDX-License-Identifier: GPL-3.0-or-later
"""Building the reference skeleton (thesis 6.2.1) from the vendored assets: myo-sim's 27 hand bones plus
radius and ulna in MyoHand's rest pose, joint centres at MyoHand's body origins, flexion axes seeded by
MyoHand's hinge axes, the DOFs and limits of ``presets/hand/joints.json`` (Table 6.4).

MyoHand tilts the flexion axes of the middle, ring and little fingers 11, 26 and 34 degrees out of the palm
plane (the transverse arch), so curled fingers converge towards the thumb; MyoHand's fingers collide and
stop each other, ours have no finger-finger contact, and with the whole tilt the curled fingers of a fist
ran into each other (neighbouring phalanx axes 2.7 mm apart; a finger is about 16-20 mm wide). The thesis
sets its joint frames by hand on the template hand (6.2.1), so the phalanges keep only the share
``finger_flexion_tilt`` of joints.json of that tilt (the axis turns about the bone towards the palm plane;
the shipped preset keeps none: with half of it the curled middle finger's tip still ended under the ring
finger's, out of reach of the finger contact of :mod:`.contact`).

The signs of the DOF axes are fixed by geometry (:mod:`.skeleton` docstring): positive flexion brings a
finger's tip towards the palm side (+X of the asset frame, the palm of the right hand faces +X) and the
thumb's towards the middle of the palm; positive abduction moves a finger away from the middle finger
(radially for the middle finger and the wrist, away from the index for the thumb); positive rotation turns
the palm-side direction towards the thumb (-Y).
"""
from __future__ import annotations

import numpy as np

from .. import assets
from ..core.errors import UserError
from .presets import JointsPreset
from .skeleton import FINGERS, TIP_NAMES, Dof, Skeleton, rotation_matrices

__all__ = ["PALM_NORMAL", "RADIAL", "build_skeleton", "finger_of", "untilted"]

PALM_NORMAL = np.array([1.0, 0.0, 0.0])   # the right hand's palm faces +X in the asset frame
RADIAL = np.array([0.0, -1.0, 0.0])       # the thumb side


def finger_of(bone: str) -> str | None:
    head = bone.split("-")[0]
    return head if head in FINGERS else None


def _unit(v: np.ndarray) -> np.ndarray:
    return v / max(float(np.linalg.norm(v)), 1e-12)


def _tip(position: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """The far end of a distal bone mesh along the direction joint -> mesh centroid."""
    u = _unit(vertices.mean(axis=0) - position)
    return position + u * float(np.max((vertices - position) @ u))


def _moved(point, about, axis, angle=1e-3):
    r = rotation_matrices(axis[None], np.array([angle]))[0]
    return about + r @ (point - about)


def _signed_axis(axis, position, tail, score) -> np.ndarray:
    """``axis`` or ``-axis``: the one whose small positive rotation of ``tail`` about ``position`` raises
    ``score(point)``."""
    return axis if score(_moved(tail, position, axis)) > score(_moved(tail, position, -axis)) else -axis


def untilted(x: np.ndarray, z: np.ndarray, kept: float) -> np.ndarray:
    """The flexion axis ``x`` (unit, normal to the bone direction ``z``) turned about ``z`` towards the palm
    plane (normal to :data:`PALM_NORMAL`) so that only the share ``kept`` of its tilt out of it is left."""
    level = _unit(np.cross(z, PALM_NORMAL))
    level = level if level @ x >= 0 else -level
    tilt = np.arctan2(np.cross(level, x) @ z, level @ x)
    return rotation_matrices(z[None], np.array([(kept - 1.0) * tilt]))[0] @ x


def _frames(names, position, tail, flexion_seed, palm_target, index_mcp, tilt_kept=1.0):
    """Right-handed joint frames x (flexion), y = z x x, z (to the child), with x signed by geometry, and the
    sign (+1/-1) that makes a positive abduction angle move the child as the module docstring says."""
    frames = np.empty((len(names), 3, 3))
    abduction_sign = np.ones(len(names))
    for b, name in enumerate(names):
        z = _unit(tail[b] - position[b])
        seed = flexion_seed[b]
        x = _unit(seed - (seed @ z) * z)
        finger = finger_of(name)
        if finger not in (None, "thumb") and "phalanx" in name and tilt_kept != 1.0:
            x = untilted(x, z, tilt_kept)
        if finger == "thumb":
            x = _signed_axis(x, position[b], tail[b], lambda p: -np.linalg.norm(p - palm_target))
        else:
            x = _signed_axis(x, position[b], tail[b], lambda p: p @ PALM_NORMAL)
        y = np.cross(z, x)
        if finger == "thumb":
            wanted = _signed_axis(y, position[b], tail[b], lambda p: np.linalg.norm(p - index_mcp))
        elif finger in ("ring", "pinky"):
            wanted = _signed_axis(y, position[b], tail[b], lambda p: -(p @ RADIAL))
        else:
            wanted = _signed_axis(y, position[b], tail[b], lambda p: p @ RADIAL)
        abduction_sign[b] = 1.0 if wanted @ y > 0 else -1.0
        frames[b] = np.column_stack([x, y, z])
    return frames, abduction_sign


def _rotation_sign(frame: np.ndarray) -> float:
    """+1 if a positive rotation about z turns the palm-side direction towards the thumb, else -1."""
    z = frame[:, 2]
    turned = rotation_matrices(z[None], np.array([1e-3]))[0] @ PALM_NORMAL
    return 1.0 if (turned - PALM_NORMAL) @ RADIAL >= 0 else -1.0


def build_skeleton(preset: JointsPreset) -> Skeleton:
    """The reference skeleton: bones, joints, oriented frames, DOFs with Table 6.4 limits, bone meshes."""
    model = assets.myohand_model()
    meshes = assets.hand_bones()
    axes = {j.name: j.axis for j in model.joints}
    names = ["forearm"] + [j["bone"] for j in preset.joints]
    joints = {j["bone"]: j for j in preset.joints}
    position = np.zeros((len(names), 3))
    for b, name in enumerate(names[1:], 1):
        body = model.bodies.get(joints[name]["body"])
        if body is None:
            raise UserError(f"hand/joints.json: joint {name!r} names body {joints[name]['body']!r}, "
                            "which MyoHand does not have")
        position[b] = body.position
    index = {name: b for b, name in enumerate(names)}
    mesh_vertices = {}
    for name in names:
        try:
            mesh_vertices[name] = [meshes[stem] for stem in preset.bone_meshes[name]]
        except KeyError as error:
            raise UserError(f"hand/joints.json: bone_meshes names {error.args[0]!r}, not a myo-sim bone") from None
    tips = {}
    for tip in TIP_NAMES:
        finger = tip.split("-")[0]
        bone = "thumb-phalanx-distal" if finger == "thumb" else f"{finger}-finger-phalanx-distal"
        tips[tip] = _tip(position[index[bone]], mesh_vertices[bone][0].vertices)
    tail = np.zeros_like(position)
    for b, name in enumerate(names[1:], 1):
        child = joints[name]["child"]
        tail[b] = tips[child] if child in tips else position[index[child]]
    radius = np.concatenate([m.vertices for m in mesh_vertices["forearm"]])
    position[0] = np.array([radius[:, 0].mean(), radius[:, 1].mean(), radius[:, 2].max()])
    tail[0] = np.zeros(3)                           # the forearm ends at the wrist centre
    seeds = np.zeros_like(position)
    seeds[0] = (0.0, -1.0, 0.0)
    for b, name in enumerate(names[1:], 1):
        axis = axes.get(joints[name]["flexion_axis"])
        if axis is None:
            raise UserError(f"hand/joints.json: joint {name!r} names MyoHand joint "
                            f"{joints[name]['flexion_axis']!r}, which does not exist")
        seeds[b] = axis
    middle_mcp = position[index["middle-finger-phalanx-proximal"]]
    palm_target = 0.5 * (middle_mcp + position[index["middle-finger-metacarpal"]]) + 0.03 * PALM_NORMAL
    frames, abduction_sign = _frames(names, position, tail, seeds, palm_target,
                                     position[index["index-finger-phalanx-proximal"]], preset.finger_flexion_tilt)
    dofs = []
    for b, name in enumerate(names[1:], 1):
        joint = joints[name]
        for kind in ("flexion", "abduction", "rotation"):
            if kind not in joint["dofs"]:
                continue
            low, high = np.radians(joint["dofs"][kind])
            sign = {"flexion": 1.0, "abduction": abduction_sign[b], "rotation": _rotation_sign(frames[b])}[kind]
            dofs.append(Dof(b, kind, float(low), float(high), joint.get("coupled", {}).get(kind), sign))
    vertices = {n: np.concatenate([m.vertices for m in ms]) for n, ms in mesh_vertices.items()}
    faces = {}
    for n, ms in mesh_vertices.items():
        offset, parts = 0, []
        for m in ms:
            parts.append(m.faces + offset)
            offset += len(m.vertices)
        faces[n] = np.concatenate(parts)
    return Skeleton(names, np.array([-1] + [index[joints[n]["parent"]] for n in names[1:]]), position, tail,
                    frames, dofs, vertices, faces, {n: list(preset.bone_meshes[n]) for n in names}, tips,
                    {n: [len(m.vertices) for m in ms] for n, ms in mesh_vertices.items()})
