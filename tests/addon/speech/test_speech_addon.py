"""Speak Text / Lip Sync Audio through the installed add-on, on a mesh with viseme shape keys."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

# Ready Player Me spelling (viseme_I/O/U) on purpose: lip sync must find them as aliases of the Oculus
# names viseme_ih/oh/ou.
VISEMES = ["viseme_sil", "viseme_PP", "viseme_FF", "viseme_TH", "viseme_DD", "viseme_kk", "viseme_CH",
           "viseme_SS", "viseme_nn", "viseme_RR", "viseme_aa", "viseme_E", "viseme_I", "viseme_O", "viseme_U"]
DATA = Path(__file__).resolve().parents[2] / "data" / "speech"


def _viseme_mesh(bpy):
    bpy.ops.mesh.primitive_plane_add()
    obj = bpy.context.active_object
    obj.shape_key_add(name="Basis")
    for name in VISEMES + ["smile"]:
        obj.shape_key_add(name=name)
    return obj


def _strip_start(strip):
    """Where a strip's content starts (Blender 5.2 renamed ``frame_start`` to ``content_start``)."""
    return strip.content_start if hasattr(strip, "content_start") else strip.frame_start


def _strip_duration(strip):
    if hasattr(strip, "left_handle"):
        return strip.right_handle - strip.left_handle
    return strip.frame_final_duration


def _curves(id_block):
    """Data path -> F-curve of ``id_block``'s action (the layered-action API)."""
    anim = id_block.animation_data
    if anim is None or anim.action is None:
        return {}
    bag = anim.action.layers[0].strips[0].channelbag(anim.action_slot)
    return {fc.data_path: fc for fc in bag.fcurves}


def _viseme_curves(obj):
    return _curves(obj.data.shape_keys)


def test_speak_text_drives_visemes_and_adds_sound(bpy_clean):
    bpy = bpy_clean
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 30000, 1001  # 29.97
    scene.frame_start = 10
    obj = _viseme_mesh(bpy)
    key = obj.data.shape_keys
    key.key_blocks["smile"].value = 0.3
    key.key_blocks["smile"].keyframe_insert("value", frame=5)  # an artist's key that must survive
    assert bpy.ops.faces_hands.speak_text(text="Can you show me the way to the conference hall?") == {"FINISHED"}
    curves = _viseme_curves(obj)
    viseme_curves = [p for p in curves if "viseme_" in p]
    assert len(viseme_curves) == 15 and 'key_blocks["viseme_U"].value' in curves
    assert 'key_blocks["smile"].value' in curves
    strips = [s for s in scene.sequence_editor.strips if s.name.startswith("FH Speech")]
    assert len(strips) == 1 and _strip_start(strips[0]) == 10 and strips[0].sound.packed_file is not None
    fps = 30000 / 1001
    pp = curves['key_blocks["viseme_PP"].value']
    frames = np.array([k.co[0] for k in pp.keyframe_points])
    duration_frames = _strip_duration(strips[0])
    assert frames[0] == pytest.approx(10, abs=1.0)
    assert abs(frames[-1] - (10 + duration_frames)) < 0.1 * fps
    values = np.array([k.co[1] for k in pp.keyframe_points])
    assert values.max() > 0.5, "the /p/ /m/ of 'me' and 'show me' never reach the PP viseme"
    # run again: the take is replaced, not stacked; the artist's key survives
    assert bpy.ops.faces_hands.speak_text(text="Hello there.") == {"FINISHED"}
    curves = _viseme_curves(obj)
    assert len([p for p in curves if "viseme_" in p]) == 15
    assert 'key_blocks["smile"].value' in curves
    assert len([s for s in scene.sequence_editor.strips if s.name.startswith("FH Speech")]) == 1


def test_speak_empty_text_changes_nothing(bpy_clean):
    bpy = bpy_clean
    obj = _viseme_mesh(bpy)
    bpy.context.scene.faces_hands.speech_text = "   "
    with pytest.raises(RuntimeError, match="no text"):
        bpy.ops.faces_hands.speak_text(text="")
    assert obj.data.shape_keys.animation_data is None
    assert bpy.context.scene.sequence_editor is None or len(bpy.context.scene.sequence_editor.strips) == 0


def test_target_without_visemes_is_a_clear_error(bpy_clean):
    bpy = bpy_clean
    bpy.ops.mesh.primitive_cube_add()
    with pytest.raises(RuntimeError, match="viseme shape keys"):
        bpy.ops.faces_hands.speak_text(text="Hello.")


def test_lipsync_audio_file(bpy_clean, tmp_path):
    import soundfile
    bpy = bpy_clean
    wav = DATA / "slt_ill_disposed.wav"                               # Festival speech (tests/data/speech)
    transcript = next(line.split("\t")[1] for line in wav.with_suffix(".tsv").read_text().splitlines()
                      if line.startswith("text\t"))
    obj = _viseme_mesh(bpy)
    with pytest.raises(RuntimeError, match="no speech take"):
        bpy.ops.faces_hands.export_mouth_cues(filepath=str(tmp_path / "none.json"))
    assert bpy.ops.faces_hands.lipsync_audio(filepath=str(wav), transcript=transcript) == {"FINISHED"}
    assert len([p for p in _viseme_curves(obj) if "viseme_" in p]) == 15
    strip = bpy.context.scene.sequence_editor.strips[0]
    assert Path(bpy.path.abspath(strip.sound.filepath)).resolve() == wav.resolve()
    # the same take as Rhubarb mouth cues, from the N-panel / File > Export
    assert bpy.ops.faces_hands.export_mouth_cues(filepath=str(tmp_path / "cues.json")) == {"FINISHED"}
    cues = json.loads((tmp_path / "cues.json").read_text())["mouthCues"]
    assert cues[0]["start"] == 0.0 and {c["value"] for c in cues} <= set("ABCDEFGHX")
    assert cues[-1]["end"] == pytest.approx(soundfile.info(str(wav)).duration, abs=0.02)
    assert all(a["end"] == b["start"] for a, b in zip(cues, cues[1:]))


def test_corrupt_audio_changes_nothing(bpy_clean, tmp_path):
    bpy = bpy_clean
    bad = tmp_path / "broken.wav"
    bad.write_bytes(b"RIFF\x00\x00\x00\x00WAVEfmt garbage")
    obj = _viseme_mesh(bpy)
    with pytest.raises(RuntimeError):
        bpy.ops.faces_hands.lipsync_audio(filepath=str(bad), transcript="hello")
    assert obj.data.shape_keys.animation_data is None


def _speech_curves(rig):
    return _curves(rig)


def test_speak_on_face_rig_writes_speech_layer_and_keeps_artist_keys(bpy_clean):
    bpy = bpy_clean
    scene = bpy.context.scene
    scene.render.fps, scene.render.fps_base = 25, 1.0
    scene.frame_start = 1
    assert bpy.ops.faces_hands.build_face_rig() == {"FINISHED"}
    rig = bpy.context.active_object
    rig["fh.ctrl.zygomaticus_major_L"] = 0.4
    rig.keyframe_insert('["fh.ctrl.zygomaticus_major_L"]', frame=3)
    assert bpy.ops.faces_hands.speak_text(text="Peter picked a pepper.") == {"FINISHED"}
    curves = _speech_curves(rig)
    speech = [p for p in curves if p.startswith('["fh.speech.')]
    assert '["fh.speech.jaw_open"]' in speech and '["fh.speech.orbicularis_oris_upper"]' in speech
    assert '["fh.ctrl.zygomaticus_major_L"]' in curves
    first = curves['["fh.speech.jaw_open"]'].keyframe_points[0].co[0]
    assert first == pytest.approx(1.0, abs=0.5)
    upper = np.array([k.co[1] for k in curves['["fh.speech.orbicularis_oris_upper"]'].keyframe_points])
    assert upper.max() > 0.5, "the /p/ closures never contract the lips"
    count = len(speech)
    assert bpy.ops.faces_hands.speak_text(text="Hello.") == {"FINISHED"}
    curves = _speech_curves(rig)
    assert len([p for p in curves if p.startswith('["fh.speech.')]) == count
    assert '["fh.ctrl.zygomaticus_major_L"]' in curves
    assert len(scene.sequence_editor.strips) == 1


def test_zero_length_audio_is_a_clear_error(bpy_clean, tmp_path):
    bpy = bpy_clean
    import wave
    empty = tmp_path / "empty.wav"
    with wave.open(str(empty), "wb") as handle:
        handle.setnchannels(1)
        handle.setsampwidth(2)
        handle.setframerate(16000)
    obj = _viseme_mesh(bpy)
    with pytest.raises(RuntimeError, match="(?i)empty|no audio|too short|zero"):
        bpy.ops.faces_hands.lipsync_audio(filepath=str(empty), transcript="hello")
    assert obj.data.shape_keys.animation_data is None


def _glb_animation_seconds(path):
    import struct
    data = path.read_bytes()
    length = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + length])
    times = [doc["accessors"][s["input"]] for a in doc.get("animations", []) for s in a["samplers"]]
    return min(t["min"][0] for t in times), max(t["max"][0] for t in times)


def test_cli_speak_jobs_csv_glb_and_wav_start_together(installed, tmp_path):
    import soundfile
    from conftest import run_fh
    jobs = tmp_path / "lines.csv"
    jobs.write_text("out,text,voice,cues\n"
                    f"{tmp_path / 'hello.glb'},Hello there.,en-us,{tmp_path / 'hello.json'}\n"
                    f"{tmp_path / 'hallo.fbx'},Guten Tag.,de,{tmp_path / 'hallo.tsv'}\n")
    result = run_fh(installed, "speak", "--rig", "mask", "--jobs", jobs, "--fps", "25")
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    for name in ("hello.glb", "hello.wav", "hallo.fbx", "hallo.wav", "hello.json", "hallo.tsv"):
        assert (tmp_path / name).exists(), name
    cues = json.loads((tmp_path / "hello.json").read_text())          # Rhubarb's JSON mouth cues
    assert cues["metadata"]["soundFile"] == "hello.wav"
    assert cues["metadata"]["duration"] == pytest.approx(soundfile.info(str(tmp_path / "hello.wav")).duration,
                                                         abs=0.01)
    assert {c["value"] for c in cues["mouthCues"]} <= set("ABCDEFGHX") and len(cues["mouthCues"]) >= 5
    tsv = [line.split("\t") for line in (tmp_path / "hallo.tsv").read_text().splitlines()]
    assert tsv[0] == ["0.00", "X"] and tsv[-1][1] == "X"
    assert [float(t) for t, _ in tsv] == sorted(float(t) for t, _ in tsv)
    start, end = _glb_animation_seconds(tmp_path / "hello.glb")
    audio = soundfile.info(str(tmp_path / "hello.wav"))
    assert start == pytest.approx(0.0, abs=1e-6)
    assert abs(end - audio.duration) <= 1.0 / 25 + 1e-6, (end, audio.duration)


def test_cli_speak_bad_jobs_file_writes_nothing(installed, tmp_path):
    from conftest import run_fh
    jobs = tmp_path / "lines.csv"
    jobs.write_text("out,txt\n" f"{tmp_path / 'a.glb'},Hello.\n")              # a misspelt column
    result = run_fh(installed, "speak", "--rig", "mask", "--jobs", jobs)
    assert result.returncode == 1 and "unknown column(s) txt" in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lines.csv"]


def test_speak_with_behaviour_and_emotion_puts_each_on_its_layer(bpy_clean):
    bpy = bpy_clean
    settings = bpy.context.scene.faces_hands
    assert bpy.ops.faces_hands.build_face_rig() == {"FINISHED"}
    rig = bpy.context.active_object
    settings.behavior_style, settings.behavior_seed, settings.speech_emotion = "neutral", 3, "hungry"
    before = sorted(_curves(rig))
    with pytest.raises(RuntimeError, match="unknown emotion word"):          # checked before any work
        bpy.ops.faces_hands.speak_text(text="Hi! ;-) How are you?")
    assert sorted(_curves(rig)) == before
    settings.speech_emotion = "joy"
    assert bpy.ops.faces_hands.speak_text(text="Well, hello there. How are you today?") == {"FINISHED"}
    curves = _curves(rig)
    lids = curves['["fh.behavior.eyelid_close_L"]']
    assert max(k.co[1] for k in lids.keyframe_points) == pytest.approx(1.0, abs=1e-6)     # a full blink
    smile = curves['["fh.emotion.zygomaticus_major_L"]']
    values = np.array([k.co[1] for k in smile.keyframe_points])
    # joy all through the take, except where the lips round (/ow/ in "hello", /aw/ "how", /uw/ "you"): there
    # speech owns the smile (performance.priority), so it gives way and comes back
    assert np.median(values) > 0.5 and (values > 0.2).mean() > 0.6 and values.min() < 0.2
    assert rig["fh_take_layers"] == "behavior emotion head"
    assert max(abs(a) for a in rig.delta_rotation_euler) < 0.35        # the head turns with the speech
    # lip sync only again: the previous take's behaviour and emotion go with it, the artist's keys stay
    settings.behavior_style, settings.speech_emotion = "NONE", ""
    assert bpy.ops.faces_hands.speak_text(text="Hello.") == {"FINISHED"}
    left = _curves(rig)
    assert not [p for p in left if p.startswith(('["fh.behavior.', '["fh.emotion.', "delta_"))]
    assert "fh_take_layers" not in rig and tuple(rig.delta_rotation_euler) == (0.0, 0.0, 0.0)


def _glb_weight_animation(path):
    """{node name: (times, {target name: weights})} of a GLB's weights channels."""
    import struct
    data = path.read_bytes()
    length = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + length])
    blob = data[20 + length + 8:]

    def floats(index):
        accessor = doc["accessors"][index]
        view = doc["bufferViews"][accessor["bufferView"]]
        count = accessor["count"] * {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[accessor["type"]]
        offset = view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
        return np.frombuffer(blob, dtype="<f4", count=count, offset=offset)
    out = {}
    for animation in doc["animations"]:
        for channel in animation["channels"]:
            node = doc["nodes"][channel["target"]["node"]]
            if channel["target"]["path"] != "weights":
                sampler = animation["samplers"][channel["sampler"]]
                times = floats(sampler["input"])
                out[node["name"], channel["target"]["path"]] = (times, floats(sampler["output"]).reshape(len(times), -1))
                continue
            names = doc["meshes"][node["mesh"]]["extras"]["targetNames"]
            sampler = animation["samplers"][channel["sampler"]]
            times = floats(sampler["input"])
            weights = floats(sampler["output"]).reshape(len(times), -1)
            out[node["name"]] = (times, dict(zip(names, weights.T)))
    return out


def test_cli_speak_thesis_example_with_behaviour_exports_blinks_wink_and_smile(installed, tmp_path):
    from conftest import run_fh
    from faces_hands_addon.speech import synthesize
    text = "Hi! ;-) Can you show me the way to the conference hall? :-)"
    out = tmp_path / "hi.glb"
    result = run_fh(installed, "speak", "--text", text, "--style", "neutral", "--seed", "1", "--rig", "mask", "--out", out)
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    animation = _glb_weight_animation(out)
    times, weights = max((v for k, v in animation.items() if isinstance(k, str)), key=lambda tw: len(tw[1]))
    # the head moves as a whole: the root node's rotation, small (raises of at most ~3 deg, tilts, turns)
    rotations = [v for k, v in animation.items() if isinstance(k, tuple) and k[1] == "rotation"]
    assert len(rotations) == 1, list(animation)
    _, quaternions = rotations[0]
    rest = quaternions[0]
    angles = 2 * np.arccos(np.clip(np.abs(quaternions @ rest), 0, 1))
    assert 0.01 < angles.max() < 0.35
    assert weights["eyeBlinkLeft"].max() > 0.6 and weights["eyeBlinkRight"].max() > 0.6     # blinks
    wink = next(t.time for t in synthesize(text).emotions if t.emotion == "kidding")
    at = int(np.argmin(np.abs(times - wink)))
    assert weights["eyeBlinkRight"][at] - weights["eyeBlinkLeft"][at] > 0.3                # one eye: a wink
    assert max(weights["mouthSmileLeft"][at], weights["mouthSmileRight"][at]) > 0.2        # and a smile
    bad = run_fh(installed, "speak", "--text", text, "--style", "shy", "--out", tmp_path / "b.glb")
    assert bad.returncode == 1 and "unknown character style 'shy'" in bad.stderr
    assert not (tmp_path / "b.glb").exists()


def test_cli_speak_glb_shows_every_bilabial_closed_on_time(installed, tmp_path):
    """The engine-ready weights in the file: every /p b m/ closure of the take has a key inside it (or the
    key nearest its middle) showing viseme_PP alone, with no corrective reopening the lips."""
    from conftest import run_fh
    from faces_hands_addon.speech import synthesize
    from faces_hands_addon.speech.closures import lip_closures
    text = "Papa made a map, and Bob bought a bumpy boat."
    out = tmp_path / "papa.glb"
    result = run_fh(installed, "speak", "--rig", "mask", "--text", text, "--out", out, "--live-link",
                    tmp_path / "papa.csv", "--cues", tmp_path / "papa.tsv")
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    _every_file_of_the_take_reads_back(installed, tmp_path, out)
    times, weights = max((v for k, v in _glb_weight_animation(out).items() if isinstance(k, str)),
                         key=lambda tw: len(tw[1]))
    closures = lip_closures(synthesize(text).phones)
    assert len(closures) >= 8
    others = [n for n in weights if n.startswith("viseme_") and n != "viseme_PP"]
    correctives = [n for n in weights if n.startswith("FH.")]
    for closure in closures:
        keys = np.flatnonzero((times >= closure.start - 1e-4) & (times <= closure.end + 1e-4))
        if not len(keys):
            keys = [int(np.argmin(np.abs(times - (closure.start + closure.end) / 2)))]
        for k in keys:
            assert weights["viseme_PP"][k] > 0.999, (closure, times[k])
            assert max(weights[n][k] for n in others + correctives) < 1e-6, (closure, times[k])


def _every_file_of_the_take_reads_back(installed, tmp_path, glb):
    """Every format the take was written in, read back by ``retarget`` (issue 33 item 5): the GLB's and the
    Live Link CSV's weights at every frame of the take, the mouth cues' shapes at their times."""
    from types import SimpleNamespace

    import bpy
    from conftest import addon_module, run_fh
    from export_checks import played_weights, save_avatar
    from faces_hands_addon.anim.retarget import ARKIT_NAMES
    from faces_hands_addon.speech.cues import SHAPE_VISEME, read_cues
    avatar = tmp_path / "avatar.blend"
    save_avatar(bpy, avatar, list(ARKIT_NAMES) + sorted(set(SHAPE_VISEME.values()) | {"viseme_PP", "viseme_aa"}))
    times, weights = max((v for k, v in _glb_weight_animation(glb).items() if isinstance(k, str)),
                         key=lambda tw: len(tw[1]))
    cues = tmp_path / "played_cues.blend"                     # in this process: the same service, faster
    addon_module("operators.face.services").retarget(SimpleNamespace(
        source=str(tmp_path / "papa.tsv"), character=str(avatar), fps=None, csv_fps=None, rig=None, object=None), cues)
    _, played = played_weights(bpy, cues)
    for cue in read_cues(tmp_path / "papa.tsv")[1:-1]:
        middle = int(round((cue.start + cue.end) / 2 * 30))
        assert played[SHAPE_VISEME[cue.shape]][middle] == 1.0, (cue, middle)
    for source in ("papa.glb", "papa.csv"):
        out = tmp_path / f"played_{source.replace('.', '_')}.blend"
        result = run_fh(installed, "retarget", "--source", tmp_path / source, "--character", avatar, "--out", out)
        assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
        frames, played = played_weights(bpy, out)
        assert f"Transferred {len(times)} frames at 30 fps" in result.stdout, result.stdout
        assert len(frames) == len(times)                        # 30 fps: not read as 60 (149 -> 135 on main)
        names = [n for n in played if n in weights] if source == "papa.glb" else [n for n in played if n[0] != "v"]
        assert len(names) >= 50
        for name in names:
            assert np.abs(played[name] - np.clip(weights[name], 0, 1)).max() < 1e-5, (source, name)   # float32
