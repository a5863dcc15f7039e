# SPDX-License-Identifier: GPL-3.0-or-later
"""The hand's services for commands, the demo and other subsystems (plain functions, no operator classes):
build a hand rig object, put poses and motions on its controls, solve contractions for a posed armature,
bake, export, retarget onto any armature with the same (WebXR) joint names."""
from __future__ import annotations

import bpy
import numpy as np
from mathutils import Matrix

from ...faces_hands_addon.anim.layers import BASE_LAYER
from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.hand import motion
from ..adapters import controls, fcurves
from ..adapters.blendfile import open_blend, save_blend
from ..adapters.export import ExportOptions, export_rig
from ..bases.jobs import run_job
from ..adapters.outputs import atomic_output
from ..adapters.rig_store import find_rig, get_rig, store_rig
from ..adapters.timing import scene_fps
from . import sheet
from .jobs import BakeHandJob, BuildHandJob, write_indexed_curves
from .objects import EXPORT_ROLES, armature_of, pose_bone_rotations

__all__ = ["KIND", "build_hand_object", "hand_object", "apply_pose", "animate", "bake", "export", "solve",
           "retarget", "read_photo", "detect_photo", "run_demo", "add_hand_object", "key_joint_angles"]

KIND = "hand"


def read_photo(points_path: str) -> dict:
    """A checked photo input from a feature-point JSON file (6.2.3)."""
    from ...faces_hands_addon.hand.photo import read_photo_points
    return read_photo_points(points_path)


def detect_photo(photo_path: str, side: str, hand_length_mm: float) -> dict:
    """A checked photo input found automatically on the photo (6.2.3's 26 points from MediaPipe's hand
    landmarks, ``tracking.photo_points``); the photo is read by Blender (PNG, JPEG, ...) and nothing is kept."""
    from ...faces_hands_addon.core.foreign_files import check_path
    from ...faces_hands_addon.hand.photo import check_photo
    from ...faces_hands_addon.tracking.photo_points import detect_photo_points
    from ...faces_hands_addon.hand.template import reference_template
    path = check_path(photo_path, "the photo of the hand")
    known = set(bpy.data.images)
    try:
        image = bpy.data.images.load(str(path))
    except RuntimeError:
        raise UserError(f"{path}: Blender cannot read this image") from None
    try:
        width, height = image.size
        if not width or not height:
            raise UserError(f"{path}: Blender cannot read this image")
        pixels = np.empty(width * height * image.channels, np.float32)
        image.pixels.foreach_get(pixels)
        rgb = pixels.reshape(height, width, image.channels)[::-1, :, :3].copy()
    finally:
        for made in [i for i in bpy.data.images if i not in known]:
            bpy.data.images.remove(made)
    doc = detect_photo_points(rgb, reference_template().features, side, hand_length_mm, str(path))
    return {**check_photo(doc, str(path)), "image": str(path.resolve())}


def build_hand_object(progress=None, name: str = "FH Hand", side: str = "right", photo: dict | None = None,
                      mesh: str | None = None):
    """A new empty file holding a hand rig (the reference hand on the skin ``mesh`` of
    ``hand.template.MESHES``, or the hand of ``photo``); its rig object."""
    bpy.ops.wm.read_homefile(use_empty=True)
    print(run_job(BuildHandJob(name, side, photo, mesh), bpy.context, progress))
    return find_rig(bpy.data.objects, name, KIND)


def hand_object(blend: str | None, rig_name: str | None = None, progress=None):
    """The hand rig object of ``blend`` (by ``rig_name`` when there are several), or a new reference hand."""
    if blend:
        open_blend(blend)
        return find_rig(bpy.data.objects, rig_name, KIND)
    return build_hand_object(progress)


def apply_pose(obj, name: str, squeeze: bool = False) -> tuple[dict[str, float], bool]:
    """Set the artist's layer to the preset pose ``name`` (every other muscle relaxed). A staged pose
    (:func:`.motion.pose_stages`) gives its first stage, or with ``squeeze`` its second: a static layer is
    simulated from wherever the hand is, and a squeeze from rest swings the thumb across the palm before it
    rests on the fingers, so the artist applies the squeeze once the live preview has closed the hand (Animate
    Hand with the pose keys both stages in turn, hand/motion.py). Returns the contractions set and whether the
    pose has a squeeze."""
    rig = get_rig(obj, KIND)
    stages = motion.pose_stages(name, rig.muscle_names)
    values = stages[-1 if squeeze else 0]
    for muscle in rig.muscle_names:
        obj[controls.prop_name(muscle, BASE_LAYER)] = float(values.get(muscle, 0.0))
    obj.update_tag()
    return values, len(stages) > 1


def animate(context, obj, name: str, start_frame: int | None = None) -> tuple[int, int]:
    """Key the motion (or pose) preset ``name`` on the artist's layer: one Bezier key per muscle and key time
    (Hermite interpolation, 6.2.1); the scene's frame range is set to the motion. Returns (first, last) frame."""
    rig = get_rig(obj, KIND)
    times, poses = motion.motion_keys(name, rig.muscle_names)
    scene = context.scene
    fps = scene_fps(scene)
    start = scene.frame_start if start_frame is None else int(start_frame)
    frames = start + np.round(times * fps)
    curves = {controls.data_path(m, BASE_LAYER): (frames, np.array([p.get(m, 0.0) for p in poses]))
              for m in rig.muscle_names}
    fcurves.write_curves(obj, curves, "FH Hand Controls", interpolation="BEZIER")
    scene.frame_start, scene.frame_end = start, int(frames[-1])
    return start, int(frames[-1])


def bake(context, obj, progress=None) -> str:
    """Bake the hand rig object ``obj`` (bone keys + corrective shape keys) over the scene's frame range."""
    return run_job(BakeHandJob(context, obj), context, progress)


def export(context, obj, path: str, options: ExportOptions = ExportOptions()):
    """Export the skin and its armature (with the baked Action and shape-key weights) to .glb or .fbx."""
    return export_rig(context, obj, path, EXPORT_ROLES, options)


def solve(context, obj) -> str:
    """Solve Contractions: the minimal-effort contractions that hold the pose the artist gave the armature's
    bones; they go onto the artist's layer, the bones back to rest, and a simulation from rest checks them."""
    from ...faces_hands_addon.hand.solve import angles_from_rotations, solve_contractions
    rig = get_rig(obj, KIND)
    arm = armature_of(obj)
    if arm is None:
        raise UserError(f"'{obj.name}' has lost its armature; rebuild the hand rig")
    target = angles_from_rotations(rig.skeleton, pose_bone_rotations(arm, rig))
    if not np.any(np.abs(target) > np.radians(1.0)):
        raise UserError("pose the hand first: rotate some bones of its armature in Pose Mode, then solve")
    solution = solve_contractions(rig.pseudo, target)
    for muscle, value in solution.contractions.items():
        obj[controls.prop_name(muscle, BASE_LAYER)] = value
    rig.settled({BASE_LAYER: solution.contractions}, 3.0)
    error = np.degrees(np.abs(rig.joint_angles - np.clip(target, rig.pseudo.lower, rig.pseudo.upper)))
    reached = float(np.mean(error[rig.pseudo.dynamic]))
    for pose_bone in arm.pose.bones:
        pose_bone.rotation_euler = (0.0, 0.0, 0.0)
        pose_bone.rotation_quaternion = (1.0, 0.0, 0.0, 0.0)
    rig.reset()
    store_rig(obj, rig)
    active = sum(1 for v in solution.contractions.values() if v > 0.01)
    return (f"Solved {active} muscle contractions; simulated from rest the joints come within {reached:.1f} deg "
            f"of the pose on average (worst {float(error[rig.pseudo.dynamic].max()):.1f} deg)")


def _world_bone_matrices(arm) -> dict[str, np.ndarray]:
    world = np.array(arm.matrix_world)
    return {b.name: world @ np.array(b.matrix) for b in arm.pose.bones}


def retarget(context, source_obj, target_arm, frames=None) -> int:
    """Copy the hand's bone animation onto ``target_arm``: an armature with WebXR joint names (the generic
    hand), each matched bone turning in world space as the source bone does; or one named like a skeleton of
    the bone map (MPFB2 game-engine/default, Mixamo, VRM, Rigify), whose hand bones of the rig's side take
    the hand bones' turns seen in its hand (:func:`_retarget_mapped`). Returns the number of bones keyed."""
    source_arm = armature_of(source_obj)
    if source_arm is None or target_arm is None or target_arm.type != "ARMATURE":
        raise UserError("select the hand rig and an armature to retarget onto")
    scene = context.scene
    frames = list(range(scene.frame_start, scene.frame_end + 1)) if frames is None else list(frames)
    names = [b.name for b in target_arm.data.bones if b.name in source_arm.data.bones]
    if not names:
        return _retarget_mapped(context, get_rig(source_obj, KIND).side, source_arm, target_arm, frames)
    tw = np.array(target_arm.matrix_world)
    rest_s = {n: np.array(source_arm.matrix_world) @ np.array(source_arm.data.bones[n].matrix_local) for n in names}
    rest_t = {b.name: tw @ np.array(b.matrix_local) for b in target_arm.data.bones}
    keys = {n: [] for n in names}
    current = scene.frame_current
    try:
        for frame in frames:
            scene.frame_set(frame)
            posed_s = _world_bone_matrices(source_arm)
            posed_t = {}
            for bone in target_arm.data.bones:          # parents come before children
                rest = rest_t[bone.name]
                if bone.name in names:
                    delta = posed_s[bone.name][:3, :3] @ np.linalg.inv(rest_s[bone.name][:3, :3])
                    rotation = delta @ rest[:3, :3]
                else:
                    rotation = rest[:3, :3]
                if bone.parent is None:
                    head = rest[:3, 3]
                else:
                    parent_rest, parent_posed = rest_t[bone.parent.name], posed_t[bone.parent.name]
                    head = parent_posed[:3, :3] @ np.linalg.inv(parent_rest[:3, :3]) @ (rest[:3, 3] - parent_rest[:3, 3]) \
                        + parent_posed[:3, 3]
                matrix = np.eye(4)
                matrix[:3, :3], matrix[:3, 3] = rotation, head
                posed_t[bone.name] = matrix
                if bone.name in names:
                    local_rest = rest if bone.parent is None else np.linalg.inv(rest_t[bone.parent.name]) @ rest
                    local_pose = matrix if bone.parent is None else np.linalg.inv(posed_t[bone.parent.name]) @ matrix
                    keys[bone.name].append(np.linalg.inv(local_rest) @ local_pose)
    finally:
        scene.frame_set(current)
    _key_quaternions(target_arm, keys, frames)
    return len(names)


def _retarget_mapped(context, side: str, source_arm, target_arm, frames) -> int:
    """Key the hand bones of ``target_arm`` (named like a skeleton of the bone map) from the hand armature
    ``source_arm`` at ``frames``: the hand's frame turned onto the target's hand, each bone's turn given to
    its mapped bone (``character.hands.fit_hand_heads``, ``retarget_basis``)."""
    from ...faces_hands_addon.character.hands import fit_hand_heads, hand_skeleton_of
    from ...faces_hands_addon.character.skeleton import CharacterSkeleton
    letter = "R" if side == "right" else "L"
    bones = list(target_arm.data.bones)
    names = [b.name for b in bones]
    column = hand_skeleton_of(names, letter)
    rest = np.array([np.array(b.matrix_local) for b in bones])
    skeleton = CharacterSkeleton(
        column, names, np.array([names.index(b.parent.name) if b.parent else -1 for b in bones], np.int64),
        rest[:, :3, 3].copy(), np.array([b.tail_local[:] for b in bones]), np.zeros(len(bones)),
        np.array([b.use_connect for b in bones]), rest)
    fit = fit_hand_heads(skeleton, {b.name: np.array(b.head_local) for b in source_arm.data.bones}, letter)
    source_rest = {n: np.linalg.inv(np.array(source_arm.data.bones[n].matrix_local)) for n in fit.pairs}
    keys = {bone: [] for bone in fit.pairs.values()}
    scene = context.scene
    current = scene.frame_current
    try:
        for frame in frames:
            scene.frame_set(frame)
            transforms = {n: np.array(source_arm.pose.bones[n].matrix) @ source_rest[n] for n in fit.pairs}
            for bone, matrix in fit.basis(transforms).items():
                keys[bone].append(matrix)
    finally:
        scene.frame_set(current)
    _key_quaternions(target_arm, keys, frames)
    return len(keys)


def _key_quaternions(arm, keys: dict, frames) -> None:
    curves = {}
    for name, matrices in keys.items():
        arm.pose.bones[name].rotation_mode = "QUATERNION"
        quats = np.array([Matrix(m.tolist()).to_quaternion()[:] for m in matrices])
        for i in range(1, len(quats)):                    # keep the quaternions on one hemisphere
            if np.dot(quats[i], quats[i - 1]) < 0:
                quats[i] = -quats[i]
        for axis in range(4):
            curves[(f'pose.bones["{name}"].rotation_quaternion', axis)] = (np.array(frames, float), quats[:, axis])
    write_indexed_curves(arm, curves, "FH Retargeted Hand")


def run_demo(out_dir, progress, motion_name: str = "showcase") -> list:
    """The hand part of ``faces_hands demo``: the reference hand in every preset pose (palm and thumb-side
    contact sheets, each cell framed on its pose, a matcap that shows surface shape), its geometric muscles
    bulging with the joints straight and in the grip poses, with and without the bulge (Fig. 6.18), the
    showcase motion baked to a GLB, the rig as .blend. Returns the written paths."""
    def part(start, end):
        return lambda fraction, message="": progress(start + (end - start) * fraction, message)

    obj = build_hand_object(part(0.0, 0.05))
    rig = get_rig(obj, KIND)
    outputs = []
    for name, cells, view, columns, framing in (
            ("hand_contact_sheet.png", sheet.pose_cells(rig), "palm", 4, "pose"),
            ("hand_contact_sheet_side.png", sheet.pose_cells(rig), "side", 4, "pose"),
            ("hand_bulges.png", sheet.bulge_cells(rig), "palm", 6, "rest")):
        path = out_dir / name
        with atomic_output(path) as tmp:
            sheet.render_hand_sheet(bpy.context, obj, cells, tmp, view, columns, (360, 450), part(0.05, 0.45),
                                    framing=framing, matcap=sheet.SHAPE_MATCAP)
        outputs.append(path)
    path = out_dir / "hand_grip_bulges.png"
    with atomic_output(path) as tmp:
        sheet.render_grip_sheet(bpy.context, obj, tmp, progress=part(0.45, 0.6))
    outputs.append(path)
    bpy.context.scene.render.fps = 30
    animate(bpy.context, obj, motion_name)
    print(bake(bpy.context, obj, part(0.6, 0.95)))
    outputs.append(export(bpy.context, obj, str(out_dir / f"hand_{motion_name}.glb")))
    blend = out_dir / "hand_rig.blend"
    save_blend(blend)
    outputs.append(blend)
    return outputs


def add_hand_object(context, rig, name: str = "FH Hand"):
    """A hand rig object for ``rig`` in the current file (the rig object: its skin; :func:`.objects.create_hand_objects`)
    without clearing the scene; for other subsystems (the pitch replay)."""
    from .objects import create_hand_objects
    return create_hand_objects(context, rig, name)


def key_joint_angles(obj, rig, frames, angles, action_name: str = "FH Hand Motion") -> None:
    """Key the armature of hand rig object ``obj`` at ``frames`` with the joint ``angles`` ((K, DOFs) radians,
    the rig's DOF order): bone rotations as the engine's forward kinematics gives them."""
    from ...faces_hands_addon.hand import bake as hand_bake
    from .objects import EULER_ORDER, rest_bone_matrices
    arm = armature_of(obj)
    names = rig.skeleton.names
    rest = rest_bone_matrices(arm, names)
    eulers = np.zeros((len(frames), len(names), 3))
    for f, a in enumerate(angles):
        basis = hand_bake.bone_basis(rest, rig.skeleton.parent, rig.transforms(np.asarray(a, np.float64)))
        for b in range(len(names)):
            eulers[f, b] = Matrix(basis[b].tolist()).to_euler(EULER_ORDER)[:]
    curves = {}
    frames = np.asarray(frames, np.float64)
    for b, name in enumerate(names):
        arm.pose.bones[name].rotation_mode = EULER_ORDER
        for axis in range(3):
            curves[(f'pose.bones["{name}"].rotation_euler', axis)] = (frames, eulers[:, b, axis])
    write_indexed_curves(arm, curves, action_name)
