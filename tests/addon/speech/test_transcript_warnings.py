"""Transcript-check warnings reach the user: the Lip Sync Audio operator reports them as warnings
and ``./fh lipsync`` prints them; a wrong transcript is refused with one clear line."""
from __future__ import annotations

from pathlib import Path

import pytest

VISEMES = ["viseme_sil", "viseme_PP", "viseme_FF", "viseme_TH", "viseme_DD", "viseme_kk", "viseme_CH",
           "viseme_SS", "viseme_nn", "viseme_RR", "viseme_aa", "viseme_E", "viseme_ih", "viseme_oh", "viseme_ou"]

FIXTURE = Path(__file__).resolve().parents[2] / "data" / "transcript_check" / "slt_bring_the_blue_basket.wav"
ADDED_WORD = "Bring the blue basket to the elephant kitchen before dinner."


def _viseme_mesh(bpy):
    bpy.ops.mesh.primitive_plane_add()
    obj = bpy.context.active_object
    obj.shape_key_add(name="Basis")
    for name in VISEMES:
        obj.shape_key_add(name=name)
    return obj


def test_operator_reports_the_word_that_does_not_match(bpy_clean, capfd):
    bpy = bpy_clean
    _viseme_mesh(bpy)
    assert bpy.ops.faces_hands.lipsync_audio(filepath=str(FIXTURE), transcript=ADDED_WORD) == {"FINISHED"}
    out = capfd.readouterr().out
    assert "warning:" in out and "'elephant'" in out, out[-2000:]


def test_operator_refuses_a_wrong_transcript(bpy_clean):
    bpy = bpy_clean
    _viseme_mesh(bpy)
    with pytest.raises(RuntimeError, match="does not match the audio"):
        bpy.ops.faces_hands.lipsync_audio(filepath=str(FIXTURE), transcript="The quick brown fox jumps.")


def test_cli_lipsync_prints_named_word_warnings_and_refuses_wrong_text(installed, tmp_path):
    from conftest import run_fh
    wrong = run_fh(installed, "lipsync", "--rig", "mask", "--audio", FIXTURE, "--transcript", "She sells sea shells by the shore.",
                   "--out", tmp_path / "wrong.glb")
    assert wrong.returncode == 1 and "does not match the audio" in wrong.stderr, wrong.stderr[-2000:]
    assert not (tmp_path / "wrong.glb").exists()
    result = run_fh(installed, "lipsync", "--rig", "mask", "--audio", FIXTURE, "--transcript", ADDED_WORD,
                    "--out", tmp_path / "x.glb")
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-2000:]
    assert "'elephant'" in result.stdout and "not in the recording" in result.stdout, result.stdout[-2000:]
    assert (tmp_path / "x.glb").exists()
