# SPDX-License-Identifier: GPL-3.0-or-later
"""The report of a jobs run: what was done, skipped (already current) and failed with its reason, as JSON
for pipelines and as a short summary for people; the progress line; the merge of a farm job's chunk
reports into one."""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["REPORT_FORMAT", "RunReport", "progress_line", "merge_reports", "duration_text", "write_report"]

REPORT_FORMAT = "faces_hands.jobs_report"


def duration_text(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    seconds = int(round(seconds))
    if seconds < 60:
        return f"{seconds} s"
    if seconds < 3600:
        return f"{seconds // 60} min {seconds % 60:02d} s"
    return f"{seconds // 3600} h {seconds % 3600 // 60:02d} min"


def progress_line(finished: int, to_run: int, failed: int, skipped: int, elapsed: float) -> str:
    """``rows 37/200 done (2 failed, 15 skipped) | 5.1 rows/min | ETA 31 min 10 s``: the rate and the time
    left count only rows run now (skipped rows cost nothing)."""
    rate = finished / elapsed * 60.0 if elapsed > 0 and finished else 0.0
    left = (to_run - finished) / (rate / 60.0) if rate else math.inf
    notes = ", ".join(part for part in (f"{failed} failed" if failed else "",
                                        f"{skipped} skipped" if skipped else "") if part)
    return (f"rows {finished}/{to_run} done" + (f" ({notes})" if notes else "")
            + f" | {rate:.1f} rows/min | ETA {duration_text(left) if finished < to_run else '0 s'}")


@dataclass
class RunReport:
    """Rows by line: ``done`` (out, seconds, worker), ``skipped`` (out: current before the run),
    ``failed`` (out, reason), ``not_run`` (out: an interrupt came first)."""
    manifest: str
    total: int
    workers: int = 1
    done: dict[int, dict] = field(default_factory=dict)
    skipped: dict[int, str] = field(default_factory=dict)
    failed: dict[int, dict] = field(default_factory=dict)
    not_run: dict[int, str] = field(default_factory=dict)
    wall_s: float = 0.0
    worker_peak_rss_mb: dict[str, float] = field(default_factory=dict)
    extension_version: str = ""
    manifest_sha256: str = ""

    def fail(self, line: int, out: str, reason: str) -> None:
        self.failed[line] = {"out": out, "reason": reason}

    def rows_per_min(self) -> float:
        return len(self.done) / self.wall_s * 60.0 if self.wall_s > 0 else 0.0

    def to_json(self) -> str:
        rows = sorted([{"line": n, "state": "done", **v} for n, v in self.done.items()]
                      + [{"line": n, "state": "skipped", "out": v} for n, v in self.skipped.items()]
                      + [{"line": n, "state": "failed", **v} for n, v in self.failed.items()]
                      + [{"line": n, "state": "not_run", "out": v} for n, v in self.not_run.items()],
                      key=lambda r: r["line"])
        doc = {"format": REPORT_FORMAT, "version": 1, "manifest": self.manifest,
               "manifest_sha256": self.manifest_sha256, "extension_version": self.extension_version,
               "workers": self.workers,
               "counts": {"rows": self.total, "done": len(self.done), "skipped": len(self.skipped),
                          "failed": len(self.failed), "not_run": len(self.not_run)},
               "wall_s": round(self.wall_s, 3), "rows_per_min": round(self.rows_per_min(), 3),
               "worker_peak_rss_mb": self.worker_peak_rss_mb, "rows": rows}
        return json.dumps(doc, indent=1, ensure_ascii=False)

    @classmethod
    def from_json(cls, text: str) -> "RunReport":
        doc = json.loads(text)
        if not isinstance(doc, dict) or doc.get("format") != REPORT_FORMAT:
            raise ValueError("not a jobs report")
        report = cls(doc["manifest"], int(doc["counts"]["rows"]), int(doc.get("workers", 1)),
                     wall_s=float(doc.get("wall_s", 0.0)), worker_peak_rss_mb=doc.get("worker_peak_rss_mb", {}),
                     extension_version=doc.get("extension_version", ""),
                     manifest_sha256=doc.get("manifest_sha256", ""))
        for row in doc["rows"]:
            line, state = int(row["line"]), row["state"]
            values = {k: v for k, v in row.items() if k not in ("line", "state")}
            if state == "done":
                report.done[line] = values
            elif state == "failed":
                report.failed[line] = values
            else:
                (report.skipped if state == "skipped" else report.not_run)[line] = values.get("out", "")
        return report

    def summary(self, limit: int = 50) -> str:
        """A few lines for people: the counts, then every failed row with its reason (up to ``limit``)."""
        head = (f"{self.total} rows: {len(self.done)} done, {len(self.skipped)} skipped (already current), "
                f"{len(self.failed)} failed" + (f", {len(self.not_run)} not run" if self.not_run else "")
                + (f" in {duration_text(self.wall_s)} ({self.rows_per_min():.1f} rows/min)"
                   if self.done and self.wall_s else ""))
        lines = [head]
        for line, row in sorted(self.failed.items())[:limit]:
            lines.append(f"  line {line} ({row['out']}): {row['reason']}")
        if len(self.failed) > limit:
            lines.append(f"  ... and {len(self.failed) - limit} more failed rows (all in the JSON report)")
        return "\n".join(lines)


def merge_reports(manifest: str, total_lines: dict[int, str], current: set[int], parts: list[RunReport],
                  missing_reason: str = "no task reported this row") -> RunReport:
    """One report for a farm job from its chunk reports: every row of the manifest (line -> out) is done
    when it is current now and a chunk did it, skipped when it was current before, otherwise failed with
    the chunk's reason (or ``missing_reason`` when no chunk reported it)."""
    merged = RunReport(manifest, len(total_lines), workers=len(parts))
    merged.wall_s = sum(part.wall_s for part in parts)
    for part in parts:
        merged.extension_version = merged.extension_version or part.extension_version
        merged.worker_peak_rss_mb.update(part.worker_peak_rss_mb)
    done = {line: row for part in parts for line, row in part.done.items()}
    failed = {line: row for part in parts for line, row in part.failed.items()}
    for line, out in sorted(total_lines.items()):
        if line in current:
            if line in done:
                merged.done[line] = done[line]
            else:
                merged.skipped[line] = out
        elif line in failed:
            merged.failed[line] = failed[line]
        else:
            merged.fail(line, out, missing_reason)
    return merged


def write_report(path: Path, report: RunReport) -> None:
    """Write ``report`` as JSON (aside, then renamed: a reader never sees half a report)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(report.to_json(), encoding="utf-8")
    tmp.replace(path)
