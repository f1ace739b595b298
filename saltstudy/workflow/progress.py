"""Live progress: tasks write ``progress.json`` (at most once a second, atomically); the display
polls the files, which work alike with threads, processes and a cluster, and survive a worker.
"""
from __future__ import annotations

import os
import platform
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .lock import pid_alive
from .paths import read_json, write_json_atomic

PROGRESS_NAME = "progress.json"
#: [s] a "running" file not updated for this long belongs to a process that died (the slowest
#: step measured takes 1.2 s, docs/BENCHMARKS.md; a callback writes every second)
STALE_AFTER = 300.0

_ACTIVE: "ProgressDisplay | None" = None
_EMIT_LOCK = threading.Lock()


def emit(message: str) -> None:
    """Print a log line (stderr) without tearing the live display of this process, if any."""
    display = _ACTIVE
    if display is not None:
        display.log(message)
        return
    with _EMIT_LOCK:
        sys.stderr.write(message + "\n")
        sys.stderr.flush()


class ProgressFile:
    """Callable handed to a task: ``cb(t_done, t_target)`` (simulated seconds)."""

    def __init__(self, task_dir: Path, task: str, label: str, phase: str, min_interval: float = 1.0):
        self.path = Path(task_dir) / PROGRESS_NAME
        self.task, self.label, self.phase = task, label, phase
        self.min_interval = min_interval
        self._last = 0.0
        self._t0 = time.time()
        self._t_start: float | None = None  # simulated time when this process took the task up
        self.target = None
        self._writer = {"host": platform.node(), "pid": os.getpid()}   # as task.json names it

    def __call__(self, t: float, target: float | None = None) -> None:
        if target is not None:
            self.target = float(target)
        now = time.time()
        if now - self._last < self.min_interval:
            return
        self._last = now
        self.write(float(t), "running")

    def write(self, t: float, state: str, message: str = "") -> None:
        if self._t_start is None:
            self._t_start = t
        try:
            write_json_atomic(self.path, {
                "task": self.task, "label": self.label, "phase": self.phase, "state": state,
                "t": t, "t_start": self._t_start, "target": self.target, "started": self._t0,
                "updated": time.time(), "message": message, **self._writer})
        except OSError:  # progress is best-effort; never fail a task because of it
            pass


def read_progress(task_dir: Path) -> dict | None:
    return read_json(Path(task_dir) / PROGRESS_NAME)


def writer_gone(p: dict) -> bool:
    """True if the record (progress.json or task.json) was written on this host by a process that
    has exited; another host's record falls back on the STALE_AFTER clock."""
    pid = p.get("pid")
    return isinstance(pid, int) and p.get("host") == platform.node() and not pid_alive(pid)


def is_stale(p: dict, now: float | None = None) -> bool:
    """True if a progress record's writer died (gone from this host, or silent STALE_AFTER s)."""
    quiet_for = (time.time() if now is None else now) - p.get("updated", 0.0)
    return writer_gone(p) or quiet_for > STALE_AFTER


def eta(p: dict, now: float | None = None) -> float | None:
    """Seconds left for a running task at the rate since its process took it up (a resumed run
    starts part-way); None if unknown."""
    t, target = p.get("t") or 0.0, p.get("target")
    now = time.time() if now is None else now
    done = t - (p.get("t_start") or 0.0)
    if not target or done <= 0:
        return None
    return (now - p.get("started", now)) * (target - t) / done


def format_duration(s: float | None) -> str:
    if s is None or s != s or s < 0:
        return "?"
    s = int(round(s))
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s // 3600}h{(s % 3600) // 60:02d}m"


@dataclass
class TaskRef:
    name: str        # e.g. "saltation case01"
    directory: Path  # the task's cache directory


class ProgressDisplay:
    """Background thread printing every running task's state: a refreshed block on a terminal,
    else (or with ``quiet``) a log line per task every ``log_every`` seconds."""

    def __init__(self, tasks: list[TaskRef], quiet: bool = False, interval: float = 1.0,
                 log_every: float = 30.0, stream=None):
        self.tasks, self.quiet = tasks, quiet
        self.stream = stream or sys.stderr
        self.interactive = (not quiet) and self.stream.isatty()
        self.interval = interval if self.interactive else log_every
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True, name="saltstudy-progress")
        self._lines = 0

    def __enter__(self) -> "ProgressDisplay":
        global _ACTIVE
        _ACTIVE = self
        self._thread.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        global _ACTIVE
        self._stop.set()
        self._thread.join(timeout=5)
        _ACTIVE = None

    def log(self, message: str) -> None:
        with _EMIT_LOCK:
            self._clear()
            self.stream.write(message + "\n")
            self.stream.flush()

    def _clear(self) -> None:
        if self.interactive and self._lines:
            self.stream.write(f"\x1b[{self._lines}F\x1b[J")
            self._lines = 0

    def rows(self) -> list[str]:
        out = []
        now = time.time()
        for ref in self.tasks:
            p = read_progress(ref.directory)
            if p is None or p.get("state") != "running" or is_stale(p, now):
                continue
            t, target = p.get("t") or 0.0, p.get("target")
            elapsed = now - p.get("started", now)
            if target:
                frac = min(max(t / target, 0.0), 1.0)
                out.append(f"{ref.name:<28} {p.get('phase', ''):<10} t = {t:8.2f} / {target:.2f} s "
                           f"({100 * frac:5.1f} %)  elapsed {format_duration(elapsed)}  "
                           f"ETA {format_duration(eta(p, now))}")
            else:
                out.append(f"{ref.name:<28} {p.get('phase', ''):<10} t = {t:8.2f} s  "
                           f"elapsed {format_duration(elapsed)}")
        return out

    def _run(self) -> None:
        while not self._stop.wait(self.interval):
            rows = self.rows()
            with _EMIT_LOCK:
                if self.interactive:
                    self._clear()  # move up over the previous block and redraw it
                    self.stream.write("".join(r + "\n" for r in rows))
                    self._lines = len(rows)
                else:
                    for r in rows:
                        self.stream.write(f"[progress] {r}\n")
                self.stream.flush()
        with _EMIT_LOCK:
            self._clear()
            self.stream.flush()
