# SPDX-License-Identifier: GPL-3.0-or-later
"""Animation tracks: one control's values over time, and named sets of them.

A :class:`Track` is a control name plus strictly increasing ``times`` (seconds from the start of the
utterance) and ``values``; between samples it is read linearly, outside its span it holds the first /
last value. A :class:`TrackSet` is an ordered ``name -> Track`` mapping.

Operators turn each track into one F-curve: key ``k`` goes to frame ``start_frame + times[k] * fps``
(:meth:`Track.frames`). Times need not fall on whole frames (the coarticulation adds key frames at the
start of lip closures, 3.1.3 "Closure and Release Phases"); :meth:`TrackSet.resample` puts everything
on the frame grid when an exporter wants exactly one key per frame.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, Iterator, Mapping

import numpy as np

from ..core.errors import UserError


def frame_times(fps: float, start: float, end: float) -> np.ndarray:
    """Times of the whole frames ``k / fps`` covering ``[start, end]`` (first frame at or before
    ``start``, last at or after ``end``)."""
    if not np.isfinite(fps) or fps <= 0:
        raise UserError(f"fps must be a positive number, not {fps!r}")
    first = np.floor(start * fps + 1e-9)
    last = np.ceil(end * fps - 1e-9)
    return np.arange(first, max(last, first) + 1) / fps


@dataclass(frozen=True)
class Track:
    """One control's animation: ``values[k]`` at ``times[k]`` seconds (linear in between)."""

    name: str
    times: np.ndarray
    values: np.ndarray

    def __post_init__(self) -> None:
        times = np.ascontiguousarray(self.times, dtype=np.float64).reshape(-1)
        values = np.ascontiguousarray(self.values, dtype=np.float64).reshape(-1)
        if times.shape != values.shape:
            raise UserError(f"track {self.name!r}: {times.size} times but {values.size} values")
        if times.size == 0:
            raise UserError(f"track {self.name!r} has no keys")
        if times.size > 1 and not np.all(np.diff(times) > 0):
            raise UserError(f"track {self.name!r}: times must be strictly increasing")
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(values))):
            raise UserError(f"track {self.name!r} contains NaN or infinite numbers")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "values", values)

    @property
    def start(self) -> float:
        return float(self.times[0])

    @property
    def end(self) -> float:
        return float(self.times[-1])

    def __len__(self) -> int:
        return int(self.times.size)

    def sample(self, times: np.ndarray | float) -> np.ndarray:
        """Values at arbitrary ``times`` (linear interpolation, held constant outside the track)."""
        return np.interp(np.asarray(times, dtype=np.float64), self.times, self.values)

    def resample(self, fps: float, start: float | None = None, end: float | None = None) -> "Track":
        """The track read at every whole frame ``k / fps`` from ``start`` to ``end``."""
        grid = frame_times(fps, self.start if start is None else start, self.end if end is None else end)
        return Track(self.name, grid, self.sample(grid))

    def shifted(self, seconds: float) -> "Track":
        return Track(self.name, self.times + seconds, self.values)

    def scaled(self, factor: float) -> "Track":
        return Track(self.name, self.times, self.values * factor)

    def clipped(self, low: float, high: float) -> "Track":
        return Track(self.name, self.times, np.clip(self.values, low, high))

    def frames(self, fps: float, start_frame: float = 0.0) -> np.ndarray:
        """Frame numbers of the keys for a scene at ``fps`` whose time 0 is ``start_frame``."""
        return start_frame + self.times * fps


@dataclass
class TrackSet:
    """Named tracks in insertion order. ``tracks[name]`` is a :class:`Track` whose ``name`` is ``name``."""

    tracks: dict[str, Track] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name, track in self.tracks.items():
            if name != track.name:
                raise UserError(f"track stored as {name!r} is named {track.name!r}")

    @classmethod
    def from_arrays(cls, times: np.ndarray, values: Mapping[str, np.ndarray] | np.ndarray,
                    names: Iterable[str] | None = None) -> "TrackSet":
        """Tracks sharing one time axis: ``values`` is ``{name: array}`` or a ``(len(names), T)`` array."""
        if isinstance(values, Mapping):
            return cls({n: Track(n, times, v) for n, v in values.items()})
        names = list(names or [])
        values = np.asarray(values)
        if values.ndim != 2 or values.shape[0] != len(names):
            raise UserError("from_arrays needs one row of values per name")
        return cls({n: Track(n, times, values[i]) for i, n in enumerate(names)})

    def __getitem__(self, name: str) -> Track:
        return self.tracks[name]

    def __contains__(self, name: object) -> bool:
        return name in self.tracks

    def __iter__(self) -> Iterator[Track]:
        return iter(self.tracks.values())

    def __len__(self) -> int:
        return len(self.tracks)

    @property
    def names(self) -> list[str]:
        return list(self.tracks)

    @property
    def start(self) -> float:
        return min((t.start for t in self), default=0.0)

    @property
    def end(self) -> float:
        return max((t.end for t in self), default=0.0)

    def add(self, track: Track) -> None:
        """Add or replace the track of that name."""
        self.tracks[track.name] = track

    def sample(self, times: np.ndarray) -> dict[str, np.ndarray]:
        return {t.name: t.sample(times) for t in self}

    def resample(self, fps: float) -> "TrackSet":
        """Every track on the same whole-frame grid spanning the whole set."""
        start, end = self.start, self.end
        return TrackSet({t.name: t.resample(fps, start, end) for t in self})

    def shifted(self, seconds: float) -> "TrackSet":
        return TrackSet({t.name: t.shifted(seconds) for t in self})

    def merged(self, other: "TrackSet", mode: str = "sum") -> "TrackSet":
        """Combine two sets. Tracks present in only one set are copied. For a name present in both,
        ``mode="sum"`` adds the two curves on the union of their key times (the thesis combines
        emotion and speech by summing muscle contractions, 4.3.5), ``mode="replace"`` keeps ``other``'s.
        """
        if mode not in ("sum", "replace"):
            raise UserError(f"merge mode must be 'sum' or 'replace', not {mode!r}")
        result = TrackSet(dict(self.tracks))
        for track in other:
            mine = result.tracks.get(track.name)
            if mine is None or mode == "replace":
                result.add(track)
                continue
            times = np.union1d(mine.times, track.times)
            result.add(Track(track.name, times, mine.sample(times) + track.sample(times)))
        return result

    def clipped(self, ranges: Mapping[str, tuple[float, float]]) -> "TrackSet":
        """Clip the named tracks to ``(low, high)``; tracks without a range are kept as they are."""
        return TrackSet({t.name: (t.clipped(*ranges[t.name]) if t.name in ranges else t) for t in self})
