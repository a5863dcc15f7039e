# SPDX-License-Identifier: GPL-3.0-or-later
"""The character's Rigify option: MPFB2's Rigify meta-rig (``rig.human_toes.json``) made into a Blender
meta-rig -- bone collections with their UI rows and colour sets, the Rigify colour sets, every bone's Rigify
type and parameters -- and generated into a Rigify control rig with Rigify's own generator (the ``rigify``
add-on that ships with Blender, enabled on demand). The body deforms with the generated rig's DEF- bones (the
weights' names, ``character.skeleton``); the meta-rig stays in the character's collection, hidden, so the
artist can change it and generate again.
"""
from __future__ import annotations

import bpy

from ...faces_hands_addon.core.errors import UserError

__all__ = ["generate_rigify", "META_ROLE"]

META_ROLE = "character_metarig"
COLLECTION_UI = {"ui_row": "rigify_ui_row", "ui_title": "rigify_ui_title", "color_set_id": "rigify_color_set_id",
                 "sel_set": "rigify_sel_set", "is_visible": "is_visible"}


def _enable_rigify() -> None:
    import addon_utils
    loaded, enabled = addon_utils.check("rigify")
    if not enabled:
        addon_utils.enable("rigify", default_set=True)
    if not hasattr(bpy.types.PoseBone, "rigify_type"):
        raise UserError("Blender's Rigify add-on could not be enabled; enable it in Preferences > Add-ons, or build "
                        "the character with the game-engine skeleton")


def _parameter(data, params, key: str, value) -> None:
    if key.endswith("_coll_refs"):            # references to bone collections, by name in the file
        refs = getattr(params, key)
        refs.clear()
        for name in value:
            refs.add().set_collection(data.collections[name])
        return
    try:
        setattr(params, key, value)
    except (AttributeError, TypeError, ValueError):
        pass                                  # a parameter this Rigify version no longer has


def _collections(data, skeleton) -> None:
    ui = skeleton.meta.get("rigify_ui", {})
    for name in skeleton.meta.get("collections", []):
        data.collections.new(name)
    for name, entry in ui.get("collections", {}).items():
        collection = data.collections.get(name)
        for key, attribute in COLLECTION_UI.items():
            if collection is not None and key in entry:
                setattr(collection, attribute, entry[key])
    for entry in ui.get("colors", []):
        item = data.rigify_colors.add()
        for key, value in entry.items():
            setattr(item, key, value)
    data.rigify_colors_lock = bool(ui.get("rigify_colors_lock", True))
    for key, value in ui.get("selection_colors", {}).items():
        setattr(data.rigify_selection_colors, key, value)


def _types(meta, skeleton) -> None:
    data = meta.data
    for name in skeleton.names:
        extra = skeleton.extra[name]
        for collection in extra.get("collections", []):
            data.collections[collection].assign(data.bones[name])
        pose_bone = meta.pose.bones[name]
        if "rotation_mode" in extra:
            pose_bone.rotation_mode = extra["rotation_mode"]
        rigify = extra.get("rigify") or {}
        if rigify.get("rigify_type"):
            pose_bone.rigify_type = rigify["rigify_type"]
            for key, value in rigify.get("rigify_parameters", {}).items():
                _parameter(data, pose_bone.rigify_parameters, key, value)


def generate_rigify(context, meta, skeleton, name: str):
    """Give the meta-rig ``meta`` (bones already made from ``skeleton``) its Rigify set-up and generate the
    control rig; returns the generated armature object, named ``<name> Rig``."""
    _enable_rigify()
    _collections(meta.data, skeleton)
    _types(meta, skeleton)
    before = set(bpy.data.objects)
    view_layer = context.view_layer
    view_layer.objects.active = meta
    meta.data.rigify_rig_basename = f"{name} Rig"
    try:
        bpy.ops.pose.rigify_generate()
    except RuntimeError as error:
        raise UserError(f"Rigify could not generate the control rig: {str(error).splitlines()[-1]}") from None
    made = [o for o in bpy.data.objects if o not in before and o.type == "ARMATURE"]
    if not made:
        raise UserError("Rigify generated no control rig; check the meta-rig in the character's collection")
    rig = made[0]
    for collection in list(rig.users_collection):
        collection.objects.unlink(rig)
    for collection in meta.users_collection:
        collection.objects.link(rig)
    meta.hide_set(True)
    meta.hide_render = True
    return rig
