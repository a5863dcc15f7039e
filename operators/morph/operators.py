# SPDX-License-Identifier: GPL-3.0-or-later
"""Morphable Face operators (5.1): new face, attribute sliders, caricature, segments, constraints, feature
import, detail, affine transforms, save/load, build a model from meshes, Make Animatable."""
from __future__ import annotations

import bpy

from ...faces_hands_addon.core.errors import UserError
from ..bases.hardened import HardenedOperator
from ..bases.jobs import Job
from ..bases.modal import JobOperator
from . import services
from .jobs import BuildModelJob, MakeAnimatableJob
from ...names import MORPH_EXAMPLES

PARTS = [("both", "Shape + Colour", "Shape and colour"), ("shape", "Shape", "Shape only"),
         ("colour", "Colour", "Colour only")]


def _face_object(context):
    obj = services.morph_object(context.active_object)
    if obj is None:
        raise UserError("select a morph face (create one with 'New Face' in Morphable Face)")
    return obj


class FH_OT_morph_new_face(HardenedOperator, bpy.types.Operator):
    """Create a face from the morphable model: the average, a random face (seed) or a database example"""

    bl_idname = "faces_hands.morph_new_face"
    bl_label = "New Face"
    bl_options = {"REGISTER", "UNDO"}

    kind: bpy.props.EnumProperty(name="Face", items=[
        ("average", "Average", "The average face of the model"),
        ("random", "Random", "A random face (seeded: the same seed gives the same face)"),
        ("example", "Example", "A face of the model's database")], description="Which face to start from")
    seed: bpy.props.IntProperty(name="Seed", default=0, min=0, description="Seed of the random face")
    index: bpy.props.IntProperty(name="Example", default=0, min=0, description="Database example")

    def run(self, context):
        settings = context.scene.faces_hands_morph
        obj = services.create_face_object(context, settings.model_path or services.DEFAULT, self.kind,
                                          self.seed, self.index)
        self.report({"INFO"}, f"Created '{obj.name}' ({services.face_of(obj).model.name})")
        return {"FINISHED"}


class FH_OT_morph_set_attribute(HardenedOperator, bpy.types.Operator):
    """Set an attribute of the face (restricted to the selected segments; constraints are kept)"""

    bl_idname = "faces_hands.morph_set_attribute"
    bl_label = "Set Attribute"
    bl_options = {"REGISTER", "UNDO", "INTERNAL"}

    name: bpy.props.StringProperty(name="Attribute", description="Attribute name (Table 5.2)")
    part: bpy.props.EnumProperty(name="Part", items=PARTS[1:], description="Shape or colour value")
    value: bpy.props.FloatProperty(name="Value", description="New value in standard deviations of the ratings")

    def run(self, context):
        obj = _face_object(context)
        segments = services.selected_segments(obj)
        face = services.face_of(obj)
        if abs(face.slider(self.name, self.part, segments) - self.value) < 1e-12:
            return {"FINISHED"}
        services.apply(obj, lambda f: f.set_attribute(self.name, self.value, self.part, segments))
        return {"FINISHED"}


class FH_OT_morph_caricature(HardenedOperator, bpy.types.Operator):
    """Caricature: move the face away from (or towards) the average (3.2.2)"""

    bl_idname = "faces_hands.morph_caricature"
    bl_label = "Caricature"
    bl_options = {"REGISTER", "UNDO", "INTERNAL"}

    level: bpy.props.FloatProperty(name="Level", default=1.0, min=0.05, max=5.0,
                                   description="1 = the face itself, 2 = twice as far from the average")

    def run(self, context):
        obj = _face_object(context)
        segments = services.selected_segments(obj)
        services.apply(obj, lambda f: f.caricature(self.level, "both", segments))
        return {"FINISHED"}


class FH_OT_morph_show_segments(HardenedOperator, bpy.types.Operator):
    """Show the segments as colours on the face (the selection bright) or the skin colour again"""

    bl_idname = "faces_hands.morph_show_segments"
    bl_label = "Show Segments"
    bl_options = {"REGISTER", "UNDO", "INTERNAL"}

    show: bpy.props.BoolProperty(name="Show", default=True, description="Show the segment colours")

    def run(self, context):
        obj = _face_object(context)
        services.show_mask(obj, self.show)
        services.sync_panel(obj, services.face_of(obj))     # slider values belong to the selection
        return {"FINISHED"}


class FH_OT_morph_constrain(HardenedOperator, bpy.types.Operator):
    """Keep the attribute's current value through later edits (3.2.3); restricted to the selected segments"""

    bl_idname = "faces_hands.morph_constrain"
    bl_label = "Constrain Attribute"
    bl_options = {"REGISTER", "UNDO"}

    name: bpy.props.StringProperty(name="Attribute", description="Attribute to keep")
    part: bpy.props.EnumProperty(name="Part", items=PARTS, description="Keep its shape and/or colour value")
    database: bpy.props.BoolProperty(name="Apply to Database", default=False,
                                     description="Also adapt every database example to it (5.1.7)")

    def run(self, context):
        obj = _face_object(context)
        segments = services.selected_segments(obj)
        services.apply(obj, lambda f: f.constrain(self.name, self.part, segments, self.database))
        self.report({"INFO"}, f"Constrained {self.name}")
        return {"FINISHED"}


class FH_OT_morph_release(HardenedOperator, bpy.types.Operator):
    """Remove a constraint"""

    bl_idname = "faces_hands.morph_release"
    bl_label = "Remove Constraint"
    bl_options = {"REGISTER", "UNDO"}

    name: bpy.props.StringProperty(name="Attribute", description="Constrained attribute to release")

    def run(self, context):
        services.apply(_face_object(context), lambda f: f.unconstrain(self.name))
        return {"FINISHED"}


class FH_OT_morph_import_feature(HardenedOperator, bpy.types.Operator):
    """Import the selected segments of a database example into the face (5.1.5), blended at the borders"""

    bl_idname = "faces_hands.morph_import_feature"
    bl_label = "Import Feature"
    bl_options = {"REGISTER", "UNDO"}

    index: bpy.props.IntProperty(name="Example", default=0, min=0, description="Database example")
    part: bpy.props.EnumProperty(name="Part", items=PARTS, description="Import shape and/or colour")

    def run(self, context):
        obj = _face_object(context)
        segments = services.selected_segments(obj)
        if not segments:
            raise UserError("select the segments to import first (Segments list)")
        services.apply(obj, lambda f: f.import_feature(self.index, segments, self.part))
        return {"FINISHED"}


class FH_OT_morph_transform(HardenedOperator, bpy.types.Operator):
    """Move, rotate or scale the face or the selected segments (5.1.3)"""

    bl_idname = "faces_hands.morph_transform"
    bl_label = "Transform Segment"
    bl_options = {"REGISTER", "UNDO"}

    offset: bpy.props.FloatVectorProperty(name="Offset", size=3, subtype="TRANSLATION", unit="LENGTH",
                                          description="Translation in metres")
    rotation: bpy.props.FloatVectorProperty(name="Rotation", size=3, subtype="EULER",
                                            description="Rotation about the selection's centre")
    scale: bpy.props.FloatVectorProperty(name="Scale", size=3, default=(1.0, 1.0, 1.0), min=0.2, max=5.0,
                                         description="Non-uniform scale about the selection's centre")

    def run(self, context):
        from mathutils import Euler, Matrix
        obj = _face_object(context)
        matrix = (Matrix.Translation(self.offset) @ Euler(self.rotation).to_matrix().to_4x4()
                  @ Matrix.Diagonal((*self.scale, 1.0)))
        segments = services.selected_segments(obj)
        services.apply(obj, lambda f: f.transform([list(row) for row in matrix], segments))
        return {"FINISHED"}


class FH_OT_morph_add_detail(HardenedOperator, bpy.types.Operator):
    """Add the model's high-frequency detail vector to the face's colour (5.1.9)"""

    bl_idname = "faces_hands.morph_add_detail"
    bl_label = "Add Detail"
    bl_options = {"REGISTER", "UNDO"}

    factor: bpy.props.FloatProperty(name="Factor", default=0.7, min=0.0, max=2.0,
                                    description="How much detail (the thesis found 0.7 good)")

    def run(self, context):
        obj = _face_object(context)
        details = list(services.face_of(obj).model.details)
        if not details:
            raise UserError("this model has no detail vector")
        services.apply(obj, lambda f: f.add_detail(details[0], self.factor))
        return {"FINISHED"}


class FH_OT_morph_undo_edit(HardenedOperator, bpy.types.Operator):
    """Take the last edit of the history back"""

    bl_idname = "faces_hands.morph_undo_edit"
    bl_label = "Undo Edit"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context):
        obj = _face_object(context)
        face = services.apply(obj, lambda f: f.undo())
        services.sync_panel(obj, face)
        return {"FINISHED"}


class FH_OT_morph_link_character(HardenedOperator, bpy.types.Operator):
    """Let this morph head reshape the selected character's head: every edit (Average, Random, Example,
    sliders, caricature) is written into the character's 'FH Morph Head' shape key"""

    bl_idname = "faces_hands.morph_link_character"
    bl_label = "Reshape Character"
    bl_options = {"REGISTER", "UNDO"}

    def run(self, context):
        obj = _face_object(context)
        bodies = [o for o in context.selected_objects if o is not obj and o.type == "MESH"]
        if len(bodies) != 1:
            raise UserError("select the character's body and then the morph head (the head active)")
        services.link_character(obj, bodies[0])
        self.report({"INFO"}, f"'{obj.name}' now reshapes the head of '{bodies[0].name}'")
        return {"FINISHED"}


class FH_OT_morph_refit_character(JobOperator, bpy.types.Operator):
    """Fit the character's face rig again to the head this morph head gave it, and bake its existing face
    targets (ARKit, visemes, emotions, muscle basis) again on the new head; your own shape keys and animation
    are kept. Esc cancels with nothing changed"""

    bl_idname = "faces_hands.morph_refit_character"
    bl_label = "Refit Face Rig"
    bl_options = {"REGISTER", "UNDO"}

    targets: bpy.props.BoolProperty(name="Bake Targets", default=True,
                                    description="Bake the character's existing face targets again on the "
                                                "refitted rig (off: refit only; the targets keep their old shapes)")

    def make_job(self, context) -> Job:
        from .refit import RefitCharacterJob
        return RefitCharacterJob(context, context.active_object, self.targets)


class FH_OT_morph_save_face(HardenedOperator, bpy.types.Operator):
    """Save the face (model, edit history, constraints, coefficients) as JSON"""

    bl_idname = "faces_hands.morph_save_face"
    bl_label = "Save Face"
    bl_options = {"REGISTER"}

    filepath: bpy.props.StringProperty(name="File", subtype="FILE_PATH", description="Where to save (.json)")

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def run(self, context):
        out = services.save_face(_face_object(context), self.filepath)
        self.report({"INFO"}, f"Saved {out}")
        return {"FINISHED"}


class FH_OT_morph_load_face(HardenedOperator, bpy.types.Operator):
    """Load a saved face (JSON) onto the selected morph face"""

    bl_idname = "faces_hands.morph_load_face"
    bl_label = "Load Face"
    bl_options = {"REGISTER", "UNDO"}

    filepath: bpy.props.StringProperty(name="File", subtype="FILE_PATH", description="A saved face (.json)")

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def run(self, context):
        services.load_face(_face_object(context), self.filepath)
        return {"FINISHED"}


class FH_OT_morph_render_thumbnails(HardenedOperator, bpy.types.Operator):
    """Render thumbnails of the database examples that pass the filters (sex, age group, population)"""

    bl_idname = "faces_hands.morph_render_thumbnails"
    bl_label = "Render Thumbnails"
    bl_options = {"REGISTER", "UNDO"}

    count: bpy.props.IntProperty(name="Count", default=12, min=1, max=60, description="How many examples")

    def run(self, context):
        import json
        from ...faces_hands_addon.morph.model import matching_examples
        from .sheet import render_thumbnails
        obj = _face_object(context)
        settings = context.scene.faces_hands_morph
        shown = matching_examples(json.loads(obj.get(MORPH_EXAMPLES, "[]")), settings.filter_sex,
                                  settings.filter_age, settings.filter_population)[:self.count]
        if not shown:
            raise UserError("no database example passes the filters")
        images = render_thumbnails(context, obj, [index for index, _ in shown])
        self.report({"INFO"}, f"Rendered {len(images)} thumbnails")
        return {"FINISHED"}


class FH_OT_morph_build_model(JobOperator, bpy.types.Operator):
    """Build a morphable model by PCA of the selected same-topology meshes (or a folder of OBJ/PLY), with
    optional per-example ratings from a CSV (5.1.10); saves it and uses it for new faces"""

    bl_idname = "faces_hands.morph_build_model"
    bl_label = "Build Model from Meshes"
    bl_options = {"REGISTER", "UNDO"}

    folder: bpy.props.StringProperty(name="Folder", subtype="DIR_PATH", default="",
                                     description="Folder of OBJ/PLY meshes (empty: the selected mesh objects)")
    labels: bpy.props.StringProperty(name="Labels CSV", subtype="FILE_PATH", default="",
                                     description="Ratings: a 'name' column and one column per attribute")
    out: bpy.props.StringProperty(name="Save As", subtype="FILE_PATH", default="//morph_model.npz",
                                  description="Where to save the model (.npz)")

    def make_job(self, context) -> Job:
        return BuildModelJob(context, self.folder, self.labels, self.out)


class FH_OT_morph_make_animatable(JobOperator, bpy.types.Operator):
    """Hand the face to the face-rig builder: same topology as the template, so no registration is needed"""

    bl_idname = "faces_hands.morph_make_animatable"
    bl_label = "Make Animatable"
    bl_options = {"REGISTER", "UNDO"}

    def make_job(self, context) -> Job:
        return MakeAnimatableJob(_face_object(context))


CLASSES = [FH_OT_morph_link_character, FH_OT_morph_refit_character, FH_OT_morph_new_face, FH_OT_morph_set_attribute, FH_OT_morph_caricature, FH_OT_morph_show_segments,
           FH_OT_morph_constrain, FH_OT_morph_release, FH_OT_morph_import_feature, FH_OT_morph_transform,
           FH_OT_morph_add_detail, FH_OT_morph_undo_edit, FH_OT_morph_save_face, FH_OT_morph_load_face,
           FH_OT_morph_render_thumbnails, FH_OT_morph_build_model, FH_OT_morph_make_animatable]
