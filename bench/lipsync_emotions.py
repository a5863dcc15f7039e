# SPDX-License-Identifier: GPL-3.0-or-later
"""Lip closures under every emotion and behaviour style, measured in the exported file.

``bench/lipsync_accuracy.py --emotions`` (or this script directly) runs the same real ``./fh lipsync`` on one
labelled recording once per condition, each condition adding ``--emotion`` and/or ``--style``:

* every emotion word of the NECA table (``presets/emotion/emotion_words.json``, thesis Table 4.4), with the
  neutral behaviour style on;
* points on the rim of the activation-evaluation disk (thesis Fig. 4.5) every 30 degrees, with the
  ``expressive`` style;
* every behaviour style of ``presets/behavior/styles.json`` with an emotion (the words cycled), and each style
  alone;
* ``--full``: every word with every style.

Each GLB is scored like ``lipsync_accuracy`` scores the neutral take: the lip aperture at the mouth centre as
the file holds it (accessors + the ``weights`` channel, numpy), and, with ``--browser``, as three.js plays it in
headless chromium; a labelled /p b m/ is closed when the aperture falls to ``CLOSED_MM`` inside the phone, or
within a frame of it. /f v/ are scored by the lower lip's distance to the upper incisors' edge (the lowest
upper-teeth vertex of the file at the mouth centre), ``LABIODENTAL_MM``.

Recordings: the 14 Festival sentences of ``lipsync_accuracy`` (default), or ``--quick`` the four labelled
Festival recordings of ``tests/data/speech`` (for iterating), or ``--audio/--labels/--transcript``.
Last line: ``RESULT ...`` (worst condition's closure percentages, the count of conditions meeting 95 % / 100 %).
"""
from __future__ import annotations

import argparse
import json
import math
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import lipsync_accuracy as acc  # noqa: E402  (first: it enables the installed extension and its wheels)
import gltf_client as client  # noqa: E402
import numpy as np  # noqa: E402
import soundfile  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
LABIODENTALS = ("f", "v")
LABIODENTAL_MM = 2.0
RIM_STEP_DEG = 30


def words() -> list[str]:
    doc = json.loads((ROOT / "presets" / "emotion" / "emotion_words.json").read_text())
    return sorted(doc["words"])


def styles() -> list[str]:
    doc = json.loads((ROOT / "presets" / "behavior" / "styles.json").read_text())
    return sorted(doc["styles"])


def disk_radius() -> float:
    from faces_hands_addon.emotion import DISK_RADIUS
    return float(DISK_RADIUS)


def conditions(full: bool) -> list[tuple[str, list[str]]]:
    """(label, extra ./fh lipsync arguments) of every condition."""
    out = [("neutral", [])]
    out += [(f"word {w}", ["--emotion", w, "--style", "neutral"]) for w in words()]
    radius = disk_radius()
    for angle in range(0, 360, RIM_STEP_DEG):
        a, e = radius * math.sin(math.radians(angle)), radius * math.cos(math.radians(angle))
        out.append((f"rim {angle:3d}deg", [f"--emotion={a:.1f},{e:.1f}", "--style", "expressive"]))
    cycle = words()
    for k, style in enumerate(styles()):
        out.append((f"style {style}", ["--style", style]))
        out.append((f"style {style} + {cycle[(7 * k + 3) % len(cycle)]}",
                    ["--style", style, "--emotion", cycle[(7 * k + 3) % len(cycle)]]))
    if full:
        out += [(f"{s} x {w}", ["--style", s, "--emotion", w]) for s in styles() for w in words()]
    return out


def quick_recording(folder: Path):
    """The four labelled recordings of tests/data/speech joined with 0.5 s of silence."""
    data = ROOT / "tests" / "data" / "speech"
    pieces, phones, texts, offset, rate = [], [], [], 0.0, None
    for tsv in sorted(data.glob("slt_*.tsv")):
        samples, rate = soundfile.read(str(tsv.with_suffix(".wav")), dtype="float64")
        rows = [line.split("\t") for line in tsv.read_text().splitlines() if line and not line.startswith("#")]
        texts += [r[1] for r in rows if r[0] == "text"]
        phones += [(r[1].lower(), float(r[2]) + offset, float(r[3]) + offset) for r in rows if r[0] == "phone"]
        gap = np.zeros(int(acc.GAP_S * rate))
        pieces += [samples, gap]
        offset += (len(samples) + len(gap)) / rate
    wav = folder / "quick.wav"
    soundfile.write(str(wav), np.concatenate(pieces), rate, subtype="PCM_16")
    return wav, phones, " ".join(texts)


def run(wav: Path, text: str, out: Path, extra: list[str]) -> float:
    started = time.perf_counter()
    done = subprocess.run([str(ROOT / "fh"), "lipsync", "--audio", str(wav), "--transcript", text, "--out",
                           str(out), "--overwrite", *extra, *acc.RIG], capture_output=True, text=True)
    if done.returncode != 0:
        raise client.Failure(f"./fh lipsync {' '.join(extra)} failed: {done.stderr.strip()[-1500:]}")
    return time.perf_counter() - started


def teeth_edge(glb: client.Glb) -> float | None:
    """Lowest vertex (glTF y, m: Y is up there) of the upper teeth mesh near the mouth centre, or None."""
    for mesh_index, mesh in enumerate(glb.gltf["meshes"]):
        if "teeth_upper" not in mesh.get("name", "").lower().replace(" ", "_"):
            continue
        node = next((n for n, item in enumerate(glb.gltf["nodes"]) if item.get("mesh") == mesh_index), None)
        if node is None:
            continue
        positions = glb.accessor(mesh["primitives"][0]["attributes"]["POSITION"])
        matrix = glb.world_matrices()[node]
        world = positions @ matrix[:3, :3].T + matrix[:3, 3]
        centre = 0.5 * (world[:, 0].min() + world[:, 0].max())
        near = world[np.abs(world[:, 0] - centre) < 0.004]
        return float(near[:, 1].min()) if len(near) else float(world[:, 1].min())
    return None


def file_aperture(path: Path):
    """(times, aperture mm, lower-lip top y mm, glb) as the file holds it (no browser)."""
    glb = client.Glb(path)
    skin = client.Skin(glb)
    keys, values, interpolation = client.weights_channel(glb, None, skin.node)
    every = np.arange(len(skin.base))
    motion = (skin.world(client.weights_at(keys, values, interpolation, keys), every)[:, :, 1].min(axis=0)
              - skin.rest(every)[:, 1])
    upper, lower = client.lip_vertices(skin, motion)
    vertices = np.concatenate([upper, lower])
    times = np.arange(0.0, float(keys[-1]) + 1e-9, acc.SAMPLE_S)
    world = skin.world(client.weights_at(keys, values, interpolation, times), vertices)
    lower_top = world[:, len(upper):, 1].max(axis=1) * 1000
    return times, client.aperture_mm(world, len(upper)), lower_top, glb


def labiodental_figures(times, lower_top_mm, edge_m, phones) -> tuple[int, float]:
    """(count, worst distance mm) of /f v/: the lower lip's top against the upper incisors' edge at the
    phone's closest sample (below the edge counts as its distance; at or above it, 0)."""
    worst, count = 0.0, 0
    if edge_m is None:
        return 0, float("nan")
    for phone, start, end in phones:
        if phone not in LABIODENTALS:
            continue
        inside = (times >= start) & (times <= end)
        if not inside.any():
            continue
        count += 1
        gap = max(edge_m * 1000 - float(lower_top_mm[inside].max()), 0.0)
        worst = max(worst, gap)
    return count, worst


def score_file(path: Path, phones, browser: bool) -> dict:
    times, aperture, lower_top, glb = file_aperture(path)
    count, worst = labiodental_figures(times, lower_top, teeth_edge(glb), phones)
    agreement = float("nan")
    if browser:
        times, aperture, agreement, _ = acc.glb_aperture(path)
    figures = acc.score(acc.intervals(times, aperture <= acc.CLOSED_MM), phones)
    figures.update(fv=count, fv_worst_mm=worst, agreement_mm=agreement, min_mm=float(aperture.min()))
    return figures


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="the four short recordings of tests/data/speech")
    parser.add_argument("--audio", type=Path)
    parser.add_argument("--labels", type=Path)
    parser.add_argument("--transcript")
    parser.add_argument("--browser", action="store_true", help="score as three.js plays each file (slower)")
    parser.add_argument("--full", action="store_true", help="also every style x every word")
    parser.add_argument("--only", help="comma-separated substrings: run the conditions whose label has one")
    parser.add_argument("--no-rhubarb", action="store_true", help="skip Rhubarb (quick runs while tuning)")
    parser.add_argument("--rig", choices=("mask", "character"), default="mask",
                        help="mask (default): the face-only head; character: the default character")
    parser.add_argument("--keep", type=Path, help="keep the files in this folder")
    args = parser.parse_args()
    acc.RIG[:] = [] if args.rig == "character" else ["--rig", "mask"]
    folder = args.keep or Path(tempfile.mkdtemp(prefix="fh-lipsync-emo-"))
    folder.mkdir(parents=True, exist_ok=True)
    try:
        if args.audio:
            wav, phones, text = args.audio, acc.read_labels(args.labels), args.transcript
        elif args.quick:
            wav, phones, text = quick_recording(folder)
        else:
            wav, phones, _, text, _ = acc.joined_festival(folder)
        chosen = conditions(args.full)
        if args.only:
            keys = [k.strip() for k in args.only.split(",")]
            chosen = [c for c in chosen if any(k in c[0] for k in keys)]
        print(f"{wav.name}: {soundfile.info(str(wav)).duration:.1f} s; {len(chosen)} conditions; closed = aperture "
              f"<= {acc.CLOSED_MM} mm {'in three.js' if args.browser else 'in the file'}")
        print(f"{'condition':34} {'bilabials':>9} {'closed%':>8} {'±frame%':>8} {'lag':>6} {'min mm':>7} "
              f"{'f/v':>4} {'f/v mm':>7} {'s':>6}")
        rows = []
        for k, (label, extra) in enumerate(chosen):
            out = folder / f"take_{k:03d}.glb"
            seconds = run(wav, text, out, extra)
            f = score_file(out, phones, args.browser)
            rows.append((label, f))
            print(f"{label:34} {f['n']:9d} {f['closed_pct']:8.1f} {f['frame_pct']:8.1f} {f['lag_ms']:6.0f} "
                  f"{f['min_mm']:7.2f} {f['fv']:4d} {f['fv_worst_mm']:7.2f} {seconds:6.1f}", flush=True)
            if args.keep is None:
                out.unlink()
        rhubarb = float("nan")
        if not args.no_rhubarb and acc.RHUBARB is not None:     # the peer in the same run (it has no emotions)
            cues, rh_s = acc.rhubarb_cues(wav, text, folder)
            f = acc.score([(s, e) for s, e, shape in cues if shape == "A"], phones)
            rhubarb = f["closed_pct"]
            print(f"{'Rhubarb 1.13 (A cues, any emotion)':34} {f['n']:9d} {f['closed_pct']:8.1f} {f['frame_pct']:8.1f} "
                  f"{f['lag_ms']:6.0f} {'':7} {'':4} {'':7} {rh_s:6.1f}")
        closed = [f["closed_pct"] for _, f in rows]
        frame = [f["frame_pct"] for _, f in rows]
        fv = [f["fv_worst_mm"] for _, f in rows if f["fv"]]
        worst = min(rows, key=lambda r: (r[1]["closed_pct"], r[1]["frame_pct"]))[0]
        print(f"RESULT conditions={len(rows)} closed_pct_min={min(closed):.1f} frame_pct_min={min(frame):.1f} "
              f"closed95_conditions={sum(c >= 95 for c in closed)} frame100_conditions={sum(f >= 100 for f in frame)} "
              f"fv_worst_mm={max(fv) if fv else float('nan'):.2f} worst=\"{worst}\" browser={int(args.browser)} "
              f"rhubarb_closed_pct={rhubarb:.1f}")
        return 0
    except client.Failure as failure:
        print(f"FAILED: {failure}")
        return 1
    finally:
        if args.keep is None:
            shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
