# SPDX-License-Identifier: GPL-3.0-or-later
"""Free phone recognition (pocketsphinx's phone loop), in this process or in a second one beside it.

A checked alignment of recorded speech (3.1.3 phones and durations from a recording) needs two decodes
that do not depend on the transcript: the phone loop the word confidences are measured against, and
phone recognition for words the transcript lacks. pocketsphinx holds Python's global lock while it
decodes, so a thread cannot run them beside the forced alignment; :class:`PhoneLoops` runs them in a child
process of the same interpreter (``sys.executable``: Blender's own Python in Blender, the venv's with the
``bpy`` module) while the parent aligns, and hands each result over when it is needed. The child runs
this file alone (it imports nothing from the package) and decodes exactly as :func:`decode` does here,
so the results are the same bytes either way; when the child cannot start, fails or stalls, the parent
decodes the rest itself.
"""
from __future__ import annotations

import json
import queue
import subprocess
import sys
import threading
from pathlib import Path

__all__ = ["free_phone_decoder", "segments", "decode", "PhoneLoops"]

#: the child gets this long (s) per second of audio, and at least CHILD_MIN_S, before the parent decodes itself
CHILD_SECONDS_PER_AUDIO_SECOND = 2.0
CHILD_MIN_S = 30.0


def free_phone_decoder(ps, **options):
    """pocketsphinx's phone loop with the bundled en-us phone model, all senones computed."""
    return ps.Decoder(allphone=ps.get_model_path("en-us/en-us-phone.lm.bin"), lm=None, loglevel="FATAL",
                      compallsen=True, **options)


def segments(decoder) -> list[tuple[str, int, int, float]]:
    """A decoder's path: (word or phone, first frame, last frame, acoustic score in log units)."""
    logmath = decoder.get_logmath()
    return [(seg.word, seg.start_frame, seg.end_frame, float(logmath.log(max(seg.ascore, 1e-300))))
            for seg in decoder.seg()]


def decode(ps, pcm: bytes, **options) -> list[tuple[str, int, int, float]]:
    """Free phone recognition of 16 kHz mono int16 ``pcm``: the phone loop's path (:func:`segments`)."""
    decoder = free_phone_decoder(ps, **options)
    decoder.start_utt()
    decoder.process_raw(pcm, full_utt=True)
    decoder.end_utt()
    return segments(decoder)


class PhoneLoops:
    """Free phone decodes of ``pcm``, one per option dict of ``runs``, started in a child process.

    ``result(k)`` returns run ``k``'s path (from the child, or decoded here when the child is unusable);
    ``close()`` stops the child. Use as a context manager."""

    def __init__(self, ps, pcm: bytes, runs: list[dict], in_child: bool = True) -> None:
        self._ps, self._pcm, self._runs = ps, pcm, [dict(r) for r in runs]
        self._results: dict[int, list] = {}
        self._lines: queue.Queue = queue.Queue()
        self._timeout = max(CHILD_MIN_S, CHILD_SECONDS_PER_AUDIO_SECOND * len(pcm) / 32000)
        self._child = self._start() if in_child else None

    def _start(self):
        header = {"paths": [str(Path(self._ps.__file__).resolve().parents[1])], "runs": self._runs,
                  "bytes": len(self._pcm)}
        try:
            child = subprocess.Popen([sys.executable, "-I", str(Path(__file__).resolve())], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
            child.stdin.write(json.dumps(header).encode() + b"\n" + self._pcm)
            child.stdin.close()
        except (OSError, ValueError):
            return None
        threading.Thread(target=self._read, args=(child.stdout,), daemon=True).start()
        return child

    def _read(self, stream) -> None:
        for line in stream:
            self._lines.put(line)
        self._lines.put(None)

    def result(self, index: int) -> list[tuple[str, int, int, float]]:
        while index not in self._results and self._child is not None:
            try:
                line = self._lines.get(timeout=self._timeout)
                path = [tuple(seg) for seg in json.loads(line)] if line is not None else None
            except (queue.Empty, ValueError):
                path = None
            if path is None:
                self.close()
                break
            self._results[len(self._results)] = path
        if index not in self._results:
            self._results[index] = decode(self._ps, self._pcm, **self._runs[index])
        return self._results[index]

    def close(self) -> None:
        if self._child is not None:
            if self._child.poll() is None:
                self._child.kill()
            self._child.wait()
            self._child.stdout.close()
            self._child = None

    def __enter__(self) -> "PhoneLoops":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _child_main() -> None:
    """In the child: read the header line and the audio, decode every run, one JSON line per path."""
    header = json.loads(sys.stdin.buffer.readline())
    pcm = sys.stdin.buffer.read(header["bytes"])
    sys.path[:0] = header["paths"]
    import pocketsphinx  # noqa: PLC0415 - the wheel's folder is known only now
    for options in header["runs"]:
        sys.stdout.write(json.dumps(decode(pocketsphinx, pcm, **options)) + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    _child_main()
