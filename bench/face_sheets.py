# SPDX-License-Identifier: GPL-3.0-or-later
"""Contact sheets of population heads, made the way a user makes them (issue 33's acceptance: the worst
held-out head's 67 shapes looked at full size, front and side; thesis 3.1.2 "Creating New Animatable Head
Models from the Template" is the fit they show).

For each named head of the population (``scripts/population_heads.py``; ``.npz`` with ``vertices``,
``faces`` and the ``spec`` JSON) the script writes the mesh as an OBJ in the head's own units and axes (the
file as the user has it, nothing normalised), fits it with ``./fh build-face --mesh HEAD.obj --out
HEAD.blend`` (orientation searched, as a user who does not know the axes gets it) and renders the sheet
twice, ``./fh render --blend HEAD.blend --view front|side``. The sheet's camera looks along Blender's +Y
with +Z up whatever the head's orientation, so before rendering the fitted head is turned, as a user turns
an imported head to look at it, until the face looks along -Y with the top of the head up (``HEAD_turned.blend``;
the object's transform only, from the spec's axes: the fit and its shapes are untouched);
``--as-imported`` renders the file as the fit left it. ``--default`` adds the default head
(``./fh render`` with no ``--blend``). Every run is a separate CLI process, one at a time; a refused fit is
reported (its message and the preview the CLI writes) and counted, not hidden.

The sheet holds neutral, every muscle at full contraction, the direct parameters, the 52 ARKit shapes and
the 15 visemes (``render``'s ``expressions`` sheet); ``--cells neutral,jawOpen,...`` renders a subset.

Run: ``python bench/face_sheets.py [--heads DIR] [--only h36,h19,h44] [--default] [--out DIR]
[--views front,side]``. Ends with ``RESULT heads=.. sheets=.. refused=.. seconds=..`` (wall clock on a
shared machine: noisy).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FH = ROOT / "fh"


def write_obj(npz: Path, out: Path) -> dict:
    """The head of ``npz`` as an OBJ, vertices as stored (the spec's units and axes); returns the spec."""
    data = np.load(npz)
    vertices, faces = data["vertices"].astype(np.float64), data["faces"].astype(np.int64)
    spec = json.loads(str(data["spec"])) if "spec" in data else {}
    lines = [f"# {npz.name}: units {spec.get('units', '?')}, forward {spec.get('forward', '?')}, "
             f"up {spec.get('up', '?')}\n"]
    lines += [f"v {x:.6g} {y:.6g} {z:.6g}\n" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in faces]
    out.write_text("".join(lines))
    return spec


def axis(name: str) -> np.ndarray:
    """'+Y', '-X', ... as a unit vector."""
    vector = np.zeros(3)
    vector["XYZ".index(name[1])] = -1.0 if name[0] == "-" else 1.0
    return vector


def turn_to_front(linear: np.ndarray, forward: str, up: str) -> np.ndarray:
    """The world rotation that takes a mesh whose face looks along ``forward`` and whose top points along
    ``up`` (the file's axes), placed by the object matrix ``linear`` (3x3), to a face looking along world -Y
    with the top along +Z (the sheet's camera)."""
    f, u = linear @ axis(forward), linear @ axis(up)
    f, u = f / np.linalg.norm(f), u / np.linalg.norm(u)
    source = np.column_stack([f, u, np.cross(f, u)])
    target = np.column_stack([[0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]])
    return target @ source.T


def face_front(blend: str, forward: str, up: str, out: str) -> int:
    """Child process: open ``blend``, turn every root object (the fitted head, its parts parented to it) so
    that the mesh's ``forward`` looks along world -Y and its ``up`` along +Z, save as ``out``."""
    sys.path.insert(0, str(ROOT / "bench"))
    import _harness  # noqa: F401 - the installed extension, enabled, before the file is read
    import bpy
    from mathutils import Matrix
    bpy.ops.wm.open_mainfile(filepath=blend)
    roots = [o for o in bpy.data.objects if o.parent is None and o.type == "MESH"]
    for obj in roots:
        turn = np.eye(4)
        turn[:3, :3] = turn_to_front(np.array(obj.matrix_world.to_3x3()), forward, up)
        obj.matrix_world = Matrix(turn.tolist()) @ obj.matrix_world
        angle = np.degrees(np.arccos(np.clip((np.trace(turn[:3, :3]) - 1) / 2, -1, 1)))
        print(f"{obj.name}: turned by {angle:.0f} deg")
    bpy.ops.wm.save_as_mainfile(filepath=out)
    return 0


def run(args: list[str], log, command: list[str] | None = None) -> tuple[int, float]:
    """One CLI process (niced: the machine is shared); its output appended to ``log``."""
    started = time.perf_counter()
    command = ["nice", "-n", "10", *(command or [str(FH)]), *args]
    log.write("$ " + " ".join(command) + "\n")
    log.flush()
    result = subprocess.run(command, stdout=log, stderr=subprocess.STDOUT, cwd=ROOT)
    seconds = time.perf_counter() - started
    log.write(f"# exit {result.returncode} after {seconds:.1f} s\n")
    log.flush()
    return result.returncode, seconds


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--heads", type=Path, default=ROOT / "out" / "population", help="folder of hNN.npz")
    parser.add_argument("--only", default="", help="comma-separated head names, e.g. h36,h19,h44")
    parser.add_argument("--default", action="store_true", help="also the default head (render with no --blend)")
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "face_sheets", help="folder for the sheets")
    parser.add_argument("--views", default="front,side", help="comma-separated: front, three-quarter, side")
    parser.add_argument("--cells", default="", help="render only these cells (render's --cells)")
    parser.add_argument("--columns", type=int, default=10)
    parser.add_argument("--as-imported", action="store_true",
                        help="render the fitted file as it is (the camera then sees the head as imported)")
    parser.add_argument("--reuse", action="store_true", help="keep a fitted HEAD.blend already in --out")
    parser.add_argument("--face-front", nargs=2, metavar=("BLEND", "OUT"), help=argparse.SUPPRESS)
    parser.add_argument("--forward", help=argparse.SUPPRESS)
    parser.add_argument("--up", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.face_front:
        code = face_front(args.face_front[0], args.forward, args.up, args.face_front[1])
        sys.stdout.flush()
        os._exit(code)                                 # skip bpy's slow interpreter teardown
    heads = [name.strip() for name in args.only.split(",") if name.strip()]
    views = [view.strip() for view in args.views.split(",") if view.strip()]
    args.out.mkdir(parents=True, exist_ok=True)
    extra = (["--cells", args.cells] if args.cells else []) + ["--columns", str(args.columns)]
    started = time.perf_counter()
    sheets, refused, done = 0, [], 0
    with open(args.out / "face_sheets.log", "a") as log:
        jobs = [(name, args.heads / f"{name}.npz") for name in heads] + ([("default", None)] if args.default else [])
        for name, npz in jobs:
            blend_args: list[str] = []
            if npz is not None:
                if not npz.exists():
                    print(f"{name}: no {npz}", file=sys.stderr)
                    refused.append(name)
                    continue
                obj, blend = args.out / f"{name}.obj", args.out / f"{name}.blend"
                if args.reuse and blend.exists():
                    spec, code, fit_s = json.loads(str(np.load(npz)["spec"])), 0, 0.0
                else:
                    spec = write_obj(npz, obj)
                    code, fit_s = run(["build-face", "--mesh", str(obj), "--out", str(blend)], log)
                    obj.unlink()                               # the npz is the source; keep the disk free
                print(f"{name}: {spec.get('base')} {spec.get('resolution')} {spec.get('crop')} {spec.get('units')} "
                      f"fwd {spec.get('forward')} up {spec.get('up')}: fit exit {code} in {fit_s:.0f} s", flush=True)
                if code != 0:
                    refused.append(name)
                    continue
                if not args.as_imported:
                    front = args.out / f"{name}_turned.blend"
                    turn = ["--face-front", str(blend), str(front), f"--forward={spec['forward']}",
                            f"--up={spec['up']}"]
                    code, _ = run(turn, log, [sys.executable, str(Path(__file__).resolve())])
                    if code != 0:
                        refused.append(name)
                        continue
                    blend = front
                blend_args = ["--blend", str(blend)]
            done += 1
            for view in views:
                png = args.out / f"{name}_{view}.png"
                code, render_s = run(["render", *blend_args, "--view", view, *extra, "--out", str(png)], log)
                print(f"{name}: {view} sheet exit {code} in {render_s:.0f} s -> {png}", flush=True)
                sheets += int(code == 0 and png.exists())
    seconds = time.perf_counter() - started
    if refused:
        print(f"refused or missing: {', '.join(refused)} (see {args.out / 'face_sheets.log'})")
    print(f"RESULT heads={done} sheets={sheets} refused={len(refused)} seconds={seconds:.0f}")
    return 0 if not refused else 1


if __name__ == "__main__":
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    sys.exit(main())
