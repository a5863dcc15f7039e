# SPDX-License-Identifier: GPL-3.0-or-later
"""The thesis' behaviour rates (4.2.1, 4.3.5) on real espeak-ng speech over many seeds.

The tests check the rates on utterances built with a known layout; this bench checks them on what the product
speaks: a few paragraphs synthesised by espeak-ng (statements, questions, commas, a filled pause), each run
through ``generate_behavior`` in the neutral style for ``--seeds`` seeds. Counted from the planned events:
brow raises per kept pitch maximum (0.71), sideways tilts per head raise (~0.75), glances per accented
syllable (0.70) and per phrase-boundary pause outside thinking (0.70), frowns per thinking pause (0.25),
the longest stretch without a blink (<= 4.8 s) and the blink phases (1/8, 1/24, 1/12 s).

Run: ``.venv/bin/python bench/behavior_rates.py [--seeds 200]`` (needs ``make install``). Last line: ``RESULT``.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402,F401  (the installed extension)
import numpy as np  # noqa: E402
from faces_hands_addon.behavior import generate_behavior  # noqa: E402
from faces_hands_addon.speech.tts import synthesize  # noqa: E402

TEXTS = (
    "Hi! Can you show me the way to the conference hall? I have a talk there at ten, and I am late.",
    "The weather was fine this morning, but the forecast says it will rain, so take an umbrella with you.",
    "Well, errr, I am not quite sure what you mean. Could you explain it again, slowly, from the start?",
    "Our team built a talking head that moves its brows, its eyes and its head while it speaks. "
    "People who watched it said it looked alive, and they asked where they could try it themselves.",
    "First you open the box. Then you take out the parts, one by one, and you lay them on the table. "
    "Do you have everything? Good. Now we can begin.",
)


def rates(seeds: int) -> dict:
    counts = dict.fromkeys(("pitch_max", "brow_raise", "head_raise", "tilted", "accents", "accent_glance",
                            "boundary_pauses", "within_turn_glance", "thinking", "frown"), 0)
    gaps, phases = [], set()
    for text in TEXTS:
        u = synthesize(text)
        for seed in range(seeds):
            r = generate_behavior(u, "neutral", seed)
            counts["pitch_max"] += r.count("pitch_max")
            counts["brow_raise"] += r.count("brow_raise")
            raises = r.of_kind("head_raise")
            counts["head_raise"] += len(raises)
            counts["tilted"] += sum(e.params["tilt_rad"] != 0.0 for e in raises)
            counts["accents"] += len(u.accented_syllables)
            counts["accent_glance"] += r.count("accent_glance")
            thinking = [(e.start, e.end) for e in r.of_kind("thinking")]
            counts["boundary_pauses"] += sum(1 for p in u.pauses if p.kind in ("phrase", "sentence")
                                             and not any(a < p.end and p.start < b for a, b in thinking))
            counts["within_turn_glance"] += r.count("within_turn_glance")
            counts["thinking"] += len(thinking)
            counts["frown"] += sum(e.params["mode"] == "down" for e in r.of_kind("thinking"))
            onsets = [e.start for e in r.of_kind("blink")]
            gaps.append(float(np.diff([0.0, *onsets, u.duration]).max()))
            phases |= {(round(e.params["close_s"], 6), round(e.params["apex_s"], 6), round(e.params["open_s"], 6))
                       for e in r.of_kind("blink")}
    return {"counts": counts, "max_gap": max(gaps), "phases": sorted(phases)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=200)
    args = parser.parse_args()
    started = time.perf_counter()
    got = rates(args.seeds)
    c = got["counts"]
    table = [("brow raises per pitch maximum", c["brow_raise"], c["pitch_max"], "0.71"),
             ("sideways tilts per head raise", c["tilted"], c["head_raise"], "~0.75"),
             ("glances per accented syllable", c["accent_glance"], c["accents"], "0.70"),
             ("glances per phrase-boundary pause", c["within_turn_glance"], c["boundary_pauses"], "0.70"),
             ("frowns per thinking pause", c["frown"], c["thinking"], "0.25")]
    print(f"{len(TEXTS)} espeak-ng paragraphs x {args.seeds} seeds, neutral style "
          f"({time.perf_counter() - started:.1f} s)")
    print(f"  {'rate':36s} {'count':>13s} {'measured':>8s} {'thesis':>6s}")
    values = {}
    for name, hits, total, thesis in table:
        values[name] = hits / total if total else float("nan")
        print(f"  {name:36s} {hits:6d}/{total:<6d} {values[name]:8.3f} {thesis:>6s}")
    print(f"  longest stretch without a blink: {got['max_gap']:.2f} s (rule: 4.8 s)")
    print(f"  blink phases (close, apex, open) s: {got['phases']} (1/8, 1/24, 1/12)")
    keys = ("brow", "tilt", "accent_glance", "pause_glance", "frown")
    print("RESULT " + " ".join(f"{k}={v:.3f}" for k, v in zip(keys, values.values()))
          + f" max_blink_gap_s={got['max_gap']:.2f} seeds={args.seeds}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
