# SPDX-License-Identifier: GPL-3.0-or-later
"""glTF / FBX export of a baked face rig through Blender's own exporters.

Only the visible head goes out: skin, eyes, teeth and tongue with their shape keys (morph targets,
names kept in glTF ``extras.targetNames``) and the shape-key animation (glTF ``weights`` channel).
Skull, jaw and muscle helpers stay behind. Settings follow what was measured to keep shape keys and
their animation (see ../shared/notes/verified-recipes.md): no modifiers applied, no morph normals.
"""
from __future__ import annotations

from pathlib import Path

import bpy

from ..faces_hands_addon.errors import UserError
from .bl_face import parts
from .outputs import atomic_output, check_output_path

EXPORT_ROLES = ("eye_L", "eye_R", "teeth_upper", "teeth_lower", "tongue")
SUFFIXES = (".glb", ".fbx")


def export_objects(obj) -> list:
    found = [obj]
    for role, part in parts(obj).items():
        if role in EXPORT_ROLES:
            found.append(part)
    return found


def _select_only(context, objects) -> list:
    previous = [o for o in context.view_layer.objects if o.select_get()]
    for other in previous:
        other.select_set(False)
    for obj in objects:
        obj.hide_set(False)
        obj.select_set(True)
    context.view_layer.objects.active = objects[0]
    return previous


def export_rig(context, obj, filepath: str) -> Path:
    """Export ``obj`` (a rig's skin object) and its visible parts to ``filepath`` (.glb or .fbx)."""
    out = check_output_path(bpy.path.abspath(filepath), SUFFIXES)
    objects = export_objects(obj)
    previous = _select_only(context, objects)
    try:
        with atomic_output(out) as tmp:
            if out.suffix.lower() == ".glb":
                bpy.ops.export_scene.gltf(
                    filepath=str(tmp), export_format="GLB",
                    use_selection=True, export_apply=False, export_morph=True, export_morph_normal=False,
                    export_animations=True, export_anim_slide_to_zero=True, export_yup=True)
            else:
                bpy.ops.export_scene.fbx(
                    filepath=str(tmp), use_selection=True, object_types={"MESH"}, use_mesh_modifiers=False,
                    bake_anim=True, bake_anim_use_all_actions=False, bake_anim_use_nla_strips=False,
                    add_leaf_bones=False)
    except RuntimeError as error:
        raise UserError(f"export to {out} failed: {error}") from None
    finally:
        for o in objects:
            o.select_set(False)
        for other in previous:
            if other.name in context.view_layer.objects:
                other.select_set(True)
    return out
