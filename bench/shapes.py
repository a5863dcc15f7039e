# SPDX-License-Identifier: GPL-3.0-or-later
"""Shape audit (issue 10): settle each of the 52 ARKit shapes, the 15 visemes and the named emotions on a
face rig and measure them against anatomical targets (``faces_hands_addon/face/audit_targets.py``; sources
and how sure each target is: ``bench/shape_targets.md``). Prints one table and a ``RESULT`` line per head.

Run: ``FH_TEST_FROM_SOURCE=1 python bench/shapes.py`` (engine from the working tree, default head),
``python bench/shapes.py`` (the installed extension, like ``make bench``), ``--rig RIG.npz`` (a rig saved
by the engine, a fitted one included), ``--fit HEAD.npz`` (a head mesh, ``vertices`` and ``faces``, fitted
here with ``build_fitted_rig(seed=0)``, e.g. tests/data/heads/*.npz) or ``--blend RIG.blend`` (every face rig object in a saved .blend;
needs the bpy module). ``--names a,b`` audits a subset, ``--json PATH`` writes every figure.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

if os.environ.get("FH_TEST_FROM_SOURCE") == "1":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
else:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import _harness  # noqa: E402,F401

import numpy as np  # noqa: E402

from faces_hands_addon.face.audit_targets import TARGETS, audit_shapes  # noqa: E402
from faces_hands_addon.face.expressions import load_expressions  # noqa: E402

SHOW = ("gap_L", "gap_R", "iris_L", "iris_R", "yaw_L", "yaw_R", "pitch_L", "pitch_R", "brow_in_L", "brow_in_R",
        "brow_out_L", "brow_out_R", "corner_up_L", "corner_out_L", "corner_up_R", "corner_out_R", "width",
        "lip_gap", "protrusion", "incisal", "upper_show", "lower_show", "ff_dist", "cheek_L", "inverted",
        "asym95")
ARKIT_VISEMES = 67


def _expressions() -> dict[str, dict[str, float]]:
    out = {}
    for name in ("arkit", "visemes", "named"):
        out.update(load_expressions(name))
    return out


def _rigs(args) -> list[tuple[str, object]]:
    if args.blend:
        import bpy
        from faces_hands_addon.core.rig import load_rig_bytes
        bpy.ops.wm.open_mainfile(filepath=str(Path(args.blend).resolve()), load_ui=False)
        found = [(f"{Path(args.blend).name}:{o.name}", load_rig_bytes(bytes(o["fh_rig_data"]), o.name))
                 for o in bpy.data.objects if o.get("fh_rig") and o.get("fh_rig_kind", "face") == "face"
                 and "fh_rig_data" in o.keys()]
        if not found:
            sys.exit(f"{args.blend}: no face rig object")
        return found
    if args.fit:
        from faces_hands_addon.face.fitted import build_fitted_rig
        out = []
        for path in args.fit:
            data = np.load(path)
            started = time.perf_counter()
            rig = build_fitted_rig(data["vertices"].astype(np.float64), data["faces"].astype(np.int64), seed=0)
            print(f"fitted {Path(path).name} in {time.perf_counter() - started:.0f} s; warnings: {rig.warnings}")
            if args.save_rig:
                Path(args.save_rig).mkdir(parents=True, exist_ok=True)
                rig.save(Path(args.save_rig) / f"{Path(path).stem}.npz")
            out.append((Path(path).stem, rig))
        return out
    if args.rig:
        from faces_hands_addon.core.rig import load_rig
        return [(Path(args.rig).name, load_rig(args.rig))]
    from faces_hands_addon.face.rig import build_default_rig
    return [("default head", build_default_rig(args.resolution))]


def _row(name: str, m: dict, neutral: dict, failed: list[str]) -> str:
    keys = [k for k, *_ in TARGETS.get(name, [])]
    shown = []
    for key in dict.fromkeys(keys):
        shown.append(f"{key}={m[key]:.1f}")
    status = "ok  " if not failed else "FAIL"
    return f"{name:22s} {status} {' '.join(shown):60s} {'; '.join(failed)}"


def _result(label: str, report: dict) -> str:
    rows, neutral = report["rows"], report["neutral"]
    core = [n for n in rows if not n.startswith(("smile", "frown", "surprise", "sad", "anger", "disg", "fear"))]
    emotions = [n for n in rows if n not in core]
    ok = sum(1 for n in core if not rows[n][1])
    eok = sum(1 for n in emotions if not rows[n][1])
    get = lambda n, k, d=float("nan"): rows[n][0][k] if n in rows else d  # noqa: E731
    cross = [abs(rows[n][0][f"{a}_{'R' if n.endswith('Left') else 'L'}"]) for n in rows if n.startswith("eyeLook")
             for a in ("yaw", "pitch")]
    fields = {
        "shapes_ok": ok, "shapes_total": len(core), "emotions_ok": eok, "emotions_total": len(emotions),
        "blink_gap_mm": max(get("eyeBlinkLeft", "gap_L"), get("eyeBlinkRight", "gap_R")),
        "blink_iris_points": get("eyeBlinkLeft", "iris_L") + get("eyeBlinkRight", "iris_R"),
        "brow_inner_up_mm": min(get("browInnerUp", "brow_in_L"), get("browInnerUp", "brow_in_R")),
        "brow_outer_up_mm": get("browOuterUpLeft", "brow_out_L"), "brow_down_mm": get("browDownLeft", "brow_in_L"),
        "gaze_other_eye_deg": max(cross) if cross else float("nan"),
        "jaw_open_incisal_mm": get("jawOpen", "incisal"), "jaw_open_inverted": get("jawOpen", "inverted"),
        "neutral_lip_gap_mm": neutral["lip_gap"], "neutral_upper_teeth_mm": neutral["upper_show"],
        "neutral_lower_teeth_mm": neutral["lower_show"], "aa_lower_teeth_mm": get("viseme_aa", "lower_show"),
        "ff_lip_to_incisor_mm": get("viseme_FF", "ff_dist"),
        "inverted_max": max(r[0]["inverted"] for r in rows.values()) if rows else 0,
    }
    text = " ".join(f"{k}={v:.2f}" if isinstance(v, float) else f"{k}={v}" for k, v in fields.items())
    return f"RESULT head={label.replace(' ', '_')} {text}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blend", help="audit every face rig object in this .blend (needs bpy)")
    parser.add_argument("--rig", help="audit a rig saved by the engine (.npz)")
    parser.add_argument("--fit", nargs="+", help="fit these head meshes (.npz with vertices, faces) and audit them")
    parser.add_argument("--save-rig", help="with --fit: save each fitted rig (.npz) into this folder")
    parser.add_argument("--resolution", default="default", help="default head resolution (default | 10k)")
    parser.add_argument("--names", help="comma-separated subset of shape names")
    parser.add_argument("--json", help="write every figure to this JSON file")
    args = parser.parse_args(argv)
    expressions = _expressions()
    names = args.names.split(",") if args.names else None
    dump = {}
    for label, rig in _rigs(args):
        started = time.perf_counter()
        report = audit_shapes(rig, expressions, names)
        neutral = report["neutral"]
        print(f"== {label}: {len(report['rows'])} shapes in {time.perf_counter() - started:.0f} s")
        print(f"neutral: lid gap L/R {neutral['gap_L']:.1f}/{neutral['gap_R']:.1f} mm, lip gap "
              f"{neutral['lip_gap']:.1f} mm, teeth shown upper/lower {neutral['upper_show']:.1f}/"
              f"{neutral['lower_show']:.1f} mm, mouth width {neutral['width']:.1f} mm, incisal "
              f"{neutral['incisal']:.1f} mm  {'; '.join(report['neutral_failed']) or 'ok'}")
        for name, (m, failed) in report["rows"].items():
            print(_row(name, m, neutral, failed))
        print(_result(label, report))
        dump[label] = {"neutral": {k: v for k, v in neutral.items() if k != "_disp"},
                       "shapes": {n: {"figures": {k: v for k, v in m.items() if k != "_disp"}, "failed": f}
                                  for n, (m, f) in report["rows"].items()}}
    if args.json:
        Path(args.json).write_text(json.dumps(dump, indent=1, default=float))
    return 0


if __name__ == "__main__":
    np.seterr(all="ignore")
    sys.exit(main())
