"""``saltstudy status``: per run and task, is the output for the *current* config done?

States: ``done``, ``stale`` (only an older key's output, per runs.json), ``failed``, ``partial``
(a checkpoint to resume from), ``running`` (progress moved in the last minutes), ``stopped``
(task.json says running, nothing moves), ``missing``.
"""
from __future__ import annotations

import platform
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from ..config import Study
from ..ncio import is_complete
from . import keys as K
from .lock import LOCK_NAME, describe_holder, read_holder, record_alive
from .paths import checkpoint_time, output_path, read_runs_file, read_task_json, task_dir
from .progress import eta, format_duration, is_stale, read_progress, writer_gone

TASKS = ("spinup", "saltation", "analysis")


@dataclass
class StatusRow:
    label: str
    task: str
    state: str
    key: str
    detail: str = ""


def _running(d: Path, tj: dict) -> tuple[str, str]:
    """A task whose task.json says running: alive if its progress file moved recently."""
    started = tj.get("started")
    since = (time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(started))
             if isinstance(started, (int, float)) else "?")
    where = f"since {since} on {tj.get('host', '?')}"
    p = read_progress(d)
    writer = p if p is not None and "pid" in p else tj   # progress files name their process
    if writer_gone(writer):
        return "stopped", f"{where}; its process ({writer['pid']}) is gone: it died or was killed"
    if p is None or "updated" not in p:    # no progress yet (a report writes none)
        here = tj.get("host") == platform.node() and isinstance(tj.get("pid"), int)
        return "running", where + ("" if here else " (or killed: its process cannot be asked)")
    if is_stale(p):
        quiet_for = time.time() - float(p["updated"])
        return "stopped", f"{where}; no progress for {format_duration(quiet_for)}: its process died"
    target = p.get("target")
    if not target:
        return "running", f"{where}; t = {p.get('t', 0.0):.3g} s"
    return "running", (f"{where}; t = {p.get('t', 0.0):.3g} / {target:.3g} s, "
                       f"ETA {format_duration(eta(p))}")


def _state(out_dir: Path, task: str, key: str, old_key: str | None) -> tuple[str, str]:
    if is_complete(output_path(out_dir, task, key)):
        return "done", ""
    d = task_dir(out_dir, task, key)
    tj = read_task_json(d) or {}
    live = _running(d, tj) if tj.get("state") == "running" else None
    if live is not None and live[0] == "running":
        return live   # a running task writes checkpoints as it goes
    if task in ("spinup", "saltation") and (d / "checkpoint.npz").is_file():
        # interrupted or failed, but a rerun resumes from the checkpoint
        t = checkpoint_time(d)
        where = f" at t = {t:.3g} s" if t is not None else ""
        why = (f" (stopped by {tj['error']})" if tj.get("state") == "failed"
               else " (its process died)" if live is not None else "")
        return "partial", f"checkpoint to resume from{where}{why}"
    if tj.get("state") == "failed":
        return "failed", str(tj.get("error", ""))
    if live is not None:
        return live
    if old_key and old_key != key and is_complete(output_path(out_dir, task, old_key)):
        return "stale", f"config or code changed; last done: {old_key}"
    return "missing", ""


def study_status(study: Study, out_dir: Path, root: Path | None = None) -> list[StatusRow]:
    """Rows for every run and task of ``study``, plus the report. Raises ConfigError."""
    runs = K.study_keys(study, root)
    recorded = read_runs_file(out_dir, study.name).get("labels", {})
    rows: list[StatusRow] = []
    analyses: dict[str, str | None] = {}
    for label, rk in runs.items():
        old = recorded.get(label, {})
        for task in TASKS:
            key = getattr(rk, task)
            state, detail = _state(out_dir, task, key, old.get(task))
            rows.append(StatusRow(label, task, state, key, detail))
            if task == "spinup" and rk.links:
                # a staggered start: the last of its continuation links (workflow/tasks.py)
                state, detail = _state(out_dir, "spinup", rk.start, None)
                rows.append(StatusRow(label, "start", state, rk.start,
                                      f"spin-up + {len(rk.links)} x "
                                      f"{rk.scene.fidelity.spinup.stagger:g} s {detail}".rstrip()))
            if task == "analysis":
                analyses[label] = key if state == "done" else None
    if study.report:
        rkey = K.report_key(study, analyses)
        d = task_dir(out_dir, "report", rkey)
        tj = read_task_json(d) or {}
        if tj.get("state") == "done" and Path(tj.get("report_dir", "")).is_dir():
            state, detail = "done", tj["report_dir"]
        elif tj.get("state") == "running":
            state, detail = _running(d, tj)
        elif tj.get("state") == "failed":
            state, detail = "failed", str(tj.get("error", ""))
        else:
            old = read_runs_file(out_dir, study.name).get("report", {})
            state, detail = ("stale" if old.get("key") else "missing"), old.get("dir", "")
        rows.append(StatusRow("(all)", "report", state, rkey, detail))
    return rows


def out_dir_state(out_dir: Path) -> str:
    """Who holds the out dir (``lock.py``): a live process, one that is gone, or none."""
    path = Path(out_dir) / LOCK_NAME
    if not path.exists():
        return "out dir: not in use"
    rec = read_holder(path)
    if rec is None:
        return f"out dir: {path} exists without a record (a process is taking it, or one died " \
               "while taking it)"
    if record_alive(rec, path):
        return f"out dir: in use by {describe_holder(rec)}"
    return (f"out dir: not in use; {path} was left by {describe_holder(rec)}, which is gone "
            "(the next run takes it over)")


def format_status(rows: list[StatusRow]) -> str:
    w = max([len(r.label) for r in rows] + [5])
    lines = [f"{'run':<{w}}  {'task':<9}  {'state':<7}  {'key':<20}  detail"]
    lines += [f"{r.label:<{w}}  {r.task:<9}  {r.state:<7}  {r.key:<20}  {r.detail}" for r in rows]
    counts = Counter(r.state for r in rows)
    lines.append("; ".join(f"{v} {k}" for k, v in sorted(counts.items())))
    return "\n".join(lines)
