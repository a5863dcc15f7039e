"""Named targets between characters (anim.retarget): ARKit / viseme spellings and the Live Link Face CSV."""
from __future__ import annotations

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.anim.retarget import (ARKIT_NAMES, match_targets, read_live_link_csv, take_rate,
                                             write_live_link_csv)


def test_the_arkit_set_is_the_52_of_live_link_face():
    assert len(ARKIT_NAMES) == 52 == len(set(ARKIT_NAMES))
    assert ARKIT_NAMES[0] == "eyeBlinkLeft" and ARKIT_NAMES[17] == "jawOpen" and ARKIT_NAMES[-1] == "tongueOut"


def test_targets_are_matched_through_the_spellings_of_other_tools():
    available = ["Basis", "EyeBlinkLeft", "eyeBlink_R", "JAWOPEN", "viseme_I", "viseme_aa", "mouthSmile"]
    found = match_targets(["eyeBlinkLeft", "eyeBlinkRight", "jawOpen", "viseme_ih", "viseme_aa",
                           "mouthSmileLeft"], available)
    assert found == {"eyeBlinkLeft": "EyeBlinkLeft", "eyeBlinkRight": "eyeBlink_R", "jawOpen": "JAWOPEN",
                     "viseme_ih": "viseme_I", "viseme_aa": "viseme_aa"}


def test_live_link_csv_round_trip(tmp_path):
    fps = 60.0
    times = np.arange(150) / fps
    rng = np.random.default_rng(3)
    weights = {"jawOpen": rng.uniform(size=150), "eyeBlinkLeft": rng.uniform(size=150)}
    path = write_live_link_csv(tmp_path / "take.csv", times, weights, fps)
    header, first = path.read_text().splitlines()[:2]
    assert header.startswith("Timecode,BlendShapeCount,EyeBlinkLeft,EyeLookDownLeft")
    assert len(header.split(",")) == 2 + 52 + 9 and first.startswith("00:00:00:00.000,61,")
    assert path.read_text().splitlines()[91].startswith("00:00:01:30.000,")
    back_times, back = read_live_link_csv(path)
    assert np.abs(back_times - times).max() < 1e-9
    assert np.abs(back["jawOpen"] - weights["jawOpen"]).max() < 1e-6
    assert not back["mouthSmileLeft"].any()


@pytest.mark.parametrize("fps, frames", [(30, 149), (24, 60), (30, 15), (30000 / 1001, 200), (60, 20), (25, 101)])
def test_every_take_we_write_reads_back_at_its_own_times_and_rate(tmp_path, fps, frames):
    """The timecodes give the rate (issue 33: a 30-fps take of 149 frames came back as 135 frames when read
    as 60 fps), for takes longer and shorter than a second."""
    times = np.arange(frames) / fps
    weights = {"jawOpen": np.linspace(0.0, 1.0, frames)}
    back_times, back = read_live_link_csv(write_live_link_csv(tmp_path / "take.csv", times, weights, fps))
    assert len(back_times) == frames and np.abs(back_times - times).max() < 1e-6
    assert take_rate(back_times) == pytest.approx(fps, rel=1e-6)
    assert np.abs(back["jawOpen"] - weights["jawOpen"]).max() < 1e-6


def test_timecodes_of_other_rates_give_their_rate(tmp_path):
    """A CSV whose timecodes count 30 frames a second (Live Link Face set to 30, or an older file of ours)
    is read at 30 once it passes a second; a rate the frame numbers exceed is refused."""
    lines = ["Timecode,BlendShapeCount,JawOpen"]
    lines += [f"00:00:{k // 30:02d}:{k % 30:02d}.000,1,{k / 44:.3f}" for k in range(45)]
    path = tmp_path / "thirty.csv"
    path.write_text("\n".join(lines) + "\n")
    times, weights = read_live_link_csv(path)
    assert np.abs(times - np.arange(45) / 30).max() < 1e-9 and take_rate(times) == 30
    with pytest.raises(UserError, match="not at 24 fps"):
        read_live_link_csv(path, 24)
    lines[5] = lines[4]
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(UserError, match="line 6: the timecode does not come after"):
        read_live_link_csv(path)


def test_a_nul_byte_is_refused(tmp_path):
    path = write_live_link_csv(tmp_path / "take.csv", np.arange(3) / 60, {"jawOpen": np.zeros(3)}, 60)
    path.write_bytes(path.read_bytes().replace(b"0.000000", b"0.0\x0000000", 1))
    with pytest.raises(UserError, match="NUL"):
        read_live_link_csv(path)


@pytest.mark.parametrize("cell, message", [("nan", "not a finite number"), ("inf", "not a finite number"),
                                            ("lots", "not a number")])
def test_bad_live_link_cells_are_refused_with_their_line(tmp_path, cell, message):
    path = write_live_link_csv(tmp_path / "take.csv", np.arange(3) / 60, {"jawOpen": np.zeros(3)}, 60)
    lines = path.read_text().splitlines()
    cells = lines[2].split(",")
    cells[2 + ARKIT_NAMES.index("jawOpen")] = cell
    lines[2] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(UserError, match=f"line 3: JawOpen|line 3: jawOpen"):
        read_live_link_csv(path)
    with pytest.raises(UserError, match=message):
        read_live_link_csv(path)


def test_not_a_live_link_csv(tmp_path):
    (tmp_path / "x.csv").write_text("a,b\n1,2\n")
    with pytest.raises(UserError, match="Timecode"):
        read_live_link_csv(tmp_path / "x.csv")
