# SPDX-License-Identifier: GPL-3.0-or-later
"""Properties of the Morphable Face panel: per face object its attribute sliders and segment picker, per
scene the model, database filters and edit options. Slider and checkbox updates call the morph operators
by ``bl_idname`` (so every edit is one operator run with Blender undo)."""
from __future__ import annotations

import bpy


def _set_shape(self, context):
    bpy.ops.faces_hands.morph_set_attribute(name=self.name, part="shape", value=self.shape)


def _set_colour(self, context):
    bpy.ops.faces_hands.morph_set_attribute(name=self.name, part="colour", value=self.colour)


def _segments_changed(self, context):
    bpy.ops.faces_hands.morph_show_segments(show=context.active_object.faces_hands_morph.show_segments)


def _caricature(self, context):
    bpy.ops.faces_hands.morph_caricature(level=self.caricature)


class FH_MorphSlider(bpy.types.PropertyGroup):
    """One attribute of Table 5.2 with separate shape and colour values (5.1.4)"""

    category: bpy.props.StringProperty(name="Category", description="Table 5.2 category of the attribute")
    has_colour: bpy.props.BoolProperty(name="Has Colour", description="The attribute has a colour vector")
    shape: bpy.props.FloatProperty(name="Shape", default=0.0, soft_min=-1.0, soft_max=1.0, min=-3.0, max=3.0,
                                   update=_set_shape,
                                   description="Shape value in standard deviations of the examples' ratings")
    colour: bpy.props.FloatProperty(name="Colour", default=0.0, soft_min=-1.0, soft_max=1.0, min=-3.0, max=3.0,
                                    update=_set_colour,
                                    description="Colour value in standard deviations of the examples' ratings")


class FH_MorphSegment(bpy.types.PropertyGroup):
    """A segment of Table 5.1; edits go to the selected ones"""

    depth: bpy.props.IntProperty(name="Depth", description="Level in the segment hierarchy (0 = the face)")
    selected: bpy.props.BoolProperty(name="Selected", default=False, update=_segments_changed,
                                     description="Restrict edits to this segment (with the other selected ones)")


class FH_MorphFace(bpy.types.PropertyGroup):
    """The morphable-face settings of one face object"""

    sliders: bpy.props.CollectionProperty(type=FH_MorphSlider, name="Attributes",
                                          description="Attribute sliders of the face's model")
    segments: bpy.props.CollectionProperty(type=FH_MorphSegment, name="Segments",
                                           description="Segment picker (Table 5.1 hierarchy)")
    caricature: bpy.props.FloatProperty(name="Caricature", default=1.0, min=0.05, max=3.0, update=_caricature,
                                        description="Distance from the average face (1 = unchanged, 3.2.2)")
    show_segments: bpy.props.BoolProperty(name="Show Segments", default=False, update=_segments_changed,
                                          description="Colour the face by segment; the selection is bright")
    history_index: bpy.props.IntProperty(name="History", default=0, description="Selected edit in the history")


SEX_ITEMS = [("any", "Any", "Both sexes"), ("female", "Female", "Women only"), ("male", "Male", "Men only")]
AGE_ITEMS = [("any", "Any", "Every age"), ("18-29", "18-29", "Younger adults"), ("30-44", "30-44", "Middle"),
             ("45+", "45+", "Older adults")]
PART_ITEMS = [("both", "Shape + Colour", "Shape and colour"), ("shape", "Shape", "Shape only"),
              ("colour", "Colour", "Colour only")]


class FH_MorphSettings(bpy.types.PropertyGroup):
    """Scene-wide morphable-face settings: model, new-face options, database filters (5.1.1)"""

    model_path: bpy.props.StringProperty(
        name="Model", subtype="FILE_PATH", default="",
        description="Morphable model file (.npz native or FLAME, BFM .mat/.h5, eos .bin); empty: the default "
                    "model (whole heads on the character's topology); 'mask': the synthetic 468-vertex face mask")
    seed: bpy.props.IntProperty(name="Seed", default=0, min=0, description="Seed of the random face")
    example: bpy.props.IntProperty(name="Example", default=0, min=0, description="Database example to use")
    filter_sex: bpy.props.EnumProperty(name="Sex", items=SEX_ITEMS, description="Show examples of this sex")
    filter_age: bpy.props.EnumProperty(name="Age", items=AGE_ITEMS, description="Show examples of this age group")
    filter_population: bpy.props.StringProperty(name="Population", default="",
                                                description="Show examples of this population (empty: all)")
    part: bpy.props.EnumProperty(name="Part", items=PART_ITEMS, description="What an import or constraint affects")
    constraint_database: bpy.props.BoolProperty(
        name="Apply to Database", default=False,
        description="Also adapt every database example to the constraint (5.1.7)")
    detail_factor: bpy.props.FloatProperty(name="Detail", default=0.7, min=0.0, max=2.0,
                                           description="Factor of the high-frequency detail vector (5.1.9)")
    slider_filter: bpy.props.StringProperty(name="Filter", default="",
                                            description="Show only attributes whose name contains this text")


CLASSES = [FH_MorphSlider, FH_MorphSegment, FH_MorphFace, FH_MorphSettings]
PROPERTIES = [(bpy.types.Object, "faces_hands_morph", bpy.props.PointerProperty(type=FH_MorphFace)),
              (bpy.types.Scene, "faces_hands_morph", bpy.props.PointerProperty(type=FH_MorphSettings))]
