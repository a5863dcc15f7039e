# SPDX-License-Identifier: GPL-3.0-or-later
"""Takes beyond the rig: put a face rig's weight animation onto other characters that have ARKit or viseme
shape keys (an artist's avatar), and write it as a Live Link Face CSV for Unreal."""
from __future__ import annotations

import bpy

from ...faces_hands_addon.core.errors import UserError
from ..adapters import targets
from ..bases.file_operators import SaveFileOperator
from ..bases.hardened import HardenedOperator
from ..adapters.rig_store import rig_of


def _source_rig(context):
    obj = rig_of(context.active_object)
    if obj is None:
        raise UserError("make the face rig with the baked take the active object")
    return obj


class FH_OT_transfer_animation(HardenedOperator, bpy.types.Operator):
    """Play the active face rig's baked weight animation on the other selected characters: every shape key
    named like an ARKit blendshape or a viseme (any common spelling) gets the rig's weight curve"""

    bl_idname = "faces_hands.transfer_animation"
    bl_label = "Transfer Animation to Character"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return context.active_object is not None and len(context.selected_objects) > 1

    def run(self, context):
        source = _source_rig(context)
        frames, weights = targets.animated_weights(source, context.scene)
        others = [o for o in context.selected_objects if o is not source and rig_of(o) is not source]
        characters = targets.characters_with_targets(others, weights)
        if not characters:
            raise UserError("select characters with ARKit or viseme shape keys (besides the face rig)")
        counts = [len(targets.transfer_weights(character, frames, weights)) for character in characters]
        names = ", ".join(f"'{c.name}' ({n} keys)" for c, n in zip(characters, counts))
        self.report({"INFO"}, f"Transferred {len(frames)} frames to {names}")
        return {"FINISHED"}


class FH_OT_export_live_link(HardenedOperator, SaveFileOperator, bpy.types.Operator):
    """Write the active face rig's ARKit weight animation as a Live Link Face CSV (timecode + the 52 ARKit
    columns + head and eye rotations), which Unreal's Live Link Face importer reads"""

    bl_idname = "faces_hands.export_live_link"
    bl_label = "Export Live Link Face CSV"
    bl_options = {"REGISTER"}

    file_suffix = ".csv"
    filter_glob: bpy.props.StringProperty(default="*.csv", options={"HIDDEN"},
                                          description="File types the file browser shows")

    def run(self, context):
        path = targets.write_live_link(_source_rig(context), context.scene, bpy.path.abspath(self.filepath))
        self.report({"INFO"}, f"Wrote {path}")
        return {"FINISHED"}


CLASSES = [FH_OT_transfer_animation, FH_OT_export_live_link]
