# SPDX-License-Identifier: GPL-3.0-or-later
"""The thesis' example (4.3.5, Fig. 4.7) played in a real glTF client: head, brows, blinks and wink in the file.

``./fh speak --text "Hi! ;-) Can you show me the way to the conference hall? :-)" --style neutral --seed 0``
writes the engine-ready weights GLB (ARKit + visemes + emotion targets, the head on the root node). three.js
(``GLTFLoader`` + ``AnimationMixer``) plays it in Debian's headless chromium every 5 ms and reads back the skin
node's world matrix (the head's motion) and the world positions of a few skin vertices, picked from the file's
own targets: the upper-lid vertex each ``eyeBlink*`` target moves most, the inner-brow vertex ``browInnerUp``
moves most on each side, the outer-brow vertex of each ``browOuterUp*``. In the head's frame:

* **head pitch** (degrees, + chin up) from the world matrix's forward axis;
* **brow rise** (mm, + up) of each brow vertex against its rest position;
* **lid closure** of each eye: the lid vertex's travel along its ``eyeBlink`` displacement, as a fraction of
  the file's own full blink (1.0). A blink in the file is a run with closure >= 0.9 on both eyes; a wink a run
  on one eye. Its phases (10-90 % closing, >= 90 % held, 90-10 % opening) are measured, and the gaps
  between the blinks' closings.

What the file shows is compared with the words' times as espeak-ng synthesised them (the synthesiser's own
segment times) and with the behaviour the engine planned for the same text and seed (4.2.1 / 4.3.5: head and
brows rise at accents; blinks close in 1/8 s, stay closed 1/24 s, open in 1/12 s; no gap over 4.8 s): the
planned event list is recomputed here from the installed engine, so what is measured is whether the shipped
file still carries what was planned, at the times the words were spoken.

Needs ``make bench-client`` and ``make install``. ``--glb FILE`` measures an existing file of the same text.
Last line: ``RESULT ...``.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401  (the installed extension)
import gltf_client as client  # noqa: E402
import numpy as np  # noqa: E402
from faces_hands_addon.behavior import generate_behavior  # noqa: E402
from faces_hands_addon.emotion import load_model  # noqa: E402
from faces_hands_addon.performance import _winks, voice_settings  # noqa: E402
from faces_hands_addon.speech.takes import take_from_text  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TEXT = "Hi! ;-) Can you show me the way to the conference hall? :-)"
SAMPLE_S = 0.005
CLOSED = 0.9          # closure fraction of the file's full blink counted as closed
FPS = 30


def speak(out: Path, seed: int, text: str = TEXT) -> float:
    started = time.perf_counter()
    done = subprocess.run([str(ROOT / "fh"), "speak", "--text", text, "--style", "neutral", "--seed", str(seed),
                           "--out", str(out), "--overwrite", "--fps", str(FPS)], capture_output=True, text=True)
    if done.returncode != 0:
        raise client.Failure(f"./fh speak failed: {done.stderr.strip()[-1500:]}")
    return time.perf_counter() - started


def planned(seed: int, text: str = TEXT):
    """The utterance as espeak-ng speaks it and the behaviour the engine plans for it (same text, seed)."""
    take = take_from_text(text, voice="en-us", fps=FPS, target="muscles", **voice_settings(None, 175.0))
    behavior = generate_behavior(take.utterance, "neutral", seed, lids_busy=_winks(take.utterance, load_model()))
    return take.utterance, behavior.events


def picked_vertices(skin: client.Skin) -> dict[str, int]:
    """Skin vertices by what moves them most in the file's targets (module docstring)."""
    rest = skin.rest(np.arange(len(skin.base)))
    middle = 0.5 * (rest[:, 0].min() + rest[:, 0].max())

    def most_moved(target: str, side: float = 0.0) -> int:
        if target not in skin.names:
            raise client.Failure(f"the file has no {target} target")
        moved = np.linalg.norm(skin.targets[skin.names.index(target)], axis=1)
        if side:
            moved = np.where(np.sign(rest[:, 0] - middle) == side, moved, 0.0)
        return int(np.argmax(moved))

    left = np.sign(rest[most_moved("eyeBlinkLeft"), 0] - middle)   # which side of x the character's left is
    return {"lid_L": most_moved("eyeBlinkLeft"), "lid_R": most_moved("eyeBlinkRight"),
            "brow_inner_L": most_moved("browInnerUp", left), "brow_inner_R": most_moved("browInnerUp", -left),
            "brow_outer_L": most_moved("browOuterUpLeft"), "brow_outer_R": most_moved("browOuterUpRight")}


def head_frame(matrices: np.ndarray):
    """(pitch degrees + chin up, per-sample inverse world matrices) from three.js' column-major matrices."""
    world = np.asarray(matrices, float).reshape(-1, 4, 4).transpose(0, 2, 1)
    forward = world[:, :3, 2] / np.linalg.norm(world[:, :3, 2], axis=1, keepdims=True)   # local +Z (glTF front)
    return np.degrees(np.arcsin(np.clip(forward[:, 1], -1, 1))), np.linalg.inv(world)


def runs(mask: np.ndarray, times: np.ndarray) -> list[tuple[float, float]]:
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    return [(float(times[a]), float(times[b - 1])) for a, b in zip(edges[::2], edges[1::2])]


def blink_phases(closure: np.ndarray, times: np.ndarray, span: tuple[float, float]) -> dict:
    """Closing (10-90 %), held (>= 90 %) and opening (90-10 %) times in ms of the blink whose closed run is
    ``span``; the percentages are of the rise from the lids' level just before the blink (gaze and smile move
    the lids too) to the blink's peak."""
    a, b = int(np.searchsorted(times, span[0])), int(np.searchsorted(times, span[1]))
    before = max(0, a - int(0.3 / SAMPLE_S))
    base = float(closure[before:a + 1].min())
    peak = float(closure[a:b + 1].max())
    low, high = base + 0.1 * (peak - base), base + 0.9 * (peak - base)
    k = a
    while k > 0 and closure[k - 1] > low:
        k -= 1
    closed = a
    while closed > k and closure[closed - 1] >= high:
        closed -= 1
    opened = b
    while opened < len(times) - 1 and closure[opened + 1] >= high:
        opened += 1
    end = opened
    while end < len(times) - 1 and closure[end + 1] > low:
        end += 1
    return {"onset": float(times[k]), "close_ms": (times[closed] - times[k]) * 1000,
            "held_ms": (times[opened] - times[closed]) * 1000, "open_ms": (times[end] - times[opened]) * 1000,
            "reopened": end < len(times) - 1}


def word_span(utterance, text: str) -> tuple[float, float]:
    found = [w for w in utterance.words if w.text.lower().strip(",.?!") == text]
    if not found:
        raise client.Failure(f"espeak-ng's words lack {text!r}: {[w.text for w in utterance.words]}")
    return float(found[0].start), float(found[0].end)


def measure(path: Path):
    """(glb, the client's result, sample times, head pitch deg, brow rise mm by vertex, lid closure by eye)."""
    glb = client.Glb(path)
    skin = client.Skin(glb)
    keys, _, _ = client.weights_channel(glb, None, skin.node)
    picked = picked_vertices(skin)
    vertices = np.array(list(picked.values()))
    times = np.arange(0.0, float(keys[-1]) + 1e-9, SAMPLE_S)
    got = client.play(path, skin, glb.gltf["animations"][0]["name"], times, vertices, [], influences=False)
    pitch, inverse = head_frame(got["samples"]["matrices"])
    world = np.asarray(got["samples"]["positions"], float)
    local = np.einsum("tij,tvj->tvi", inverse[:, :3, :3], world) + inverse[:, None, :3, 3]
    rest = skin.base[vertices]
    motion = dict(zip(picked, np.moveaxis(local - rest[None], 1, 0)))          # name -> (times x 3), metres
    closure = {}
    for side, target in (("L", "eyeBlinkLeft"), ("R", "eyeBlinkRight")):
        full = skin.targets[skin.names.index(target)][picked[f"lid_{side}"]]
        closure[side] = motion[f"lid_{side}"] @ full / float(full @ full)
    brow = {name: motion[name][:, 1] * 1000 for name in picked if name.startswith("brow")}
    return glb, got, times, pitch, brow, closure


def eye_gaze(glb, times: np.ndarray) -> dict[str, np.ndarray]:
    """Each eye's (yaw, pitch) in degrees ((Out - In, Up - Down) weights x the targets' turn) over ``times``, from the eye
    nodes' own weights channels in the file: the eyes between the gestures ("eyes alive between")."""
    gaze = {}
    for index, node in enumerate(glb.gltf["nodes"]):
        name = node.get("name", "")
        if "mesh" not in node or not name.endswith(("Eye L", "Eye R")):
            continue
        side = "Left" if name.endswith("L") else "Right"
        targets = glb.gltf["meshes"][node["mesh"]].get("extras", {}).get("targetNames", [])
        keys, values, interpolation = client.weights_channel(glb, None, index)
        w = client.weights_at(keys, values, interpolation, times)
        pick = {n: w[:, targets.index(f"eyeLook{n}{side}")] for n in ("Out", "In", "Up", "Down")}
        gaze[side] = np.column_stack([pick["Out"] - pick["In"], pick["Up"] - pick["Down"]])
        gaze[side] *= [eye_degrees(glb, node["mesh"], targets.index(f"eyeLook{n}{side}")) for n in ("Out", "Up")]
    return gaze


def eye_degrees(glb, mesh: int, target: int) -> float:
    """The eyeball's turn (degrees) at weight 1 of ``target``: the largest vertex displacement of that target
    as a chord of the eyeball (radius: half the eye mesh's extent)."""
    primitive = glb.gltf["meshes"][mesh]["primitives"][0]
    base = glb.accessor(primitive["attributes"]["POSITION"])
    moved = np.linalg.norm(glb.accessor(primitive["targets"][target]["POSITION"]), axis=1).max()
    radius = 0.5 * np.ptp(base, axis=0).max()
    return float(np.degrees(2 * np.arcsin(min(moved / (2 * radius), 1.0))))


def gaze_moves(gaze: np.ndarray, times: np.ndarray, step: float = 0.03) -> tuple[int, float]:
    """(gaze shifts: runs of movement faster than ``step`` degrees per 10 ms, the longest still stretch s)."""
    speed = np.linalg.norm(np.diff(gaze, axis=0), axis=1) / np.diff(times) * 0.01
    moving = np.concatenate([[False], speed > step])
    shifts = runs(moving, times)
    onsets = [a for a, _ in shifts]
    still = np.diff([0.0, *onsets, float(times[-1])]).max() if len(times) else 0.0
    return len(shifts), float(still)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--glb", type=Path, help="measure this GLB (of the same text and seed) instead of speaking")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--text", default=TEXT, help="another text (give --word too)")
    parser.add_argument("--word", default="conference", help="the accented word whose head and brows are reported")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="fh-performance-") as tmp:
        path, speak_s = args.glb, None
        if path is None:
            path = Path(tmp) / "performance.glb"
            speak_s = speak(path, args.seed, args.text)
        glb, got, times, pitch, brow, closure = measure(path)
    utterance, events = planned(args.seed, args.text)
    print(f"file {path.name}: {glb.size / 1e6:.2f} MB, clip {times[-1]:.2f} s; three.js r{got['info']['revision']} "
          f"in {got['browser']}; samples every {SAMPLE_S * 1000:.0f} ms"
          + (f"; ./fh speak took {speak_s:.1f} s" if speak_s else ""))
    print("words (espeak-ng's times): " + ", ".join(f"{w.text} {w.start:.2f}-{w.end:.2f}" for w in utterance.words))

    print("\nhead and brows over the words (file, three.js):")
    print(f"  {'word':12s} {'span s':>11s} {'head max deg':>12s} {'brow L mm':>9s} {'brow R mm':>9s}")
    at_word = {}
    for word in utterance.words:
        inside = (times >= word.start) & (times <= word.end)
        if not inside.any():
            continue
        row = (float(pitch[inside].max()), float(np.maximum(brow["brow_inner_L"], brow["brow_outer_L"])[inside].max()),
               float(np.maximum(brow["brow_inner_R"], brow["brow_outer_R"])[inside].max()))
        at_word.setdefault(word.text.lower().strip(",.?!"), row)
        print(f"  {word.text:12s} {word.start:5.2f}-{word.end:5.2f} {row[0]:12.2f} {row[1]:9.2f} {row[2]:9.2f}")
    plan = {e.kind: [x for x in events if x.kind == e.kind] for e in events}
    conference = word_span(utterance, args.word.lower())
    raises = [e for e in plan.get("head_raise", []) if e.start < conference[1] and e.end > conference[0]]
    brow_plan = [e for e in plan.get("brow_raise", []) + plan.get("question_raise", [])
                 if e.start < conference[1] and e.end > conference[0]]
    inside = (times >= conference[0]) & (times <= conference[1])
    head_peak_t = float(times[inside][np.argmax(pitch[inside])])
    planned_text = ", ".join(f"{np.degrees(e.params['pitch_rad']):.2f} deg peak {e.params['peak']:.2f} s"
                             for e in raises) or "none"
    print(f"\n'{args.word}' {conference[0]:.2f}-{conference[1]:.2f} s: planned head raise {planned_text}; "
          f"file: head {pitch[inside].max():.2f} deg at {head_peak_t:.2f} s (rest {pitch[0]:.2f}); "
          f"brows planned {len(brow_plan)} event(s), file L {at_word[args.word.lower()][1]:.2f} / R "
          f"{at_word[args.word.lower()][2]:.2f} mm")

    both = (closure["L"] >= CLOSED) & (closure["R"] >= CLOSED)
    blinks = [blink_phases(np.minimum(closure["L"], closure["R"]), times, span) for span in runs(both, times)]
    winks = {side: [s for s in runs((closure[side] >= CLOSED) & ~both, times)
                    if s[1] - s[0] >= 0.05] for side in "LR"}
    planned_blinks = plan.get("blink", [])
    print(f"\nblinks: planned {len(planned_blinks)} at "
          + ", ".join(f"{e.start:.2f}" for e in planned_blinks) + f" s; in the file {len(blinks)}:")
    offsets = []
    for b in blinks:
        near = min(planned_blinks, key=lambda e: abs(e.start - b["onset"]), default=None)
        offset = (b["onset"] - near.start) * 1000 if near is not None else float("nan")
        offsets.append(offset)
        print(f"  onset {b['onset']:.3f} s (planned {near.start if near else float('nan'):.3f}, {offset:+.0f} ms): "
              f"closing {b['close_ms']:.0f} ms, held {b['held_ms']:.0f} ms, opening {b['open_ms']:.0f} ms"
              f"{'' if b['reopened'] else ' (still opening at the clip end)'} "
              "(planned 125 / 42 / 83 ms end to end, i.e. 10-90 %: 100 / 42+25 / 67 ms)")
    onsets = [b["onset"] for b in blinks]
    gaps = np.diff([0.0] + onsets + [float(times[-1])])
    for side in "LR":
        for a, b in winks[side]:
            print(f"  wink {side}: closed {a:.2f}-{b:.2f} s")
    print(f"  longest stretch without a blink (incl. start and end): {gaps.max():.2f} s (rule: 4.8 s)")
    gaze = eye_gaze(glb, times)
    for side, g in gaze.items():
        shifts, still = gaze_moves(g, times)
        steps = np.abs(np.diff(g[::20], axis=0)).max(axis=1)          # 0.1-s steps
        print(f"  eye {side}: {shifts} gaze shifts, range yaw {np.ptp(g[:, 0]):.1f} / pitch {np.ptp(g[:, 1]):.1f} deg, "
              f"largest 0.1-s step {steps.max():.1f} deg, longest still stretch {still:.2f} s")
    shifts, still = gaze_moves(gaze["Left"], times) if "Left" in gaze else (0, float("nan"))
    wink_count = len(winks["L"]) + len(winks["R"])
    print(f"\nRESULT word={args.word} head_word_deg={pitch[inside].max() - pitch[0]:.2f} "
          f"planned_head_word_deg={max((np.degrees(e.params['pitch_rad']) for e in raises), default=0):.2f} "
          f"brow_word_mm={max(at_word[args.word.lower()][1:]):.2f} head_max_deg={pitch.max() - pitch[0]:.2f} "
          f"blinks_file={len(blinks)} blinks_planned={len(planned_blinks)} "
          f"blink_onset_err_ms_max={np.nanmax(np.abs(offsets)) if offsets else float('nan'):.0f} "
          f"max_blink_gap_s={gaps.max():.2f} winks={wink_count} gaze_shifts={shifts} gaze_still_max_s={still:.2f}")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except client.Failure as error:
        print(f"performance_client: {error}", file=sys.stderr)
        sys.exit(1)
