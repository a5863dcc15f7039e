# SPDX-License-Identifier: GPL-3.0-or-later
"""A take: one performance as plain data, from the text or the audio to the exported file.

Data flows one way (presets + input -> engine -> Blender): a take is built in the engine (``performance.
take_of``: speech, behaviour and emotion composed, thesis 4.3.5 and 4.4), written into Blender once (the
artist's F-curves and a sound strip), and handed to the bakes as this object, never read back from the
F-curves to be computed again. When the artist edits a layer's keys in Blender, the UI fills the same
object from those F-curves (a layer sampled at every frame), so a bake always starts from a :class:`Take`.

* ``layers``: control tracks per layer (``speech``, ``behavior``, ``emotion``; ``ctrl`` only when the
  artist's own keys were sampled), times in seconds from the take's start;
* ``head``: the head's rotation (``head.pitch/yaw/roll``, radians);
* ``closures``: the lip closures (3.1.3: /p b/ closure phase, /m/) with the viseme that shows them;
* ``owned``: the closure-phase articulations (/p b m f v/) and the controls speech owns during them
  (``performance.priority``): a bake explains the other layers there without those controls.

:meth:`Take.table` samples it at a scene's frames into the :class:`.layers.LayerTable` a bake walks.
"""
from __future__ import annotations

import io
import json
import zipfile
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from ..core.controls import ControlSpec
from ..core.errors import UserError
from .layers import BASE_LAYER, LAYERS, LayerTable
from .tracks import Track, TrackSet

__all__ = ["Span", "Take", "TAKE_FORMAT", "MAX_TAKE_BYTES"]

TAKE_FORMAT = "faces_hands.take/1"
#: a stored take that unpacks to more than this is refused (a 10-minute take is ~30 MB)
MAX_TAKE_BYTES = 400_000_000


@dataclass(frozen=True)
class Span:
    """An interval of a take (seconds from its start) and what happens in it (a viseme, an articulation)."""
    start: float
    end: float
    label: str


@dataclass
class Take:
    """One performance as plain data (module docstring)."""
    layers: dict[str, TrackSet]
    duration: float
    head: TrackSet = field(default_factory=TrackSet)
    closures: tuple[Span, ...] = ()
    owned: tuple[tuple[Span, frozenset], ...] = ()

    def __post_init__(self) -> None:
        unknown = [name for name in self.layers if name not in LAYERS]
        if unknown:
            raise UserError(f"unknown control layer {unknown[0]!r} in a take; use {', '.join(LAYERS)}")
        if not np.isfinite(self.duration) or self.duration < 0:
            raise UserError(f"a take's duration must be a finite number of seconds, not {self.duration!r}")

    # -- what a bake reads --------------------------------------------------------------------------
    def table(self, specs: Mapping[str, ControlSpec], frames, fps: float, start_frame: float = 0.0,
              lead: float = 0.0) -> LayerTable:
        """Every layer of every control of ``specs`` at the scene ``frames`` (time 0 of the take at
        ``start_frame``, ``fps`` frames per second); ``lead`` frames ahead (a simulation fed ahead shows
        its targets on time). A control without a track holds its default in ``ctrl`` and 0 elsewhere.
        The values are the tracks' own (no clamping: the layers' mix clamps once, ``layers.mix``)."""
        frames = np.asarray(list(frames), np.int64)
        times = (frames.astype(np.float64) + float(lead) - float(start_frame)) / float(fps)
        controls = tuple(specs)
        values = {}
        for layer in LAYERS:
            tracks = self.layers.get(layer, TrackSet())
            table = np.empty((len(frames), len(controls)))
            for column, control in enumerate(controls):
                if control in tracks:
                    table[:, column] = tracks[control].sample(times)
                else:
                    table[:, column] = specs[control].default if layer == BASE_LAYER else 0.0
            values[layer] = table
        return LayerTable(frames, controls, values)

    def animated(self) -> bool:
        """Does any layer change over the take (a still face bakes a take of nothing)?"""
        return any(len(track) > 1 and np.ptp(track.values) > 0 for tracks in self.layers.values() for track in tracks)

    def closure_frames(self, fps: float, start_frame: float = 0.0) -> list[tuple[float, float, str]]:
        """The closures in scene frames: (start frame, end frame, viseme)."""
        return [(start_frame + s.start * fps, start_frame + s.end * fps, s.label) for s in self.closures]

    def owned_rows(self, frames, fps: float, start_frame: float = 0.0) -> dict[int, frozenset]:
        """Row of ``frames`` -> the controls speech owns there (rows inside an owned articulation)."""
        frames = np.asarray(list(frames), np.float64)
        out: dict[int, frozenset] = {}
        for span, controls in self.owned:
            a, b = start_frame + span.start * fps, start_frame + span.end * fps
            for row in np.flatnonzero((frames >= a) & (frames <= b)):
                out[int(row)] = out.get(int(row), frozenset()) | frozenset(controls)
        return out

    def with_layer(self, layer: str, tracks: TrackSet) -> "Take":
        """The same take with ``layer`` replaced (the artist's edited keys, sampled)."""
        layers = dict(self.layers)
        layers[layer] = tracks
        return Take(layers, self.duration, self.head, self.closures, self.owned)

    # -- storage (no pickles; the same take gives the same bytes) -------------------------------------
    def to_bytes(self) -> bytes:
        meta = {"format": TAKE_FORMAT, "duration": float(self.duration),
                "layers": {name: list(tracks.names) for name, tracks in self.layers.items()},
                "head": list(self.head.names),
                "closures": [[s.start, s.end, s.label] for s in self.closures],
                "owned": [[s.start, s.end, s.label, sorted(c)] for s, c in self.owned]}
        arrays = {}
        for name, tracks in (*sorted(self.layers.items()), ("head", self.head)):
            for k, track in enumerate(tracks):
                arrays[f"{name}.{k}"] = np.stack([track.times, track.values])
        buffer = io.BytesIO()
        with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED) as archive:
            entries = {"meta": json.dumps(meta, sort_keys=True).encode("utf-8")}
            entries.update({key: _npy(value) for key, value in arrays.items()})
            for key, data in entries.items():
                info = zipfile.ZipInfo(key, date_time=(1980, 1, 1, 0, 0, 0))
                info.compress_type = zipfile.ZIP_DEFLATED
                archive.writestr(info, data)
        return buffer.getvalue()

    @classmethod
    def from_bytes(cls, data: bytes) -> "Take":
        try:
            with zipfile.ZipFile(io.BytesIO(bytes(data))) as archive:
                if sum(i.file_size for i in archive.infolist()) > MAX_TAKE_BYTES:
                    raise UserError("the stored take is too large; it is damaged")
                meta = json.loads(archive.read("meta"))
                if meta.get("format") != TAKE_FORMAT:
                    raise UserError(f"not a stored take (format {meta.get('format')!r})")

                def tracks(name: str, names: list) -> TrackSet:
                    out = TrackSet()
                    for k, control in enumerate(names):
                        times, values = np.load(io.BytesIO(archive.read(f"{name}.{k}")), allow_pickle=False)
                        out.add(Track(str(control), times, values))
                    return out
                layers = {str(n): tracks(n, names) for n, names in sorted(meta["layers"].items())}
                head = tracks("head", meta["head"])
            closures = tuple(Span(float(a), float(b), str(v)) for a, b, v in meta["closures"])
            owned = tuple((Span(float(a), float(b), str(v)), frozenset(map(str, c))) for a, b, v, c in meta["owned"])
            return cls(layers, float(meta["duration"]), head, closures, owned)
        except (KeyError, ValueError, TypeError, OSError, zipfile.BadZipFile) as error:
            raise UserError(f"the stored take cannot be read ({error}); put the take on the rig again") from None


def _npy(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.lib.format.write_array(buffer, np.ascontiguousarray(array, np.float64), allow_pickle=False)
    return buffer.getvalue()
