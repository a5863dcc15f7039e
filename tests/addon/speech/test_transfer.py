"""A speech take on the face rig, baked as engine-ready weights and transferred onto a character that has
only ARKit + viseme shape keys: its mouth opens on the open vowels and closes on /p b m/ at the phone times
espeak-ng itself reports (ground truth from the synthesiser, not from the weights pipeline)."""
from __future__ import annotations

import math
import re

import numpy as np

from conftest import addon_module

TEXT = "Papa made a map, and Bob ate a big apple."
FPS = 30
REST_APERTURE = 10.0                                  # mm between the character's two lip vertices at rest
OPENING = {"jawOpen": 20.0, "viseme_aa": 15.0, "viseme_O": 10.0, "viseme_E": 8.0, "viseme_I": 6.0,
           "viseme_U": 4.0, "mouthClose": -10.0, "viseme_PP": -10.0}          # lower lip down (mm), per key


def _character(bpy):
    """A 'character' whose lower lip (vertex 1) each mouth key moves; it has the 52 ARKit + 15 viseme keys."""
    arkit = addon_module("faces_hands_addon.anim.retarget").ARKIT_NAMES
    visemes = ["viseme_" + v for v in ("sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR", "aa", "E",
                                       "I", "O", "U")]
    mesh = bpy.data.meshes.new("Avatar")
    mesh.from_pydata([(0, 0, 0.005), (0, 0, -0.005), (0.02, 0, 0)], [], [(0, 1, 2)])
    avatar = bpy.data.objects.new("Avatar", mesh)
    bpy.context.scene.collection.objects.link(avatar)
    avatar.shape_key_add(name="Basis", from_mix=False)
    for name in list(arkit) + visemes:
        block = avatar.shape_key_add(name=name, from_mix=False)
        block.data[1].co.z -= OPENING.get(name, 0.0) / 1000.0
    return avatar


def _aperture(bpy, avatar, frame) -> float:
    bpy.context.scene.frame_set(frame)
    evaluated = avatar.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = evaluated.to_mesh()
    try:
        return (mesh.vertices[0].co.z - mesh.vertices[1].co.z) * 1000.0
    finally:
        evaluated.to_mesh_clear()


def test_speech_weights_play_on_an_arkit_viseme_character_at_the_phone_times(bpy_clean):
    bpy = bpy_clean
    from faces_hands_addon.speech import synthesize
    scene = bpy.context.scene
    scene.render.fps, scene.frame_start = FPS, 1
    utterance = synthesize(TEXT)
    scene.frame_end = 1 + math.ceil(utterance.duration * FPS)
    assert bpy.ops.faces_hands.build_face_rig() == {"FINISHED"}
    rig = bpy.context.active_object
    scene.faces_hands.speech_text = TEXT
    scene.faces_hands.speech_voice = "en-us"
    assert bpy.ops.faces_hands.speak_text() == {"FINISHED"}
    report = addon_module("operators.face.services").bake(bpy.context, rig, "animation")
    median, p90 = (float(x) for x in re.search(r"median ([\d.]+) mm, p90 ([\d.]+) mm", report).groups())
    assert median <= 4.0 and p90 <= 10.0, report    # worst vertex per frame; the rest is the physics lag
    avatar = _character(bpy)
    for obj in bpy.context.view_layer.objects:
        obj.select_set(obj in (rig, avatar))
    bpy.context.view_layer.objects.active = rig
    assert bpy.ops.faces_hands.transfer_animation() == {"FINISHED"}
    apertures = {f: _aperture(bpy, avatar, f) for f in range(scene.frame_start, scene.frame_end + 1)}

    def during(phone, pad=1):
        first = scene.frame_start + math.floor(phone.start * FPS) - pad
        last = scene.frame_start + math.ceil((phone.start + phone.duration) * FPS) + pad
        return [apertures[f] for f in range(max(first, scene.frame_start), min(last, scene.frame_end) + 1)]

    bilabials = [p for p in utterance.phones if p.phone in ("p", "b", "m")]
    vowels = [p for p in utterance.phones if p.phone in ("aa", "ae") and p.duration >= 0.06]
    assert len(bilabials) >= 8 and len(vowels) >= 4
    closed = [min(during(p)) for p in bilabials]
    opened = [max(during(p, pad=0)) for p in vowels]
    assert max(closed) <= 0.35 * REST_APERTURE, list(zip([p.phone for p in bilabials], np.round(closed, 1)))
    assert min(opened) >= 1.25 * REST_APERTURE, np.round(opened, 1)
