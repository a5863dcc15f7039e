# SPDX-License-Identifier: GPL-3.0-or-later
"""The face rig's controls (:class:`..core.controls.ControlSpec`): muscle contractions in [0, 1] and the direct parameters of
thesis 3.1.1/3.1.2 (jaw, eyes, lids, tongue, lip protrusion), with ranges, defaults and UI regions."""
from __future__ import annotations

from ..core.controls import ControlSpec

__all__ = ["DIRECT_CONTROLS", "muscle_control", "control_specs"]


DIRECT_CONTROLS = (
    ControlSpec("orbicularis_oris_protrusion", -1, 1, 0, "mouth", "direct",
                "lips forward (+1) or pressed back (-1) along the protrusion axis (3.1.2)"),
    ControlSpec("jaw_open", 0, 1, 0, "jaw", "direct",
                "jaw pitch about the TMJ: 1 = the lower incisors travel ~45 mm (40 mm between the incisal edges)"),
    ControlSpec("jaw_yaw", -1, 1, 0, "jaw", "direct", "jaw yaw: + moves the chin to the character's left"),
    ControlSpec("jaw_forward", -1, 1, 0, "jaw", "direct", "jaw protrusion (+, 6 mm) / retrusion (-, 2 mm)"),
    ControlSpec("jaw_drop", -1, 1, 0, "jaw", "direct", "vertical jaw translation: + down (5 mm), - up (1 mm)"),
    ControlSpec("eye_yaw", -1, 1, 0, "eyes", "direct", "gaze: + looks to the character's left (35 deg)"),
    ControlSpec("eye_pitch", -1, 1, 0, "eyes", "direct", "gaze: + looks up (25 deg); the lids follow"),
    ControlSpec("eye_yaw_L", -1, 1, 0, "eyes", "direct",
                "left eye only, added to eye_yaw: + looks to the character's left (ARKit eyeLook*Left)"),
    ControlSpec("eye_yaw_R", -1, 1, 0, "eyes", "direct",
                "right eye only, added to eye_yaw: + looks to the character's left (ARKit eyeLook*Right)"),
    ControlSpec("eye_pitch_L", -1, 1, 0, "eyes", "direct", "left eye only, added to eye_pitch: + looks up"),
    ControlSpec("eye_pitch_R", -1, 1, 0, "eyes", "direct", "right eye only, added to eye_pitch: + looks up"),
    ControlSpec("eyelid_close_L", 0, 1, 0, "eyes", "direct", "left eyelids: 1 = closed"),
    ControlSpec("eyelid_close_R", 0, 1, 0, "eyes", "direct", "right eyelids: 1 = closed"),
    ControlSpec("eyelid_raise_L", 0, 1, 0, "eyes", "direct",
                "left upper lid raised (levator palpebrae, FACS AU5): 1 = ~2 mm higher"),
    ControlSpec("eyelid_raise_R", 0, 1, 0, "eyes", "direct",
                "right upper lid raised (levator palpebrae, FACS AU5): 1 = ~2 mm higher"),
    ControlSpec("cheek_puff", 0, 1, 0, "cheeks", "direct",
                "air in the mouth pushes the cheeks out (ARKit cheekPuff): 1 = 5 mm; the buccinator resists it"),
    ControlSpec("tongue_tip_up", 0, 1, 0, "tongue", "direct", "tongue tip raised (35 deg)"),
    ControlSpec("tongue_back", 0, 1, 0, "tongue", "direct", "tongue pulled back (10 mm)"),
    ControlSpec("tongue_out", 0, 1, 0, "tongue", "direct", "tongue stuck out (24 mm)"),
)

_MUSCLE_REGION = {
    "frontalis": "brow", "corrugator": "brow", "procerus": "brow", "orbicularis_oculi": "eyes",
    "levator_labii_alaeque": "nose", "levator_labii_superioris": "cheeks", "zygomaticus": "cheeks",
    "levator_anguli": "cheeks", "buccinator": "cheeks", "risorius": "mouth", "depressor": "mouth", "mentalis": "mouth",
    "orbicularis_oris": "mouth",
}


def muscle_control(name: str) -> ControlSpec:
    region = next((r for key, r in _MUSCLE_REGION.items() if name.startswith(key)), "mouth")
    return ControlSpec(name, 0, 1, 0, region, "muscle", f"contraction of {name.replace('_', ' ')}")


def control_specs(muscle_names: list[str]) -> dict[str, ControlSpec]:
    """All controls of a rig: its muscles (in layout order) then the direct parameters."""
    specs = {name: muscle_control(name) for name in muscle_names}
    specs.update({c.name: c for c in DIRECT_CONTROLS})
    return specs

