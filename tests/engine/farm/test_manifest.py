"""Jobs manifests checked whole before any work: every bad line listed with its number (CSV and JSON Lines),
no output outside the output folder or over an input, and a check whose cost grows linearly."""
from __future__ import annotations

import csv
import json
import os

import numpy as np
import pytest

from faces_hands_addon import UserError
from faces_hands_addon.core.files import FileClaims
from faces_hands_addon.farm.check import check_manifest, chunk_of, chunk_starts
from faces_hands_addon.farm.rows import relative_output


def _wav(path, seconds=0.5):
    import soundfile
    soundfile.write(str(path), np.zeros(int(16000 * seconds), np.float32), 16000)
    return path


def _voice(name):
    if name not in ("en-us", "de"):
        raise UserError(f"unknown espeak-ng voice {name!r}")


def _check(path, out_dir, **kw):
    return check_manifest(path, out_dir, fps=30, max_frames=5000, voice_check=_voice, **kw)


def _problems(result):
    return {problem.line: problem.message for problem in result.problems}


def test_every_bad_csv_line_is_listed_with_its_number(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    _wav(tmp_path / "take.wav")
    _wav(out / "line.wav")                                  # an input inside the output folder
    rows = [["speak", "a.glb", "Good morning.", "", ""],                        # 2 fine
            ["spek", "b.glb", "Typo in the action.", "", ""],                   # 3
            ["speak", "a.glb", "Same output as line 2.", "", ""],               # 4
            ["speak", "../escape.glb", "Outside.", "", ""],                     # 5
            ["speak", "/abs/x.glb", "Absolute.", "", ""],                       # 6
            ["lipsync", "ok.glb", "", "take.wav", ""],                          # 7 fine
            ["lipsync", "line.glb", "", "out/line.wav", ""],                    # 8 its WAV is its own input
            ["speak", "take.glb", "Writes the WAV line 7 reads? No: other folder.", "", ""],   # 9 fine
            ["speak", "c.glb", "Fast.", "", "fast"],                            # 10
            ["speak", "d.txt", "Wrong suffix.", "", ""],                        # 11
            ["speak", "e.glb", "", "", ""],                                     # 12 no text
            ["speak", "A.GLB", "Case-folded twin of line 2.", "", ""]]          # 13
    manifest = tmp_path / "jobs.csv"
    with open(manifest, "w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(["action", "out", "text", "audio", "rate"])
        writer.writerows(rows)
    with open(manifest, "ab") as handle:
        handle.write(b"speak,f.glb,caf\xe9 latin-1\n")                       # 14 not UTF-8
        handle.write(b"speak,g.glb,a NUL\x00 byte\n")                          # 15
        handle.write(b"speak,h.glb,too,many,cells,here\n")                     # 16
    result = _check(manifest, out)
    expected = {3: "unknown action 'spek'", 4: "writes 'a.glb', which line 2 writes too",
                5: "leads outside the output folder", 6: "is an absolute path", 8: "which is the audio of line 8",
                10: "rate 'fast' is not a number", 11: "must end with", 12: "needs text",
                13: "writes 'A.GLB', which line 2 writes too", 14: "is not UTF-8 (byte 0xe9",
                15: "has a NUL byte", 16: "has 6 cells"}
    problems = _problems(result)
    assert set(problems) == set(expected), problems
    for line, fragment in expected.items():
        assert fragment in problems[line], (line, problems[line])
    assert [row.line for row in result.rows] == [2, 7, 9]


def test_a_missing_column_refuses_the_header_and_names_what_is_missing(tmp_path):
    manifest = tmp_path / "jobs.csv"
    manifest.write_text("out,text\na.glb,Hello.\n")
    problems = _problems(_check(manifest, tmp_path))
    assert list(problems) == [1] and "no 'action' column" in problems[1]
    manifest.write_text("action,out,txt\nspeak,a.glb,Hello.\n")
    problems = _problems(_check(manifest, tmp_path))
    assert list(problems) == [1] and "unknown column(s) 'txt'" in problems[1]


def test_json_lines_rows_are_checked_like_csv_rows(tmp_path):
    lines = [json.dumps({"action": "speak", "out": "a.glb", "text": "Hi."}),
             "{not json",
             json.dumps(["a", "list"]),
             json.dumps({"action": "speak", "out": "a.glb", "text": "Twice."}),
             json.dumps({"action": "speak", "out": "b.glb", "text": "Hi.", "voice": "xx"}),
             json.dumps({"action": "speak", "out": "c.glb", "text": "Hi.", "colour": "red"}),
             "",
             json.dumps({"action": "speak", "out": "d.glb", "text": "Hi.", "emotion": "joy", "seed": 7})]
    manifest = tmp_path / "jobs.jsonl"
    manifest.write_text("\n".join(lines) + "\n")
    result = _check(manifest, tmp_path / "out")
    problems = _problems(result)
    assert set(problems) == {2, 3, 4, 5, 6}, problems
    assert "unknown espeak-ng voice 'xx'" in problems[5] and "unknown key 'colour'" in problems[6]
    assert [(row.line, row.emotion, row.seed) for row in result.rows] == [(1, "", 0), (8, "joy", 7)]


def test_no_output_lands_outside_the_folder_or_on_an_input(tmp_path):
    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    out.mkdir()
    elsewhere.mkdir()
    (out / "link").symlink_to(elsewhere, target_is_directory=True)
    take = _wav(tmp_path / "take.wav")
    os.link(take, out / "hard.wav")                       # the same file under a second name in the output folder
    manifest = tmp_path / "jobs.csv"
    manifest.write_text("action,out,text,audio\n"
                        "speak,link/a.glb,Through a link.,\n"
                        "lipsync,hard.glb,,take.wav\n"
                        "speak,.fh-farm/x.glb,Reserved.,\n"
                        "speak,jobs_report.json.glb,Fine name.,\n")
    problems = _problems(_check(manifest, out))
    assert "leads outside the output folder (a link)" in problems[2]
    assert "which is the audio of line 3" in problems[3]
    assert "the jobs run's own" in problems[4]
    assert 5 not in problems
    for bad in ("a\\b.glb", "C:x.glb", "a/../../b.glb", "~/x.glb", "x\x01.glb", "", "./"):
        with pytest.raises(UserError):
            relative_output("output", bad, (".glb",))
    assert relative_output("output", "./a//b/./c.glb", (".glb",)) == "a/b/c.glb"


def test_the_check_is_linear_in_rows(tmp_path, monkeypatch):
    """20,000 rows in 7 folders: the folders are resolved once each (no resolve per row, let alone per
    pair of rows), and a duplicate in the last row is still found."""
    rows = 20_000
    manifest = tmp_path / "jobs.csv"
    with open(manifest, "w", encoding="utf-8") as handle:
        handle.write("action,out,text,emotion\n")
        emotions = ("", "joy", '"50,-20"')
        for n in range(rows - 1):
            handle.write(f"speak,c{n % 7}/line{n}.glb,Line {n} of the take.,{emotions[n % 3]}\n")
        handle.write("speak,c0/line0.glb,The last row repeats the first output.,\n")
    calls = {"realpath": 0}
    real = os.path.realpath

    def counted(path, *args, **kwargs):
        calls["realpath"] += 1
        return real(path, *args, **kwargs)
    monkeypatch.setattr(os.path, "realpath", counted)
    result = _check(manifest, tmp_path / "out")
    assert len(result.rows) == rows - 1
    assert [(p.line, p.message) for p in result.problems] == [(rows + 1, "writes 'c0/line0.glb', which line 2 "
                                                                         "writes too")]
    assert calls["realpath"] <= 7 + 1 + 4, calls


def test_file_claims_find_a_file_under_another_name(tmp_path):
    target = tmp_path / "a.wav"
    target.write_bytes(b"x")
    (tmp_path / "sub").mkdir()
    (tmp_path / "alias").symlink_to(tmp_path / "sub", target_is_directory=True)
    os.link(target, tmp_path / "hard.wav")
    claims = FileClaims()
    claims.add(target, "input")
    claims.add(tmp_path / "sub" / "new.glb", "row 2")
    assert claims.owner(tmp_path / "hard.wav") == "input"
    assert claims.owner(tmp_path / "alias" / "new.glb") == "row 2"
    assert claims.owner(tmp_path / "sub" / ".." / "a.wav") == "input"
    assert claims.owner(tmp_path / "other.glb") is None


def test_chunks_cover_every_row_once(tmp_path):
    manifest = tmp_path / "jobs.csv"
    manifest.write_text("action,out,text\n" + "".join(f"speak,r{n}.glb,Row {n}.\n" for n in range(7)))
    rows = _check(manifest, tmp_path).rows
    starts = chunk_starts(len(rows), 3)
    assert starts == [1, 4, 7]
    assert [row.out for first in starts for row in chunk_of(rows, first, 3)] == [row.out for row in rows]
    with pytest.raises(UserError):
        chunk_of(rows, 8, 3)
