# SPDX-License-Identifier: GPL-3.0-or-later
"""Weight animations of named shape keys in Blender: read the weights a bake wrote (``shape_keys.
commit_weights``), put them onto any character that has shape keys of those names (``anim.retarget``
matches the spellings), and write them as a Live Link Face CSV."""
from __future__ import annotations

import numpy as np

from ...faces_hands_addon.anim.retarget import ARKIT_NAMES, match_targets, write_live_link_csv
from ...faces_hands_addon.core.errors import UserError
from . import fcurves
from .outputs import atomic_output, check_output_path
from .poses import SIM_KEY
from .timing import scene_fps

__all__ = ["animated_weights", "keyed_weights", "transfer_weights", "write_live_link", "characters_with_targets"]

VALUE_PATH = 'key_blocks["{}"].value'


def animated_weights(obj, scene) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The frames of the scene's range and, per animated shape key of ``obj`` (not the simulation key, not
    per-frame cache keys), its weight at each frame; a UserError when none is animated."""
    key = getattr(obj.data, "shape_keys", None)
    bag = fcurves.existing_channelbag(key) if key is not None else None
    if bag is None:
        raise UserError(f"'{obj.name}' has no animated shape keys; bake its animation (as weights) first")
    frames = np.arange(scene.frame_start, scene.frame_end + 1, dtype=np.float64)
    weights = {}
    for curve in bag.fcurves:
        path = curve.data_path
        if not (path.startswith('key_blocks["') and path.endswith('"].value')) or curve.mute:
            continue
        name = path[len('key_blocks["'):-len('"].value')]
        if name == SIM_KEY or name.startswith("FH.frame_") or name not in key.key_blocks:
            continue
        weights[name] = np.array([curve.evaluate(float(f)) for f in frames])
    if not weights:
        raise UserError(f"'{obj.name}' has no weight animation; bake its animation (as weights) first")
    return frames, weights


def _weight_curves(obj) -> dict:
    key = getattr(getattr(obj, "data", None), "shape_keys", None)
    bag = fcurves.existing_channelbag(key) if key is not None else None
    out = {}
    for curve in (bag.fcurves if bag is not None else ()):
        path = curve.data_path
        if path.startswith('key_blocks["') and path.endswith('"].value') and not curve.mute:
            name = path[len('key_blocks["'):-len('"].value')]
            if name != SIM_KEY and not name.startswith("FH.frame_") and name in key.key_blocks:
                out[name] = curve
    return out


def keyed_weights(objects, fps: float) -> tuple[str, np.ndarray, dict[str, np.ndarray]]:
    """The take a file holds, read back: of ``objects`` (just imported) the mesh with the most animated
    shape keys, the times (s) of its keys (their frames at ``fps``, the rate the importer counted them in)
    and each key's weight there. A UserError when none is animated."""
    curves = {o.name: _weight_curves(o) for o in objects if o.type == "MESH"}
    name = max(curves, key=lambda n: len(curves[n]), default=None)
    if name is None or not curves[name]:
        raise UserError("the file has no mesh whose shape keys are animated; export the take with its weights")
    frames = np.unique(np.concatenate([[k.co[0] for k in c.keyframe_points] for c in curves[name].values()]))
    weights = {target: np.array([c.evaluate(float(f)) for f in frames]) for target, c in curves[name].items()}
    return name, (frames - frames[0]) / fps, weights


def characters_with_targets(objects, names) -> list:
    """The meshes among ``objects`` that have a shape key for at least one of ``names``."""
    found = []
    for obj in objects:
        key = getattr(getattr(obj, "data", None), "shape_keys", None)
        if obj.type == "MESH" and key is not None and match_targets(names, key.key_blocks.keys()):
            found.append(obj)
    return found


def transfer_weights(character, frames: np.ndarray, weights: dict[str, np.ndarray], offset: float = 0.0) -> dict:
    """Animate ``character``'s shape keys that play the named targets with their weights (replacing their
    curves; other curves and keys are untouched). Returns target name -> the character's key name."""
    key = getattr(character.data, "shape_keys", None)
    if key is None:
        raise UserError(f"'{character.name}' has no shape keys; it needs ARKit or viseme shape keys to play the take")
    matched = match_targets(weights, key.key_blocks.keys())
    if not matched:
        raise UserError(f"'{character.name}' has none of the take's targets ({', '.join(list(weights)[:4])}, ...) "
                        "as shape keys")
    curves = {VALUE_PATH.format(shape_key): (frames + offset, weights[name]) for name, shape_key in matched.items()}
    fcurves.remove_fcurves(key, tuple(curves))
    fcurves.write_curves(key, curves, action_name=f"{character.name} Weights", group="Weights")
    return matched


def write_live_link(obj, scene, path: str) -> str:
    """Write ``obj``'s ARKit weight animation as a Live Link Face CSV (52 columns + head/eye rotations)."""
    out = check_output_path(path, (".csv",))
    frames, weights = animated_weights(obj, scene)
    arkit = {name: weights[name] for name in ARKIT_NAMES if name in weights}
    if not arkit:
        raise UserError(f"'{obj.name}' animates none of the 52 ARKit shape keys; bake the animation as weights")
    fps = scene_fps(scene)
    with atomic_output(out) as tmp:
        write_live_link_csv(tmp, (frames - frames[0]) / fps, arkit, fps)
    return str(out)
