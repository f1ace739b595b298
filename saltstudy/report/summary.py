"""``summary.json``: every scalar of every run's analysis.nc in SI units, plus machine and costs.

Layout::

    {"study": ..., "fidelity": ..., "package_version": ..., "total_wall_time_s": ...,
     "machine": {"cores": ..., "processor": ..., "platform": ..., "python": ...},
     "units": {"u_star_s": "m s-1", ...},                 # unit of each scalar name
     "cases": {"2": {"label": "case02", "status": "ok", "fidelity": ..., "wall_time_s": ...,
                     "archive": ".../analysis.nc", "u_star_s": 0.55, ...}, ...}}

A plain case is keyed by its number as a string; any other run (ladder rung, scene) by its label.
NaN (undefined) is written as null; JSON has no NaN.
"""
from __future__ import annotations

import json
import math
import os
import platform
from pathlib import Path
from typing import Any

from .data import SCALAR_UNITS, ReportContext, RunData, to_si

__all__ = ["machine_info", "run_scalars", "build_summary", "write_summary", "run_key"]


def machine_info() -> dict[str, Any]:
    proc = ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    proc = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    if not proc:
        proc = platform.processor() or platform.machine()
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    return {"cores": cores, "logical_cpus": os.cpu_count(), "processor": proc,
            "platform": platform.platform(), "python": platform.python_version()}


def _clean(v: float) -> float | None:
    return float(v) if isinstance(v, (int, float)) and math.isfinite(v) else None


def run_scalars(run: RunData) -> tuple[dict[str, float | None], dict[str, str]]:
    """All 0-d numeric variables of the archive in SI units, and their units."""
    vals: dict[str, float | None] = {}
    units: dict[str, str] = {}
    if run.ds is None:
        return vals, units
    for name, var in run.ds.data_vars.items():
        if var.ndim != 0 or var.dtype.kind not in "fiub":
            continue
        v, u = to_si(float(var.values), var.attrs.get("units", SCALAR_UNITS.get(name)))
        vals[str(name)] = _clean(v)
        units[str(name)] = u if u else SCALAR_UNITS.get(name, "1")
    return vals, units


def run_key(run: RunData) -> str:
    return str(run.case) if run.plain_case and run.case is not None else run.label


def build_summary(ctx: ReportContext) -> dict[str, Any]:
    meta = ctx.meta
    cases: dict[str, Any] = {}
    units: dict[str, str] = {"wall_time_s": "s"}
    total = 0.0
    for run in ctx.runs.values():
        vals, u = run_scalars(run)
        units.update(u)
        entry: dict[str, Any] = {"label": run.label, "case_number": run.case, "status": run.status,
                                 "fidelity": run.fidelity,
                                 "archive": str(run.path) if run.path else None,
                                 "wall_time_s": _clean(run.wall_time_s)}
        entry.update(vals)
        cases[run_key(run)] = entry
        if math.isfinite(run.wall_time_s):
            total += run.wall_time_s
    fids = sorted({r.fidelity for r in ctx.runs.values() if r.fidelity})
    return {
        "study": ctx.study,
        "fidelity": meta.get("fidelity") or (fids[0] if len(fids) == 1 else fids or None),
        "package_version": meta.get("package_version") or _package_version(),
        "total_wall_time_s": total,
        "machine": machine_info(),
        "units": units,
        "cases": cases,
    }


def _package_version() -> str:
    from .. import __version__
    return __version__


def write_summary(ctx: ReportContext, path: Path) -> dict[str, Any]:
    data = build_summary(ctx)
    path.write_text(json.dumps(data, indent=2, sort_keys=False, allow_nan=False) + "\n", encoding="utf-8")
    return data
