"""Resume and idempotence without Blender: a committed row is current until its inputs, options or files
change; a commit cut short leaves every output old or new (never partial) and the row to redo; the chunk
reports of a farm job merge into one."""
from __future__ import annotations

import os

import pytest

from faces_hands_addon.farm import resume
from faces_hands_addon.farm.check import check_manifest
from faces_hands_addon.farm.report import RunReport, merge_reports
from faces_hands_addon.farm.resume import RunIdentity, commit_row, plan_rows, staging_folder

RUN = RunIdentity("0.1.0", "engine", "default", 30.0)


def _rows(tmp_path, text="action,out,text\nspeak,a.glb,One.\nspeak,sub/b.glb,Two.\nspeak,c.glb,Three.\n"):
    manifest = tmp_path / "jobs.csv"
    manifest.write_text(text)
    result = check_manifest(manifest, tmp_path / "out", fps=30, max_frames=5000)
    assert not result.problems
    return result.rows


def _commit(out, row, key, inputs, content=b"glb"):
    staging = staging_folder(out)
    staged = {}
    for name in row.outputs():
        path = staging / "row" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(content + name.encode())
        staged[name] = path
    return commit_row(out, row, key, inputs, staged, staging, RUN.extension_version)


def test_a_rerun_skips_exactly_the_current_rows(tmp_path):
    rows = _rows(tmp_path)
    out = tmp_path / "out"
    plan = plan_rows(rows, out, RUN)
    assert [r.line for r, _, _ in plan.todo] == [2, 3, 4] and not plan.problems
    for row, key, inputs in plan.todo[:2]:
        _commit(out, row, key, inputs)
    plan = plan_rows(rows, out, RUN)
    assert [r.line for r in plan.current] == [2, 3] and [r.line for r, _, _ in plan.todo] == [4]
    (out / "sub" / "b.wav").write_bytes(b"edited by hand")                  # an output changed
    assert [r.line for r, _, _ in plan_rows(rows, out, RUN).todo] == [3, 4]
    newer = RunIdentity("0.2.0", "engine", "default", 30.0)                 # another extension version
    assert [r.line for r, _, _ in plan_rows(rows, out, newer).todo] == [2, 3, 4]
    changed = _rows(tmp_path, "action,out,text\nspeak,a.glb,One said otherwise.\nspeak,sub/b.glb,Two.\n"
                              "speak,c.glb,Three.\n")
    assert [r.line for r, _, _ in plan_rows(changed, out, RUN).todo] == [2, 3, 4]


def test_an_audio_input_is_known_by_its_content(tmp_path):
    import numpy as np
    import soundfile
    soundfile.write(str(tmp_path / "take.wav"), np.zeros(8000, np.float32), 16000)
    rows = _rows(tmp_path, "action,out,audio\nlipsync,a.glb,take.wav\n")
    out = tmp_path / "out"
    row, key, inputs = plan_rows(rows, out, RUN).todo[0]
    assert set(inputs) == {"audio"} and len(inputs["audio"]) == 64
    _commit(out, row, key, inputs)
    assert plan_rows(rows, out, RUN).current == rows
    soundfile.write(str(tmp_path / "take.wav"), np.ones(8000, np.float32) * 0.1, 16000)
    assert plan_rows(rows, out, RUN).current == []


def test_a_commit_cut_short_leaves_no_partial_file_and_the_row_to_redo(tmp_path, monkeypatch):
    rows = _rows(tmp_path)
    out = tmp_path / "out"
    (row, key, inputs), (second, key2, inputs2) = plan_rows(rows, out, RUN).todo[:2]
    _commit(out, second, key2, inputs2, b"old ")
    real = os.replace

    def dies_before_the_wav(src, dst):
        if str(dst).endswith(".wav"):
            raise KeyboardInterrupt                         # killed between two renames
        return real(src, dst)
    monkeypatch.setattr(resume.os, "replace", dies_before_the_wav)
    for target, target_key, target_inputs in ((row, key, inputs), (second, key2, inputs2)):
        with pytest.raises(KeyboardInterrupt):
            _commit(out, target, target_key, target_inputs, b"new ")
    monkeypatch.setattr(resume.os, "replace", real)
    assert (out / "a.glb").read_bytes() == b"new a.glb" and not (out / "a.wav").exists()     # a first run
    assert (out / "sub/b.glb").read_bytes() == b"new sub/b.glb"                              # a rerun
    assert (out / "sub/b.wav").read_bytes() == b"old sub/b.wav"
    plan = plan_rows(rows, out, RUN)            # the incomplete sidecars mark the files as this run's own
    assert not plan.problems and [r.line for r, _, _ in plan.todo] == [2, 3, 4]
    _commit(out, row, key, inputs, b"new ")
    assert [r.line for r in plan_rows(rows, out, RUN).current] == [2]


def test_an_output_no_jobs_run_wrote_is_kept_unless_overwrite(tmp_path):
    rows = _rows(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (out / "c.wav").write_bytes(b"a recording somebody made")
    plan = plan_rows(rows, out, RUN)
    assert [(p.line, "c.wav" in p.message) for p in plan.problems] == [(4, True)]
    assert [r.line for r, _, _ in plan_rows(rows, out, RUN, overwrite=True).todo] == [2, 3, 4]


def test_chunk_reports_merge_into_one(tmp_path):
    first, second = RunReport("jobs.csv", 2), RunReport("jobs.csv", 2)
    first.done[2] = {"out": "a.glb", "seconds": 1.0, "worker": 1}
    first.skipped[3] = "b.glb"
    second.fail(4, "c.glb", "unknown voice")
    second.wall_s = 3.0
    again = RunReport.from_json(second.to_json())
    assert again.failed == second.failed and again.wall_s == 3.0
    merged = merge_reports("jobs.csv", {2: "a.glb", 3: "b.glb", 4: "c.glb", 5: "d.glb"}, {2, 3}, [first, again])
    assert (list(merged.done), list(merged.skipped), sorted(merged.failed)) == ([2], [3], [4, 5])
    assert merged.failed[5]["reason"] == "no task reported this row"
    assert "4 rows: 1 done, 1 skipped (already current), 2 failed" in merged.summary()
