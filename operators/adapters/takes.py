# SPDX-License-Identifier: GPL-3.0-or-later
"""A take (``anim.take.Take``) kept on a rig object, and the take a bake starts from.

Data flows one way: a take is built in the engine and written into Blender once (F-curves on the layer
properties, ``speech.apply``); the same engine object is stored beside them (:func:`store_take`, its bytes)
with a fingerprint of every layer's F-curves as written. A bake (:func:`take_for_bake`) starts from that
object, never from the F-curves, unless the artist changed a layer since: then the N-panel's state is what
the artist wants, and that layer alone is filled from its F-curves (sampled at every frame of the scene's
range, exactly as playing the scene shows it). A rig with no stored take (keyed by hand) gets a take made of
its layer F-curves, so every bake starts from a :class:`Take`.
"""
from __future__ import annotations

import hashlib
import json

import numpy as np

from ...faces_hands_addon.anim.layers import BASE_LAYER, LAYERS
from ...faces_hands_addon.anim.take import Take
from ...faces_hands_addon.anim.tracks import Track, TrackSet
from ...faces_hands_addon.core.errors import UserError
from . import controls, fcurves
from .shape_keys import frame_range
from .timing import scene_fps
from ...names import TAKE, TAKE_STAMP
from ...names import layer_prefix as names_layer_prefix

__all__ = ["TAKE_PROPERTY", "TAKE_STAMP_PROPERTY", "store_take", "stored_take", "remove_take", "take_for_bake"]

TAKE_PROPERTY, TAKE_STAMP_PROPERTY = TAKE, TAKE_STAMP


def _layer_fingerprint(obj, scene, layer: str) -> str:
    """A digest of everything that decides what ``layer`` shows when the scene plays: its F-curves (keys,
    handles, interpolation, mute, modifiers, extrapolation), the values of its unkeyed properties, and
    whether the curves can be read directly (no NLA, drivers or blending)."""
    digest = hashlib.sha256()
    prefix = controls.layer_prefix(layer)
    bag = fcurves.existing_channelbag(obj)
    keyed = set()
    for curve in sorted((c for c in (bag.fcurves if bag else []) if c.data_path.startswith(prefix)),
                        key=lambda c: (c.data_path, c.array_index)):
        keyed.add(curve.data_path)
        count = len(curve.keyframe_points)
        points = np.empty(count * 6, np.float32)
        for attribute, offset in (("co", 0), ("handle_left", 2), ("handle_right", 4)):
            part = np.empty(count * 2, np.float32)
            curve.keyframe_points.foreach_get(attribute, part)
            points.reshape(count, 6)[:, offset:offset + 2] = part.reshape(count, 2)
        kinds = "".join(f"{k.interpolation}{k.easing}" for k in curve.keyframe_points)
        digest.update(f"{curve.data_path}|{curve.mute}|{len(curve.modifiers)}|{curve.extrapolation}|{kinds}".encode())
        digest.update(points.tobytes())
    for key in sorted(k for k in obj.keys() if k.startswith(names_layer_prefix(layer))):
        if controls.data_path(key.split(".", 2)[2], layer) not in keyed:
            digest.update(f"{key}={float(obj[key])!r}".encode())
    digest.update(str(controls.curves_evaluate_exactly(obj, scene)).encode())
    return digest.hexdigest()[:32]


def store_take(obj, take: Take, scene, start_frame: int) -> None:
    """Keep ``take`` on ``obj`` as it was just written, starting at ``start_frame`` (call after the curves
    are written: the fingerprints say what was written)."""
    remove_take(obj)
    obj[TAKE_PROPERTY] = take.to_bytes()
    obj[TAKE_STAMP_PROPERTY] = json.dumps({
        "start_frame": int(start_frame), "fps": scene_fps(scene),
        "layers": {layer: _layer_fingerprint(obj, scene, layer) for layer in LAYERS}}, sort_keys=True)


def remove_take(obj) -> None:
    for name in (TAKE_PROPERTY, TAKE_STAMP_PROPERTY):
        if name in obj.keys():
            del obj[name]


def stored_take(obj) -> tuple[Take, dict] | None:
    """The take stored on ``obj`` and its stamp, or None."""
    if TAKE_PROPERTY not in obj.keys() or TAKE_STAMP_PROPERTY not in obj.keys():
        return None
    try:
        stamp = json.loads(obj[TAKE_STAMP_PROPERTY])
        int(stamp["start_frame"]), float(stamp["fps"]), dict(stamp["layers"])
    except (ValueError, TypeError, KeyError):
        raise UserError(f"'{obj.name}': the stored take's stamp is damaged; put the take on the rig again") from None
    return Take.from_bytes(bytes(obj[TAKE_PROPERTY])), stamp


def _sampled_layer(obj, scene, specs, layer: str, frames: np.ndarray, start_frame: int) -> TrackSet:
    """``layer`` as the scene plays it, one key per frame of ``frames`` (controls that never leave their
    default in this layer are left out)."""
    table = controls.sample_layers(obj, scene, specs, frames, layers=(layer,))
    times = (frames - float(start_frame)) / scene_fps(scene)
    tracks = TrackSet()
    for column, control in enumerate(table.controls):
        values = table.values[layer][:, column]
        resting = specs[control].default if layer == BASE_LAYER else 0.0
        if np.any(values != resting):
            tracks.add(Track(control, times, values))
    return tracks


def take_for_bake(obj, scene, specs) -> tuple[Take, int]:
    """The take a bake of ``obj`` starts from, and the scene frame of its time 0 (module docstring)."""
    frames = np.asarray(frame_range(scene), np.int64)
    found = stored_take(obj)
    fps = scene_fps(scene)
    if found is None or abs(float(found[1]["fps"]) - fps) > 1e-9:
        start = int(scene.frame_start) if found is None else int(found[1]["start_frame"])
        duration = max(float(frames[-1] - start) / fps, 0.0) if len(frames) else 0.0
        base = found[0] if found is not None else Take({}, duration)
        layers = {layer: _sampled_layer(obj, scene, specs, layer, frames, start) for layer in LAYERS}
        return Take(layers, base.duration, base.head, base.closures, base.owned), start
    take, stamp = found
    start = int(stamp["start_frame"])
    for layer in LAYERS:
        if _layer_fingerprint(obj, scene, layer) != stamp["layers"].get(layer):
            take = take.with_layer(layer, _sampled_layer(obj, scene, specs, layer, frames, start))
    return take, start
