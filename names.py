# SPDX-License-Identifier: GPL-3.0-or-later
"""The property-name contract between the extension and a .blend: every custom property the operators write
and the panels read, in one place that imports nothing (no bpy, no engine), so a panel and an operator
cannot spell a name two ways. Files saved by earlier versions use the same names: renaming one breaks them.
"""
from __future__ import annotations

__all__ = ["RIG_MARKER", "RIG_DATA", "RIG_KIND", "RIG_ID", "RIG_CONTROLS", "RIG_WARNINGS", "OUTPUT_TO_LOCAL",
           "PART_ROLE", "TAKE", "TAKE_STAMP", "TAKE_LAYERS", "MOUTH_CUES", "MORPH_MARKER", "MORPH_MODEL",
           "MORPH_STATE", "MORPH_EXAMPLES", "MORPH_HISTORY", "MORPH_CHARACTER", "MORPH_REFIT", "HAND_PHOTO", "PHOTO_POINT", "PHOTO_IMAGE",
           "PHOTO_IMAGE_SIZE", "PHOTO_RULER_MM", "PHOTO_HEAD", "PHOTO_LANDMARKS", "PHOTO_CAMERA", "CONTROL_PREFIX",
           "control_property", "layer_prefix"]

# -- a rig object (any kind) and its parts
RIG_MARKER = "fh_rig"                   # 1 on the object that carries a rig
RIG_DATA = "fh_rig_data"                # the engine rig's saved bytes (an .npz without pickles)
RIG_KIND = "fh_rig_kind"                # "face", "hand", ...
RIG_ID = "fh_rig_id"                    # names the stored data (a hash computed when stored)
RIG_CONTROLS = "fh_rig_controls"        # JSON [[name, group, kind], ...]: what the panels list
RIG_WARNINGS = "fh_rig_warnings"        # JSON list of problems that leave a fitted rig usable
OUTPUT_TO_LOCAL = "fh_head_to_local"    # 16 floats: the rig's output space -> the object's local space
PART_ROLE = "fh_part"                   # on every part: "skull", "jaw", "eye_L", ...

# -- a take on a rig (speech, behaviour, emotion)
TAKE = "fh_take"                        # the engine take's bytes (anim.take.Take)
TAKE_STAMP = "fh_take_stamp"            # JSON: its start frame, rate and each layer's F-curve fingerprint
TAKE_LAYERS = "fh_take_layers"          # the layers besides speech the take wrote ("behavior emotion head")
MOUTH_CUES = "fh_mouth_cues"            # the take's mouth cues (Rhubarb shapes), JSON

# -- a morphable face
MORPH_MARKER = "fh_morph"
MORPH_MODEL = "fh_morph_model"          # "default" or the model file
MORPH_STATE = "fh_morph_state"          # JSON of the edit state
MORPH_EXAMPLES = "fh_morph_examples"    # JSON of the model's examples (for the example list)
MORPH_HISTORY = "fh_morph_history"      # one edit a line
MORPH_CHARACTER = "fh_morph_character"  # the character body whose head the face reshapes (its name)
MORPH_REFIT = "fh_morph_refit"          # on that body: the morph state its face rig was last refitted to

# -- a hand photo and its feature points
HAND_PHOTO = "fh_hand_photo"
PHOTO_POINT = "fh_photo_point"
PHOTO_IMAGE = "fh_image"
PHOTO_IMAGE_SIZE = "fh_image_size"
PHOTO_RULER_MM = "fh_ruler_mm"

# -- a head made from a photograph (thesis 3.2.4) and its landmarks
PHOTO_HEAD = "fh_photo_head"            # JSON on the head: photo file(s), cameras, illumination, fit report
PHOTO_LANDMARKS = "fh_photo_landmarks"  # JSON on a landmark-point mesh: the photo it belongs to, its size
PHOTO_CAMERA = "fh_photo_camera"        # 1 on the camera that sees the photo (its background image)

# -- rig controls: one animatable property per control and layer
CONTROL_PREFIX = "fh"


def control_property(control: str, layer: str) -> str:
    """The property of ``control`` in ``layer`` (``ctrl``, ``speech``, ``behavior``, ``emotion``)."""
    return f"{CONTROL_PREFIX}.{layer}.{control}"


def layer_prefix(layer: str) -> str:
    """The start every property of ``layer`` shares."""
    return f"{CONTROL_PREFIX}.{layer}."
