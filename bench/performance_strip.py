# SPDX-License-Identifier: GPL-3.0-or-later
"""A frame strip of the thesis' example (4.3.5, Fig. 4.7 bottom row) as three.js draws the shipped GLB.

``./fh speak --text "Hi! ;-) Can you show me the way to the conference hall? :-)" --style neutral --seed 0``
writes the engine-ready weights GLB; headless chromium plays it with three.js and renders, at each time of
the strip, a front close-up of the upper face and a side view of the head. The first cell is the reference:
the frame where the planned head raise on the word starts (its preceding pitch minimum). Its brow line (the
top edge of the painted brows, found as dark pixels) is drawn in red on every front cell, and its side
silhouette in red on every side cell, so the brow and head rise can be seen against it. Measured in the
pictures, independently of the engine's numbers: the brow line's median rise in pixels (converted to mm at
the brows' depth) and the side silhouette's shift at the forehead.

Needs ``make bench-client`` and ``make install``. ``--out DIR`` keeps the strip PNG (default: a temporary
folder, printed). ``--glb FILE`` uses an existing file of the same text and seed. Last line: ``RESULT ...``.
"""
from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import performance_client as performance  # noqa: E402  (imports the installed extension first)
import gltf_client as client  # noqa: E402
import bpy  # noqa: E402
import numpy as np  # noqa: E402

FOV_DEG = 20.0
FRONT_DISTANCE = 0.62      # m: the front panel shows about 220 mm: the whole face
SIDE_DISTANCE = 0.75
CELL = (900, 450)          # one time step: front | side, each 450 x 450 px
DARK_FRACTION = 0.45       # brow pixels: darker than this fraction of the skin's median grey


def read_png(path: Path) -> np.ndarray:
    image = bpy.data.images.load(str(path))
    width, height = image.size
    pixels = np.asarray(image.pixels[:], np.float32).reshape(height, width, 4)[::-1, :, :3]
    bpy.data.images.remove(image)
    return pixels


def write_png(path: Path, pixels: np.ndarray) -> None:
    height, width = pixels.shape[:2]
    image = bpy.data.images.new("fh-strip", width, height, alpha=True)
    rgba = np.ones((height, width, 4), np.float32)
    rgba[..., :3] = pixels
    image.pixels.foreach_set(rgba[::-1].ravel())
    image.filepath_raw = str(path)
    image.file_format = "PNG"
    image.save()
    bpy.data.images.remove(image)


def brow_line(front: np.ndarray) -> np.ndarray:
    """Per column: the row of the brows' top edge (NaN where no brow), in the upper half of the panel."""
    grey = front.mean(axis=2)[: front.shape[0] // 2]
    skin = np.median(grey[grey > 0.3]) if (grey > 0.3).any() else 1.0
    dark = grey < DARK_FRACTION * skin
    rows = np.where(dark.any(axis=0), np.argmax(dark, axis=0), -1).astype(float)
    rows[rows < 0] = np.nan
    return rows


def silhouette(side: np.ndarray, background: np.ndarray) -> np.ndarray:
    """Per row: the column of the head's front-most edge in the side panel (the face looks left)."""
    differs = np.abs(side - background).sum(axis=2) > 0.06
    cols = np.where(differs.any(axis=1), np.argmax(differs, axis=1), -1).astype(float)
    cols[cols < 0] = np.nan
    return cols


def draw(panel: np.ndarray, rows: np.ndarray | None = None, cols: np.ndarray | None = None) -> None:
    red = np.array([1.0, 0.1, 0.1], np.float32)
    if rows is not None:
        for x, y in enumerate(rows):
            if np.isfinite(y):
                panel[max(int(y) - 1, 0): int(y) + 1, x] = red
    if cols is not None:
        for y, x in enumerate(cols):
            if np.isfinite(x):
                panel[y, max(int(x) - 1, 0): int(x) + 1] = red


def strip_times(utterance, events, word: str) -> tuple[float, list[float], tuple[float, float]]:
    span = performance.word_span(utterance, word)
    raises = [e for e in events if e.kind == "head_raise" and e.start < span[1] and e.end > span[0]]
    reference = raises[0].start if raises else max(span[0] - 0.3, 0.0)
    times = list(np.round(np.linspace(span[0] - 0.1, span[1] + 0.2, 7), 3))
    return reference, times, span


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--glb", type=Path)
    parser.add_argument("--out", type=Path, help="folder for the strip PNG")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--word", default="conference")
    parser.add_argument("--times", help="comma-separated times (s) instead of the word's span; the first is "
                                        "the reference frame")
    args = parser.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="fh-strip-"))
    out.mkdir(parents=True, exist_ok=True)
    utterance, events = performance.planned(args.seed, performance.TEXT)
    reference, times, span = strip_times(utterance, events, args.word)
    if args.times:
        reference, *times = (float(t) for t in args.times.split(","))
        span = (times[0], times[-1])
    with tempfile.TemporaryDirectory(prefix="fh-strip-work-") as tmp:
        path = args.glb or Path(tmp) / "performance.glb"
        if args.glb is None:
            performance.speak(path, args.seed)
        glb = client.Glb(path)
        skin = client.Skin(glb)
        picked = performance.picked_vertices(skin)
        brows = skin.rest(np.array([v for k, v in picked.items() if k.startswith("brow")]))
        head = skin.rest(np.arange(len(skin.base))).mean(axis=0)
        target = np.array([head[0], (brows[:, 1].mean() + head[1]) / 2 - 0.02, brows[:, 2].mean()])
        views = [{"yaw": 0.0, "target": target.tolist(), "distance": FRONT_DISTANCE, "fov": FOV_DEG},
                 {"yaw": math.pi / 2, "target": head.tolist(), "distance": SIDE_DISTANCE, "fov": FOV_DEG}]
        all_times = [reference] + times
        shots = [{"time": t, "png": str(Path(tmp) / f"shot{i}.png"), "views": views} for i, t in enumerate(all_times)]
        got = client.play(path, skin, glb.gltf["animations"][0]["name"], np.array([0.0]), np.array([0]), [],
                          influences=False, views_shots=shots, size=CELL)
        cells = [read_png(Path(s["png"])) for s in shots]
    half = CELL[0] // 2
    background = cells[0][2, 2].copy()
    ref_rows = brow_line(cells[0][:, :half])
    ref_cols = silhouette(cells[0][:, half:], background)
    metres_per_px = 2 * FRONT_DISTANCE * math.tan(math.radians(FOV_DEG) / 2) / CELL[1]
    side_m_per_px = 2 * SIDE_DISTANCE * math.tan(math.radians(FOV_DEG) / 2) / CELL[1]
    forehead = slice(int(CELL[1] * 0.2), int(CELL[1] * 0.35))
    print(f"file {path.name}; three.js r{got['info']['revision']}; '{args.word}' {span[0]:.2f}-{span[1]:.2f} s; "
          f"reference frame {reference:.2f} s (start of the planned head raise)")
    print(f"  {'time s':>7s} {'brow rise mm':>12s} {'forehead shift mm':>17s}")
    rises, shifts = [], []
    for t, cell in zip(all_times, cells):
        rows = brow_line(cell[:, :half])
        cols = silhouette(cell[:, half:], background)
        both = np.isfinite(rows) & np.isfinite(ref_rows)
        rise = float(np.median(ref_rows[both] - rows[both])) * metres_per_px * 1000 if both.any() else float("nan")
        shift = float(np.nanmedian(ref_cols[forehead] - cols[forehead])) * side_m_per_px * 1000   # + forward
        rises.append(rise)
        shifts.append(shift)
        print(f"  {t:7.2f} {rise:12.2f} {shift:17.2f}")
        draw(cell[:, :half], rows=ref_rows)
        draw(cell[:, half:], cols=ref_cols)
    strip = np.concatenate([np.concatenate(cells[i:i + 2], axis=1) if i + 1 < len(cells)
                            else np.concatenate([cells[i], np.zeros_like(cells[i])], axis=1)
                            for i in range(0, len(cells), 2)], axis=0)
    png = out / f"strip_{'times' if args.times else args.word}.png"
    write_png(png, strip)
    print(f"wrote {png} (cells in rows of two, left to right: reference, then {', '.join(f'{t:.2f}' for t in times)} s)")
    print(f"RESULT word={args.word} brow_rise_px_mm_max={np.nanmax(rises):.2f} "
          f"forehead_shift_mm_max={np.nanmax(np.abs(shifts)):.2f} cells={len(cells)}")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except client.Failure as error:
        print(f"performance_strip: {error}", file=sys.stderr)
        sys.exit(1)
