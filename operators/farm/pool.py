# SPDX-License-Identifier: GPL-3.0-or-later
"""``--workers N``: N Blender processes take rows from one queue held by this process, which draws one
progress line and keeps the report.

Each worker runs ``jobs --serve`` and speaks JSON lines: rows come in on its standard input, one at a time;
it answers on its standard output, on lines marked ``FHJOB`` (Blender's own start-up lines on the same
stream are logged, not parsed), and everything else it prints goes to its log in ``.fh-farm/logs``.
The first row runs alone (every worker starts meanwhile): a cold shape cache is filled once, not by every
worker at the same time. Because a worker holds one row at a time, a worker that dies (killed, out of
memory, a crash in C) costs exactly that row: it is reported failed, its staging folder is removed, a new
worker takes its place, and a rerun of the manifest redoes the row. On an interrupt the workers are
stopped (SIGTERM: a row under way leaves its files as they were), the rows they finished meanwhile are
recorded, the rest reported as not run. No Blender API here: the pool only starts processes.
"""
from __future__ import annotations

import json
import os
import queue
import shutil
import subprocess
import sys
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

from ...faces_hands_addon.farm.report import RunReport, progress_line
from ...faces_hands_addon.farm.rows import FARM_FOLDER, JobRow
from ..adapters.outputs import note_written

__all__ = ["MARK", "Pool", "send", "ProgressLine"]

MARK = "FHJOB "
_STOP = json.dumps({"stop": True}) + "\n"


def send(stream, message: dict) -> None:
    """One protocol line from a worker to the pool."""
    stream.write(MARK + json.dumps(message) + "\n")
    stream.flush()


class ProgressLine:
    """One line on a terminal, redrawn in place; elsewhere (a log) a line every ``every`` seconds."""

    def __init__(self, quiet: bool = False, stream=None, every: float = 30.0):
        self.stream = stream or sys.stderr
        self.quiet, self.every = quiet, every
        self.tty = self.stream.isatty()
        self._last, self._rows = -1e9, ""

    def show(self, text: str, final: bool = False) -> None:
        """Redraw with ``text``; off a terminal, print it when its row counts changed (or ``every`` s)."""
        if self.quiet:
            return
        if self.tty:
            self.stream.write("\r" + text + "\x1b[K" + ("\n" if final else ""))
            self.stream.flush()
            return
        rows = text.split(" | ")[0]
        if final or rows != self._rows or time.monotonic() - self._last >= self.every:
            print(text, file=self.stream, flush=True)
            self._last, self._rows = time.monotonic(), rows


@dataclass
class _Worker:
    number: int
    process: subprocess.Popen
    log: object
    row: tuple | None = None
    staging: str = ""
    started: float = 0.0
    ready: bool = False
    reader: threading.Thread | None = None


@dataclass
class Pool:
    """``command``: the worker's command line; ``report``: filled in as rows finish."""
    command: list[str]
    workers: int
    out_dir: Path
    report: RunReport
    env: dict = field(default_factory=lambda: dict(os.environ))
    progress: ProgressLine = field(default_factory=ProgressLine)

    def __post_init__(self):
        self.events: queue.Queue = queue.Queue()
        self.running: dict[int, _Worker] = {}
        self.deaths = 0
        self.spawned = 0
        self.warm = False           # until a first row is over, one row at a time (the others would
                                    # settle the same target shapes at the same time)
        self.logs = self.out_dir / FARM_FOLDER / "logs"

    def run(self, todo: list[tuple[JobRow, str, dict]]) -> None:
        """Run every row of ``todo`` (row, key, inputs); on an interrupt the workers are stopped, the rows
        not finished are reported as not run, and the interrupt goes on."""
        self.pending = deque(todo)
        self.to_run, self.started = len(todo), time.monotonic()
        self.logs.mkdir(parents=True, exist_ok=True)
        try:
            for _ in range(min(self.workers, len(todo))):
                self._spawn()
            while self.running:
                try:
                    number, message = self.events.get(timeout=1.0)
                except queue.Empty:
                    self._draw()
                    continue
                self._handle(self.running.get(number), message)
                self._draw()
        except KeyboardInterrupt:
            self._stop_all(interrupted=True)
            raise
        finally:
            self._draw(final=True)
        self._stop_all()

    def _spawn(self) -> None:
        self.spawned += 1
        number = self.spawned
        log = open(self.logs / f"worker-{number}.log", "w", encoding="utf-8", errors="replace")
        process = subprocess.Popen(self.command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=log,
                                   env=self.env, text=True, encoding="utf-8", errors="replace", bufsize=1)
        worker = _Worker(number, process, log)
        worker.reader = threading.Thread(target=self._read, args=(worker,), daemon=True)
        worker.reader.start()
        self.running[number] = worker

    def _read(self, worker: _Worker) -> None:
        for line in worker.process.stdout:
            if line.startswith(MARK):
                try:
                    self.events.put((worker.number, json.loads(line[len(MARK):])))
                    continue
                except ValueError:
                    pass
            worker.log.write(line)
        self.events.put((worker.number, None))

    def _handle(self, worker: _Worker | None, message: dict | None) -> None:
        if worker is None:
            return
        if message is None:
            self._ended(worker)
            return
        if "rss_mb" in message and message["rss_mb"] is not None:
            key = f"worker-{worker.number}"
            self.report.worker_peak_rss_mb[key] = max(self.report.worker_peak_rss_mb.get(key, 0.0),
                                                      message["rss_mb"])
        if message.get("ready"):
            worker.ready, worker.staging = True, message.get("staging", "")
        elif "done" in message or "failed" in message:
            self._warmed()
            self._record(worker, message)
        self._feed(worker)

    def _record(self, worker: _Worker, message: dict) -> None:
        """A worker's row is over: done (its files noted as written) or failed with the reason."""
        row = worker.row[0]
        if "done" in message:
            self.report.done[row.line] = {"out": row.out, "seconds": message["seconds"],
                                          "cpu_s": message.get("cpu_s"), "worker": worker.number}
            note_written(self.out_dir / name for name in row.outputs() + (row.sidecar,))
        else:
            self.report.fail(row.line, row.out, message["failed"])
        worker.row = None

    def _warmed(self) -> None:
        """The first row is over: its target shapes are in the cache, every ready worker takes a row."""
        if not self.warm:
            self.warm = True
            for other in list(self.running.values()):
                if other.row is None:
                    self._feed(other)

    def _feed(self, worker: _Worker) -> None:
        if worker.row is not None or not worker.ready:
            return
        if not self.warm and any(other.row is not None for other in self.running.values()):
            return                                      # the first row warms the shape cache for the rest
        if not self.pending:
            self._write(worker, _STOP)
            return
        row, key, inputs = self.pending.popleft()
        worker.row, worker.started = (row, key, inputs), time.monotonic()
        if not self._write(worker, json.dumps({"row": row.fields(), "key": key, "inputs": inputs}) + "\n"):
            self.pending.appendleft(worker.row)
            worker.row = None

    @staticmethod
    def _write(worker: _Worker, text: str) -> bool:
        try:
            worker.process.stdin.write(text)
            worker.process.stdin.flush()
            return True
        except (BrokenPipeError, OSError, ValueError):
            return False

    def _ended(self, worker: _Worker) -> None:
        """A worker's output closed: it finished, or it died (then its row fails and it is replaced)."""
        code = worker.process.wait()
        worker.log.close()
        self.running.pop(worker.number, None)
        if worker.staging:
            shutil.rmtree(worker.staging, ignore_errors=True)     # what a killed worker left half made
        died = code != 0 or worker.row is not None or not worker.ready
        if not died:
            return
        self.deaths += 1
        log = self.logs / f"worker-{worker.number}.log"
        how = (f"killed by signal {-code}" if code < 0 else f"exit code {code}") + _last_words(log)
        if worker.row is not None:
            row = worker.row[0]
            self.report.fail(row.line, row.out, f"the worker process ended during this row ({how}; its log: "
                                                f"{log}); nothing of the row was written: run again to redo it")
            worker.row = None
            self._warmed()
        if self.pending and self.deaths <= max(2, self.workers):
            self._spawn()
        elif self.pending and not self.running:
            for row, _, _ in self.pending:
                self.report.fail(row.line, row.out, f"no worker left: {self.deaths} worker processes ended "
                                                    f"early (last: {how}; see {log})")
            self.pending.clear()

    def _stop_all(self, interrupted: bool = False) -> None:
        """Stop every worker (``interrupted``: at once, SIGTERM: its row's staging goes, its files stay as they
        were); rows they finished meanwhile are recorded, the others reported as not run."""
        for worker in self.running.values():
            self._write(worker, _STOP)
            if interrupted and worker.process.poll() is None:
                worker.process.terminate()
        for worker in self.running.values():
            try:
                worker.process.wait(timeout=60)
            except subprocess.TimeoutExpired:
                worker.process.kill()
                worker.process.wait()
            worker.reader.join(timeout=10)
        while not self.events.empty():                  # what the workers said before they stopped
            number, message = self.events.get_nowait()
            worker = self.running.get(number)
            over = message is not None and ("done" in message or "failed" in message)
            if over and worker is not None and worker.row is not None:
                self._record(worker, message)
        for worker in self.running.values():
            if worker.row is not None:
                self.report.not_run[worker.row[0].line] = worker.row[0].out
            if worker.staging:
                shutil.rmtree(worker.staging, ignore_errors=True)
            worker.log.close()
        for row, _, _ in self.pending if interrupted else ():
            self.report.not_run[row.line] = row.out
        self.running.clear()

    def _draw(self, final: bool = False) -> None:
        finished = sum(1 for line in self.report.done) + len(self.report.failed)
        self.progress.show(progress_line(finished, self.to_run, len(self.report.failed),
                                         len(self.report.skipped), time.monotonic() - self.started), final)


def _last_words(log: Path) -> str:
    """The last error line of a worker's log (what it said before it stopped), for the report."""
    try:
        with open(log, "rb") as handle:
            handle.seek(max(0, handle.seek(0, os.SEEK_END) - 4096))
            lines = handle.read().decode("utf-8", errors="replace").splitlines()
    except OSError:
        return ""
    said = [line for line in lines if "error" in line.lower()]
    return f": {said[-1].strip()[:300]}" if said else ""
