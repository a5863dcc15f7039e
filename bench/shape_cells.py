# SPDX-License-Identifier: GPL-3.0-or-later
"""Full-resolution contact-sheet cells of the shapes the audit (``bench/shapes.py``) measures, for looking
at: issue 10's acceptance list (neutral, brows up/down, blink, smile, frown, funnel, pucker, cheekPuff,
jawOpen, the visemes PP, FF, E, aa, ou and the seven named emotions; ``--names`` for others), front and
side, one PNG per view. Runs the installed extension inside the bpy module (``make install``).

Run: ``.venv/bin/python bench/shape_cells.py --out-dir DIR [--size 700x800] [--blend RIG.blend | --rig RIG.npz]``.
``--rig`` takes a rig saved by the engine (a fitted one, e.g. ``bench/shapes.py --fit HEAD.npz --save-rig DIR``:
the very rig that was audited); its mesh is shown turned into head space (Z up, face along -Y), whatever
the mesh's own axes.
"""
from __future__ import annotations

import argparse
import importlib
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _harness  # noqa: E402

import bpy  # noqa: E402

CELLS = ("neutral", "browInnerUp", "browOuterUpLeft", "browDownLeft", "eyeBlinkLeft", "mouthSmileLeft",
         "mouthFrownLeft", "mouthFunnel", "mouthPucker", "cheekPuff", "jawOpen", "viseme_PP", "viseme_FF", "viseme_E",
         "viseme_aa", "viseme_ou", "smile", "frown", "surprise", "sadness", "anger", "disgust", "fear")


def _saved_rig_object(ext, services, path: str):
    """A new empty file with the rig saved at ``path``: its mesh as an object placed in head space (the
    inverse of the rig's ``head_to_mesh``), the rig attached to it."""
    import numpy as np
    from mathutils import Matrix
    load_rig = importlib.import_module(f"{ext.__name__}.faces_hands_addon.core.rig").load_rig
    rig = load_rig(path)
    bpy.ops.wm.read_homefile(use_empty=True)
    mesh = bpy.data.meshes.new("head")
    mesh.from_pydata(np.asarray(rig.rest_positions, float).tolist(), [], np.asarray(rig.faces).tolist())
    head = bpy.data.objects.new(Path(path).stem, mesh)
    bpy.context.scene.collection.objects.link(head)
    head.matrix_world = Matrix(np.linalg.inv(np.asarray(getattr(rig, "head_to_mesh", np.eye(4)), float)).tolist())
    return services.attach_fitted_rig(bpy.context, head, rig, np.eye(4))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out-dir", required=True)
    parser.add_argument("--size", default="700x800")
    parser.add_argument("--names", help="expression names, emotion words (Table 4.4) or activation,evaluation "
                                           "points, separated by ';' (default: the audit's picks)")
    parser.add_argument("--blend", help="a .blend with a face rig (default: the default head)")
    parser.add_argument("--rig", help="a face rig saved by the engine (.npz), e.g. a fitted head")
    parser.add_argument("--columns", type=int, default=6)
    parser.add_argument("--prefix", default="cells")
    args = parser.parse_args()
    ext = _harness.EXTENSION
    services = importlib.import_module(f"{ext.__name__}.operators.face.services")
    sheet = importlib.import_module(f"{ext.__name__}.operators.face.sheet")
    expressions = {}
    for name in ("arkit", "visemes", "named"):
        expressions.update(services.expressions(name))
    obj = (_saved_rig_object(ext, services, args.rig) if args.rig else
           services.rig_object(args.blend) if args.blend else services.build_default_rig_object())
    names = args.names.split(";") if args.names else CELLS
    emotion = importlib.import_module(f"{ext.__name__}.faces_hands_addon.emotion")
    # a name that is no expression preset is an emotion word of Table 4.4 (its 4.4.3 expression) or "a,e"
    cells = [(n, {} if n == "neutral" else expressions[n] if n in expressions else
              emotion.expression_for(n if "," not in n else [float(v) for v in n.split(",")]))
             for n in names]
    width, height = (int(v) for v in args.size.split("x"))
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    for view in ("front", "side"):
        path = out / f"{args.prefix}_{view}.png"
        sheet.render_sheet(bpy.context, obj, cells, path, cell_size=(width, height), columns=args.columns,
                           view=view)
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
