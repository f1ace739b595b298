"""``summary.json``: every scalar of every run's analysis.nc in SI units, plus machine and costs;
its fields: docs/ARCHITECTURE.md (``summary.json``)."""
from __future__ import annotations

import datetime as _dt
import json
import math
import os
import platform
import time
from pathlib import Path
from typing import Any

from .._identity import __version__
from ..analysis.schema import SPEC
from .data import ReportContext, RunData
from .saltation import n_parcels_per_m2_at_Q, saltation_state

__all__ = ["machine_info", "run_scalars", "build_summary", "run_key", "task_times",
           "finish_wall_time"]


def machine_info() -> dict[str, Any]:
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            proc = next((line.split(":", 1)[1].strip() for line in fh
                         if line.lower().startswith("model name")), "")
    except OSError:
        proc = ""
    proc = proc or platform.processor() or platform.machine()
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    return {"cores": cores, "logical_cpus": os.cpu_count(), "processor": proc,
            "platform": platform.platform(), "python": platform.python_version()}


def run_scalars(run: RunData) -> tuple[dict[str, float], dict[str, str]]:
    """All 0-d numeric variables of the archive (SI units, as every analysis.nc), and their
    units."""
    vals: dict[str, float] = {}
    units: dict[str, str] = {}
    for name, var in (run.ds.data_vars.items() if run.ds is not None else ()):
        if var.ndim != 0 or var.dtype.kind not in "fiub":
            continue
        vals[str(name)] = float(var.values)
        units[str(name)] = var.attrs.get("units") or SPEC.get(str(name), ("1", ""))[0]
    return vals, units


def run_key(run: RunData) -> str:
    return str(run.case) if run.plain_case and run.case is not None else run.label


def task_times(ctx: ReportContext) -> dict[str, float]:
    """Recorded task times per kind [s], from the analysis archives' attributes: a spin-up shared
    by several runs (same ``spinup_path``) counted once. An archive without the spin-up's own time
    counts its ``wall_time_s`` (spin-up + saltation) as saltation."""
    out = {"spinup": 0.0, "saltation": 0.0, "analysis": 0.0}
    spinups: dict[str, float] = {}
    for run in ctx.runs.values():
        if run.ds is None:
            continue
        wall, spin = run.wall_time_s, run.attr("spinup_wall_time_s")
        if math.isfinite(spin) and math.isfinite(wall):
            spinups.setdefault(str(run.ds.attrs.get("spinup_path") or run.label), spin)
            out["saltation"] += wall - spin
        elif math.isfinite(wall):
            out["saltation"] += wall
        a = run.attr("analysis_seconds")
        if math.isfinite(a):
            out["analysis"] += a
    out["spinup"] = float(sum(spinups.values()))
    return out


def build_summary(ctx: ReportContext) -> dict[str, Any]:
    meta = ctx.meta
    cases: dict[str, Any] = {}
    units: dict[str, str] = {"wall_time_s": "s", "n_parcels_per_m2_at_Q": "m-2",
                             "airborne_mass_per_m2": "kg m-2"}
    for run in ctx.runs.values():
        vals, u = run_scalars(run)
        units.update(u)
        entry: dict[str, Any] = {"label": run.label, "case_number": run.case, "status": run.status,
                                 "fidelity": run.fidelity, "wall_time_s": run.wall_time_s,
                                 "archive": str(run.path) if run.path else None}
        entry.update(vals)
        # present in every entry, null when undefined: the run's grains in the paper's terms
        entry["n_parcels_per_m2_at_Q"] = n_parcels_per_m2_at_Q(run) if run.ok else None
        entry.setdefault("airborne_mass_per_m2", None)
        entry["saltation"] = saltation_state(run).to_json()
        cases[run_key(run)] = entry
    fids = sorted({r.fidelity for r in ctx.runs.values() if r.fidelity})
    tt = task_times(ctx)
    started = meta.get("run_started")
    return {
        "study": ctx.study,
        "fidelity": meta.get("fidelity") or (fids[0] if len(fids) == 1 else fids or None),
        "package_version": meta.get("package_version") or __version__,
        "total_wall_time_s": None,
        "task_time_sum_s": float(sum(tt.values())),
        "task_times_s": tt,
        "run_started": _iso(started) if isinstance(started, (int, float)) else None,
        "run_finished": None,
        "tasks_from_cache": meta.get("tasks_from_cache"),
        "tasks_total": meta.get("tasks_total"),
        "machine": machine_info(),
        "units": units,
        "cases": cases,
    }


def _iso(epoch: float) -> str:
    return _dt.datetime.fromtimestamp(epoch, _dt.timezone.utc).isoformat(timespec="seconds")


def finish_wall_time(summary: dict[str, Any], meta: dict[str, Any], previous: Path) -> None:
    """Set ``total_wall_time_s`` and ``run_finished``: now − ``meta["run_started"]`` when the
    report is built by a run; else carried over from ``previous`` (the summary.json being
    replaced) if that holds one; else left null."""
    started = meta.get("run_started")
    if isinstance(started, (int, float)) and math.isfinite(started):
        now = time.time()
        summary["total_wall_time_s"] = max(0.0, now - float(started))
        summary["run_finished"] = _iso(now)
    elif previous.is_file():
        try:
            old = json.loads(previous.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            old = {}
        if isinstance(old.get("total_wall_time_s"), (int, float)) and old.get("run_started"):
            for k in ("total_wall_time_s", "run_started", "run_finished", "tasks_from_cache",
                      "tasks_total"):
                summary[k] = old.get(k)
