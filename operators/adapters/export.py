# SPDX-License-Identifier: GPL-3.0-or-later
"""glTF / FBX export of a baked rig through Blender's own exporters.

Only what the rig kind names goes out (a face: skin, eyes, teeth and tongue), with its shape keys (morph
targets, names kept in glTF ``extras.targetNames``) and their animation (glTF ``weights`` channel) as one
clip for all meshes; helpers (a face's skull, jaw and muscle display) stay behind. Internal shape keys never
leave: the export works on temporary copies without the live simulation key and without muted keys (muted
keys would add to the animation; glTF drops them, FBX would not), which carry the originals' names while
the originals step aside; the scene is exactly as it was afterwards. Settings follow what was measured to
keep shape keys and their animation (presets/SOURCES.md, "Speed and export facts"): no modifiers applied,
no morph normals, the clip starting at 0 s (the first exported frame, where the take's audio starts): glTF
slides it there, FBX copies get their keys moved there.

glTF animation is written from the F-curves' own keys (``export_force_sampling`` off) when nothing but keys
moves the exported objects: sampling calls ``frame_set`` once per frame for the whole scene (10-20 ms a frame
with a face's 116 shape keys: 12-20 s of a 30-s take's 24-s export, against 2 s from the keys, the weights
identical and the head's rotation within 0.001 degree). From keys the exporter neither slides the clip to
0 s nor names it as asked, so those copies' keys are moved to start at frame 0 (as for FBX) and the clip is
renamed in the file. Armatures, constraints and drivers are evaluated only by sampling, so a rig with any of
them is sampled as before. Bones that constraints move (the hand's Table 6.4 limits) are keyed per exported
frame with their constrained transform and their constraints removed on the copies, and a skinned original
lets go of its armature while the file is written (``export_pose``), so neither exporter warns. Skin weights
go out as the rigs give them: at most four influences per vertex, renormalised (``core.skinning``).
"""
from __future__ import annotations

import contextlib
from dataclasses import dataclass
from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix

from ...faces_hands_addon.anim.glb_clip import glb_bytes, glb_parts
from ...faces_hands_addon.core.errors import UserError
from ...faces_hands_addon.core.fbx_stamp import reproducible
from . import export_transforms as transforms
from .export_pose import bake_constraints, unskinned_originals
from .blendfile import save_blend
from .outputs import atomic_output, check_output_path
from .poses import SIM_KEY
from .rig_store import parts

__all__ = ["SUFFIXES", "ExportOptions", "export_objects", "export_rig", "exported_keys", "save_or_export"]

SUFFIXES = (".glb", ".fbx")
ASIDE = ".fh-export-original"


@dataclass(frozen=True)
class ExportOptions:
    """``clip``: the name of the one animation clip (default: the rig object's name); ``frame_range``:
    (first, last) frame to export (default: the scene's); ``scale``: uniform scale of the exported rig;
    ``selected_only``: only the rig's parts that are selected (the rig object itself always goes);
    ``animation``: False writes the still rig only (no clip; glTF only: ``adapters.take_export``)."""
    clip: str | None = None
    frame_range: tuple[int, int] | None = None
    scale: float = 1.0
    selected_only: bool = False
    animation: bool = True


def export_objects(obj, roles, selected_only: bool = False) -> list:
    """The rig object and its parts of ``roles`` (only the selected ones with ``selected_only``); a rig
    object skinned to its parent armature (a character) goes with that armature, first (the file's root)."""
    armature = obj.parent if obj.parent is not None and any(
        m.type == "ARMATURE" and m.object == obj.parent for m in obj.modifiers) else None
    return ([armature] if armature is not None else []) + [obj] + [
        part for role, part in parts(obj).items() if role in roles and (not selected_only or part.select_get())]


def exported_keys(obj) -> list[str]:
    """The shape keys of ``obj`` an export writes (not the reference key, the simulation key or muted keys)."""
    key = getattr(obj.data, "shape_keys", None)
    if key is None:
        return []
    return [b.name for b in key.key_blocks[1:] if b.name != SIM_KEY and not b.mute]


def _shift_keys(action, frames: float) -> None:
    """Move every key (and its handles) of ``action`` by ``frames``."""
    for layer in action.layers:
        for strip in layer.strips:
            for bag in strip.channelbags:
                for curve in bag.fcurves:
                    points = curve.keyframe_points
                    for attribute in ("co", "handle_left", "handle_right"):
                        values = np.empty(2 * len(points))
                        points.foreach_get(attribute, values)
                        values[0::2] += frames
                        points.foreach_set(attribute, values)
                    curve.update()


def _own_actions(copy, shift: float, key: bool = True) -> list:
    """Give the copy (object and, with ``key``, shape keys) private copies of its actions, shifted by
    ``shift`` frames."""
    made = []
    shape_keys = getattr(copy.data, "shape_keys", None) if key else None
    for owner in (copy, shape_keys):
        anim = getattr(owner, "animation_data", None) if owner is not None else None
        if anim is None or anim.action is None:
            continue
        slot = anim.action_slot.identifier if anim.action_slot else None
        action = anim.action.copy()
        anim.action = action
        if slot is not None and anim.action_slot is None:
            anim.action_slot = action.slots[slot]
        if shift:
            _shift_keys(action, shift)
        made.append(action)
    return made


def _reparent(copy, parent, original) -> None:
    """Parent ``copy`` to ``parent`` exactly as ``original`` is parented: assigning ``Object.parent`` resets
    the parent-inverse matrix, which would move a part parented while its parent was turned (a head
    imported with a 90-degree rotation) by that turn a second time."""
    copy.parent = parent
    copy.parent_type = original.parent_type
    if original.parent_type == "BONE":
        copy.parent_bone = original.parent_bone
    copy.matrix_parent_inverse = original.matrix_parent_inverse.copy()


@dataclass(frozen=True)
class _Placement:
    """Where the copies go: ``frames`` exported (the originals' numbering), ``shift`` from those to the
    copies' keys, ``scale`` about the root's origin (the export option), ``unit`` metres per scene unit
    (glTF is in metres and Blender's glTF exporter ignores the scene's unit scale; FBX applies it itself)."""
    frames: tuple
    shift: float = 0.0
    scale: float = 1.0
    unit: float = 1.0


def _chain(objects, copies: dict) -> list:
    """The rig object, then the armature that deforms it when that armature is one of its exported parts:
    in the file the armature is the root and the skin its child, as clients expect of a skinned mesh (the
    hand's skin is the rig object and its armature a child of it in the scene)."""
    root = objects[0]
    for modifier in root.modifiers:
        armature = getattr(modifier, "object", None)
        if modifier.type == "ARMATURE" and armature in copies and armature.parent is root:
            return [root, armature]
    return [root]


def _place(context, objects, copies: dict, placement: _Placement, made: list) -> None:
    """The top copy in world space without its parent (scaled as asked), every copy whose transform
    changes over the frames keyed per exported frame (``export_transforms``); actions made for keys are
    added to ``made``."""
    chain = _chain(objects, copies)
    links = [copies[o] for o in chain]
    top = links[-1]
    outer = Matrix.Diagonal((placement.unit,) * 3 + (1.0,))
    inner = Matrix.Diagonal((placement.scale,) * 3 + (1.0,))
    keyed_frames = [f + placement.shift for f in placement.frames]
    tracks = {}
    if any(transforms.moves(link) for link in links) or transforms.ancestors_move(objects[0]):
        tracks[top] = [outer @ world @ inner for world in
                       transforms.world_track(context, chain, links, placement.frames, placement.shift)]
    for copy in copies.values():
        if copy not in links and transforms.moves(copy):
            tracks[copy] = transforms.local_track(copy, keyed_frames)
    top_world = outer @ chain[-1].matrix_world @ inner
    if len(links) == 2:                                   # the skin under its armature, where it was
        skin, armature = links
        if transforms.moves(armature):
            tracks[skin] = [m.inverted() for m in transforms.local_track(armature, keyed_frames)]
        relative = (armature.matrix_parent_inverse @ armature.matrix_basis).inverted()
        armature.parent = None
        skin.parent = armature
        skin.matrix_parent_inverse = Matrix.Identity(4)
        skin.matrix_basis = relative
    top.parent = None
    top.matrix_world = top_world
    _scale_into_mesh(top, tracks)
    for copy, matrices in tracks.items():
        anim = copy.animation_data
        if anim is not None and anim.action is not None and anim.action not in made:
            made += _own_actions(copy, 0.0, key=False)        # the keys are rewritten on the copy only
        transforms.key_track(copy, keyed_frames, matrices, f"{copy.name} Export Transform")
        if copy.animation_data.action not in made:
            made.append(copy.animation_data.action)


def _scale_into_mesh(top, tracks: dict) -> None:
    """Move a non-uniform scale of the top copy (a mesh) into its mesh data and shape keys. glTF nodes are
    translation, rotation and scale: a part parented while its parent was turned and squashed sits at a
    sheared matrix relative to it, which the file cannot hold (7.6 mm off on a 0.1 m head). Only magnitudes
    move (a mirror stays on the node, where clients flip the winding)."""
    if top.type != "MESH":
        return
    scale = np.abs(np.array(top.matrix_world.decompose()[2]))
    if scale.max() <= scale.min() * (1.0 + 1e-6):
        return
    stretch = Matrix.Diagonal(tuple(scale) + (1.0,))
    mesh = top.data
    owners = [mesh.vertices] + ([b.data for b in mesh.shape_keys.key_blocks] if mesh.shape_keys else [])
    for owner in owners:
        co = np.empty(3 * len(owner))
        owner.foreach_get("co", co)
        owner.foreach_set("co", (co.reshape(-1, 3) * scale).ravel())
    mesh.update()
    world = top.matrix_world.copy()
    for child in top.children:
        child.matrix_parent_inverse = stretch @ child.matrix_parent_inverse
        if child in tracks:
            tracks[child] = [stretch @ m for m in tracks[child]]
    top.matrix_world = world @ stretch.inverted()
    if top in tracks:
        tracks[top] = [m @ stretch.inverted() for m in tracks[top]]


@contextlib.contextmanager
def _clean_copies(context, objects, placement: _Placement):
    """Copies of ``objects`` (same names, parenting, actions) without internal keys, in a temporary
    collection; the originals are renamed aside meanwhile and get their names back afterwards. The copies
    animate from private actions moved by ``placement.shift`` frames, placed by :func:`_place`."""
    collection = bpy.data.collections.new("FH Export")
    context.scene.collection.children.link(collection)
    originals = [(obj, obj.name, obj.data.name) for obj in objects]
    copies, actions = {}, []
    try:
        for obj, name, data_name in originals:
            copy = obj.copy()
            copy.data = obj.data.copy()
            obj.name, obj.data.name = name + ASIDE, data_name + ASIDE
            copy.name, copy.data.name = name, data_name
            collection.objects.link(copy)
            copies[obj] = copy
            if placement.shift:
                actions += _own_actions(copy, placement.shift)
        for obj, copy in copies.items():
            _reparent(copy, copies.get(obj.parent, obj.parent), obj)
            for modifier in copy.modifiers:               # a skin follows the copied armature
                if getattr(modifier, "object", None) in copies:
                    modifier.object = copies[modifier.object]
            key = getattr(copy.data, "shape_keys", None)
            if key is not None:
                for block in [b for b in key.key_blocks[1:] if b.name == SIM_KEY or b.mute]:
                    copy.shape_key_remove(block)
        _place(context, objects, copies, placement, actions)
        for copy in copies.values():                      # bones as keys, no constraints (export_pose)
            if copy.type == "ARMATURE" and copy.pose is not None and any(len(b.constraints) for b in copy.pose.bones):
                anim = copy.animation_data
                if anim is not None and anim.action is not None and anim.action not in actions:
                    actions += _own_actions(copy, 0.0, key=False)
                bake_constraints(context, copy, [f + placement.shift for f in placement.frames])
                if copy.animation_data.action not in actions:
                    actions.append(copy.animation_data.action)
        context.view_layer.update()
        yield list(copies.values())
    finally:
        for copy in copies.values():
            data = copy.data
            bpy.data.objects.remove(copy)
            if data is not None and data.users == 0:
                (bpy.data.armatures if isinstance(data, bpy.types.Armature) else bpy.data.meshes).remove(data)
        bpy.data.collections.remove(collection)
        for action in actions:
            bpy.data.actions.remove(action)
        for obj, name, data_name in originals:
            obj.name, obj.data.name = name, data_name


def _metres_per_unit(scene) -> float:
    """Metres per Blender unit of ``scene`` (what Blender's FBX exporter applies, and its glTF importer
    divides by)."""
    units = scene.unit_settings
    return 1.0 if units.system == "NONE" else float(units.scale_length)


def _select_only(context, objects) -> list:
    previous = [o for o in context.view_layer.objects if o.select_get()]
    for other in previous:
        other.select_set(False)
    for obj in objects:
        obj.hide_set(False)
        obj.select_set(True)
    context.view_layer.objects.active = objects[0]
    return previous


def _needs_sampling(objects) -> bool:
    """True when something other than F-curve keys moves ``objects`` (module docstring)."""
    for obj in objects:
        if obj.type == "ARMATURE" or obj.constraints or any(m.type == "ARMATURE" for m in obj.modifiers):
            return True
        for owner in (obj, obj.data, getattr(obj.data, "shape_keys", None)):
            anim = getattr(owner, "animation_data", None) if owner is not None else None
            if anim is not None and len(anim.drivers):
                return True
    return False


def _name_clip(path: Path, clip: str) -> None:
    """Rename the GLB's one animation to ``clip`` (its JSON chunk rewritten, the BIN chunk kept)."""
    doc, binary = glb_parts(path.read_bytes())
    animations = doc.get("animations", [])
    if len(animations) != 1 or animations[0].get("name") == clip:
        return
    animations[0]["name"] = clip
    path.write_bytes(glb_bytes(doc, binary))


def _write(path: Path, clip: str, sampled: bool = True, armature: bool = False, animation: bool = True) -> None:
    if path.suffix.lower() == ".glb":
        bpy.ops.export_scene.gltf(
            filepath=str(path), export_format="GLB", use_selection=True, export_apply=False, export_morph=True,
            export_morph_normal=False, export_animations=animation, export_anim_slide_to_zero=True, export_yup=True,
            export_animation_mode="ACTIVE_ACTIONS", export_nla_strips_merged_animation_name=clip,
            export_frame_range=True, export_optimize_animation_size=False, export_force_sampling=sampled,
            export_bake_animation=armature)     # a character's bones move by drivers: sampled without an action
        if animation and not sampled:
            _name_clip(path, clip)
    else:
        bpy.ops.export_scene.fbx(
            filepath=str(path), use_selection=True, object_types={"MESH", "ARMATURE"}, use_mesh_modifiers=False,
            bake_anim=animation, bake_anim_use_all_actions=False, bake_anim_use_nla_strips=False,
            bake_anim_simplify_factor=0.0, add_leaf_bones=False)
        path.write_bytes(reproducible(path.read_bytes()))   # same scene, same bytes


def export_rig(context, obj, filepath: str, roles, options: ExportOptions = ExportOptions()) -> Path:
    """Export the rig object ``obj`` and its parts of ``roles`` to ``filepath`` (.glb or .fbx)."""
    out = check_output_path(bpy.path.abspath(filepath), SUFFIXES)
    if not options.scale > 0:
        raise UserError(f"the export scale must be greater than 0, not {options.scale}")
    scene = context.scene
    kept_range = scene.frame_start, scene.frame_end
    context.view_layer.update()      # objects removed just before (a contact sheet's label) leave the layer
    previous = [o for o in context.view_layer.objects if o.select_get()]
    active = context.view_layer.objects.active
    try:
        first, last = (int(f) for f in (options.frame_range or kept_range))
        if last < first:
            raise UserError(f"the export frame range {first}..{last} is empty")
        objects = export_objects(obj, roles, options.selected_only)
        clip = options.clip or obj.name               # before the original steps aside under another name
        sampled = _needs_sampling(objects)
        # sampled glTF slides the clip to 0 s itself; FBX and glTF from keys write frame/fps (module docstring)
        shift = -first if out.suffix.lower() == ".fbx" or not sampled else 0
        scene.frame_start, scene.frame_end = first + shift, last + shift
        placement = _Placement(tuple(range(first, last + 1)), shift, options.scale,
                               _metres_per_unit(scene) if out.suffix.lower() == ".glb" else 1.0)
        with _clean_copies(context, objects, placement) as copies, atomic_output(out) as tmp, \
                unskinned_originals(objects):
            _select_only(context, copies)
            _write(tmp, clip, sampled, objects[0].type == "ARMATURE", options.animation)
    except RuntimeError as error:
        raise UserError(f"export to {out} failed: {error}") from None
    finally:
        scene.frame_start, scene.frame_end = kept_range
        context.view_layer.update()
        names = {o.name for o in previous}
        for other in context.view_layer.objects:
            if other is not None:
                other.select_set(other.name in names)
        if active is not None and active.name in context.view_layer.objects:
            context.view_layer.objects.active = active
    return out


def save_or_export(context, obj, out: Path, roles, options: ExportOptions | None = None) -> Path:
    """Write a command's result: the whole scene as ``.blend``, or ``obj`` and its parts of ``roles`` as
    .glb/.fbx (one clip named after the file unless ``options`` say otherwise)."""
    out = Path(out)
    if out.suffix.lower() == ".blend":
        save_blend(out)
        return out
    return export_rig(context, obj, str(out), roles, options or ExportOptions(clip=out.stem))
