# SPDX-License-Identifier: GPL-3.0-or-later
"""*Refit Face Rig*: after the morph head reshaped the character, the character's face rig is fitted again to
the morphed head and its baked targets are baked again (engine: ``character.refit``). The job reads plain
data first (the stored rig, the morph face's own evaluation of its stored coefficients, the names of the
body's keys), computes everything in its steps, and writes Blender data only in ``commit``: Esc or an error
before then leaves the scene as it was; the operator is one undo step.

What the commit writes on the body: the morph key (the refitted rest: the morphed head with its eyes under
the refitted lids), the targets that exist already (positions only: their values, drivers, mutes and
animation stay), the simulation key back at rest, the brow paint and the refitted rig. The artist's other
keys are not touched."""
from __future__ import annotations

import bpy
import numpy as np

from ...faces_hands_addon.core.errors import UserError
from ..adapters import controls
from ..adapters.poses import SIM_KEY, SKIN
from ..adapters.shape_keys import FRAME_PREFIX
from ..adapters.rig_store import get_rig, is_rig, rig_of, store_rig, to_local
from ..bases.jobs import Job
from ...names import MORPH_CHARACTER, MORPH_REFIT, MORPH_STATE
from . import services

__all__ = ["refit_objects", "RefitCharacterJob"]

FIT_SHARE = 0.6          # of the progress bar: the fit; the rest is the targets


def refit_objects(obj) -> tuple[object, object]:
    """(morph head, character body) for the selection ``obj``: the morph head that reshapes a character, or
    the character (body or armature) that one morph head reshapes."""
    head = services.morph_object(obj)
    if head is not None:
        body = bpy.data.objects.get(head.get(MORPH_CHARACTER, "") or "")
        if body is None:
            raise UserError(f"'{head.name}' reshapes no character; select the character's body and the head and "
                            "use Reshape Character first")
    else:
        body = rig_of(obj)
        if body is None:
            raise UserError("select the morph head (or the character it reshapes)")
        heads = [o for o in bpy.data.objects if services.morph_object(o) is not None
                 and o.get(MORPH_CHARACTER) == body.name]
        if len(heads) != 1:
            raise UserError(f"{'no' if not heads else len(heads)} morph heads reshape '{body.name}'; select the "
                            "one to refit to")
        head = heads[0]
    if not is_rig(body, "character"):
        raise UserError(f"'{body.name}' holds no character rig (build the character with Add > Character)")
    return head, body


def _key_names(body) -> list[str]:
    keys = body.data.shape_keys
    return [] if keys is None else list(keys.key_blocks.keys())


class RefitCharacterJob(Job):
    """Refit the character's face rig to the morph head's face and bake its existing targets again."""

    label = "Refitting the face rig"

    def __init__(self, context, obj, targets: bool = True):
        from ...faces_hands_addon.character.refit import refit_stages, target_expressions
        head, body = refit_objects(obj)
        rig = get_rig(body, "character")
        face = services.face_of(head)
        self.body_name, self.head_name, self.state = body.name, head.name, head.get(MORPH_STATE, "")
        names = _key_names(body)
        self.expressions = target_expressions(names, rig.control_specs()) if targets else {}
        frames = sum(name.startswith(FRAME_PREFIX) for name in names)
        self.notes = ((f"the per-frame cache ({frames} keys) was baked on the old head; bake the animation again",)
                      if frames else ())
        self._stages = refit_stages(rig, face.model, np.array(face.shape, np.float64))
        self.rig, self.bake = None, None

    def step(self) -> float:
        if self.rig is None:
            item = next(self._stages)
            if isinstance(item, tuple):
                fraction, self.label = item
                return FIT_SHARE * fraction
            self.rig = item
            self.warnings = tuple(item.warnings) + self.notes
            if not self.expressions:
                return 1.0
            from ...faces_hands_addon.anim.bakes import ShapesBake
            self.bake = ShapesBake(self.rig, self.expressions)
            self.label = f"Baking {len(self.expressions)} targets on the refitted head"
            return FIT_SHARE
        done = self.bake.step()
        return 1.0 if done >= 1.0 else FIT_SHARE + (1.0 - FIT_SHARE) * done

    def cleanup(self) -> None:
        if self.bake is not None:
            self.bake.close()
        self._stages.close()

    def commit(self, context) -> str:
        body = bpy.data.objects.get(self.body_name)
        if body is None or body.type != "MESH":
            raise UserError(f"the character '{self.body_name}' is gone; nothing was refitted")
        shapes = self.bake.shapes if self.bake is not None else []
        commit_refit(body, self.rig, shapes)
        body[MORPH_REFIT] = self.state
        return (f"Refitted the face rig of '{body.name}' to '{self.head_name}': {len(self.rig.head_ids):,} head "
                f"vertices, {len(shapes)} targets baked again")


def commit_refit(body, rig, shapes) -> None:
    """Write the refitted ``rig`` and its baked ``shapes`` (``anim.baking.BakedShape``) onto ``body`` (module
    docstring)."""
    from ..character.materials import BROW_ATTRIBUTE
    mesh = body.data
    if len(mesh.vertices) != len(rig.rest_positions):
        raise UserError(f"'{body.name}' no longer has the character's {len(rig.rest_positions)} vertices")
    if mesh.shape_keys is None:
        body.shape_key_add(name="Basis", from_mix=False)
    blocks = mesh.shape_keys.key_blocks
    morph = blocks.get(services.HEAD_KEY) or body.shape_key_add(name=services.HEAD_KEY, from_mix=False)
    morph.points.foreach_set("co", to_local(body, rig.morphed_rest).ravel())
    morph.value = 1.0
    for shape in shapes:
        block = blocks.get(shape.name)
        if block is not None:
            block.points.foreach_set("co", to_local(body, shape.pose.positions[SKIN]).ravel())
    sim = blocks.get(SIM_KEY)
    if sim is not None:
        sim.points.foreach_set("co", to_local(body, rig.rest_positions).ravel())
    brows = rig.character.mesh.brows
    if brows is not None and BROW_ATTRIBUTE in mesh.attributes:
        mesh.attributes[BROW_ATTRIBUTE].data.foreach_set("value", np.ascontiguousarray(brows, np.float32))
    controls.ensure_controls(body, rig.control_specs())
    store_rig(body, rig)
    mesh.update()
