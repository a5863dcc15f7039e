# SPDX-License-Identifier: GPL-3.0-or-later
"""*Fit Face Rig to Character*: the face rig on the artist's own skinned character (``character.user``).
Everything the engine needs is read off the selection first and checked (a body of several meshes, no
armature, no known neck and head bones, no head vertex group, a neck or head bone already animated): a
refusal changes nothing. The fit keeps the mesh, its shape keys, modifiers and the armature as they are; the
rig's keys are added after the artist's, the head's turn drives the neck and head bones."""
from __future__ import annotations

import bpy
import numpy as np

from ...faces_hands_addon.core.errors import UserError
from ..adapters import controls
from ..bases.jobs import Job
from ..adapters.rig_store import OUTPUT_TO_LOCAL, store_rig
from ..face.fit import world_geometry
from .objects import armature_of, head_drivers

__all__ = ["FitCharacterJob", "character_input"]


def _skinned(armature) -> list:
    return [o for o in bpy.data.objects if o.type == "MESH" and armature_of(o) == armature]


def _group_weights(mesh_obj, name: str) -> np.ndarray:
    group = mesh_obj.vertex_groups.get(name)
    out = np.zeros(len(mesh_obj.data.vertices))
    if group is None:
        return out
    index = group.index
    for vertex in mesh_obj.data.vertices:
        for element in vertex.groups:
            if element.group == index:
                out[vertex.index] = element.weight
    return out


def character_input(obj):
    """(CharacterInput, body object, armature object) for the selection ``obj`` (body mesh or armature)."""
    from ...faces_hands_addon.character.head import HEAD_CHAINS
    from ...faces_hands_addon.character.user import CharacterInput
    if obj is None or obj.type not in ("MESH", "ARMATURE"):
        raise UserError("select the character's body mesh (or its armature)")
    armature = obj if obj.type == "ARMATURE" else armature_of(obj)
    meshes = _skinned(armature) if armature is not None else []
    body = obj if obj.type == "MESH" else (meshes[0] if len(meshes) == 1 else None)
    if body is None and meshes:
        body = meshes[0]
    bones = [b.name for b in armature.data.bones] if armature is not None else []
    heads = {chain[-1][0] for chain in HEAD_CHAINS.values()}
    weights = {name: _group_weights(body, name) for name in heads if body is not None and name in body.vertex_groups}
    data = CharacterInput([m.name for m in meshes], body.name if body is not None else None,
                          armature.name if armature is not None else None, bones,
                          list(body.vertex_groups.keys()) if body is not None else [], weights,
                          len(body.data.vertices) if body is not None else 0)
    return data, body, armature


def _refuse_animated(armature, chain) -> None:
    """The neck and head bones get drivers: refuse when the artist animated them already."""
    anim = armature.animation_data
    paths = [f'pose.bones["{bone}"].rotation' for bone, _ in chain]
    taken = []
    if anim is not None:
        taken = [d.data_path for d in anim.drivers if d.data_path.startswith(tuple(paths))]
        if anim.action is not None:
            for layer in anim.action.layers:
                for strip in layer.strips:
                    for bag in strip.channelbags:
                        taken += [c.data_path for c in bag.fcurves if c.data_path.startswith(tuple(paths))]
    if taken:
        raise UserError(f"'{armature.name}' already animates {taken[0].split('.')[1]}; the head's turn would "
                        "replace it: remove those keys or drivers (or duplicate the armature) and fit again")


def _revalidate(armature_name: str):
    """A one-shot timer: Blender marks the new head drivers of an armature that existed before the operator
    as failed when the operator finishes (they evaluate fine when compiled again, and after reloading the
    file); compile each again once the operator has returned."""
    def again():
        armature = bpy.data.objects.get(armature_name)
        anim = getattr(armature, "animation_data", None)
        for curve in (anim.drivers if anim is not None else ()):
            if not curve.driver.is_valid:
                curve.driver.expression = curve.driver.expression
        return None
    return again


class FitCharacterJob(Job):
    """Check the selection, fit the face rig to the head part of the body, commit the rig onto the body."""

    label = "Fitting the face rig to the character"

    def __init__(self, context, obj):
        from ...faces_hands_addon.character.user import check_character
        self.data, body, armature = character_input(obj)
        chain, _ = check_character(self.data)                      # refuses before any work
        _refuse_animated(armature, chain)
        self.body_name, self.armature_name = body.name, armature.name
        self.world, self.faces = world_geometry(body)
        self.matrix = np.array(body.matrix_world, dtype=np.float64)
        turn = np.array(armature.matrix_world, dtype=np.float64)[:3, :3]
        turn = turn / np.linalg.norm(turn, axis=0)                  # rotation of the armature, scale removed
        self.frames = {bone: turn @ np.array(armature.data.bones[bone].matrix_local)[:3, :3] for bone, _ in chain}
        self.rig = None

    def step(self) -> float:
        from ...faces_hands_addon.character.user import fit_character
        self.rig = fit_character(self.data, self.world, self.faces, self.frames)
        self.warnings = tuple(self.rig.warnings)
        return 1.0

    def commit(self, context) -> str:
        body, armature = bpy.data.objects[self.body_name], bpy.data.objects[self.armature_name]
        body[OUTPUT_TO_LOCAL] = [float(v) for v in np.linalg.inv(self.matrix).ravel()]
        controls.ensure_controls(body, self.rig.control_specs())
        store_rig(body, self.rig)
        head_drivers(body, armature, self.rig)
        bpy.app.timers.register(_revalidate(armature.name), first_interval=0.0)
        return (f"Fitted the face rig to '{body.name}': {len(self.rig.head_ids):,} head vertices, head turning on "
                f"{', '.join(self.rig.terms)}")
