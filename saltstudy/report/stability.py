"""Stability report for a study of extreme scenes: did each run complete, and how close to the edge.

Per scene: completed / failed (with the workflow's failure message), max CFL, ranges of the velocity
fields, momentum-budget closure, E_splash/E_impact and wall time. Values come from what exists: the
analysis archive (scalars, attributes, copied series) and, optionally, the run's ``samples.nc``.
Anything not found is written "n/a"; nothing is estimated.
"""
from __future__ import annotations

import html
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..ncio import NC_LOCK
from .data import RunData, load_runs
from .tables import fmt

__all__ = ["stability_rows", "build_stability_report", "STABILITY_COLUMNS"]

STABILITY_COLUMNS = (
    ("status", "status"), ("max_cfl", "max CFL"), ("u_min", "u min [m s⁻¹]"),
    ("u_max", "u max [m s⁻¹]"), ("w_absmax", "|w| max [m s⁻¹]"),
    ("momentum_closure", "momentum budget residual [-]"),
    ("E_splash_over_E_impact", "E_splash/E_impact [-]"), ("wall_time_s", "wall time [s]"),
)

_MOMENTUM_NAMES = ("momentum_budget_residual", "momentum_closure", "momentum_residual",
                   "momentum_budget_closure")


def _num(x: Any) -> float:
    try:
        v = float(np.asarray(x).max()) if np.ndim(x) else float(x)
    except (TypeError, ValueError):
        return math.nan
    return v


def _from_ds(ds: xr.Dataset | None, out: dict[str, Any], source: str) -> None:
    """Fill what ``ds`` provides into ``out`` (keys not yet set only)."""
    if ds is None:
        return

    def put(key, value, how):
        if key not in out and math.isfinite(value):
            out[key] = value
            out.setdefault("_sources", {})[key] = f"{source}: {how}"

    for key in ("max_cfl",):
        if key in ds.variables:
            put(key, float(np.nanmax(ds[key].values)), f"max of {key}")
        elif key in ds.attrs:
            put(key, _num(ds.attrs[key]), f"attribute {key}")
    for var in ("u", "u_plane"):
        if var in ds.variables and ds[var].ndim >= 2:
            vals = ds[var].values
            put("u_min", float(np.nanmin(vals)), f"min of {var}")
            put("u_max", float(np.nanmax(vals)), f"max of {var}")
    for key in ("u_min", "u_max", "w_absmax"):
        if key in ds.variables and ds[key].ndim == 0:
            put(key, float(ds[key].values), key)
        elif key in ds.attrs:
            put(key, _num(ds.attrs[key]), f"attribute {key}")
    if "w" in ds.variables and ds["w"].ndim >= 2:
        put("w_absmax", float(np.nanmax(np.abs(ds["w"].values))), "max |w|")
    for name in _MOMENTUM_NAMES:
        if name in ds.variables and ds[name].ndim == 0:
            put("momentum_closure", float(ds[name].values), name)
        elif name in ds.attrs:
            put("momentum_closure", _num(ds.attrs[name]), f"attribute {name}")
    if "E_splash_over_E_impact" in ds.variables and ds["E_splash_over_E_impact"].ndim == 0:
        put("E_splash_over_E_impact", float(ds["E_splash_over_E_impact"].values), "scalar")
    if "E_splash" in ds.variables and "E_impact" in ds.variables:
        es, ei = np.asarray(ds["E_splash"].values, float), np.asarray(ds["E_impact"].values, float)
        if es.size and ei.size and np.isfinite(ei[-1]) and ei[-1] > 0:
            put("E_splash_over_E_impact", float(es[-1] / ei[-1]), "E_splash/E_impact at the end")


def _snapshot_fallback(ds: xr.Dataset | None, out: dict[str, Any]) -> None:
    """Last resort for the u range: the analysis keeps only the last u(0.1 m) plane."""
    if ds is None or "u_snapshot" not in ds.variables:
        return
    v = ds["u_snapshot"].values
    for key, val in (("u_min", float(np.nanmin(v))), ("u_max", float(np.nanmax(v)))):
        if key not in out and math.isfinite(val):
            out[key] = val
            out.setdefault("_sources", {})[key] = "analysis.nc: last u(0.1 m) plane only"


def _open_samples(path: Path) -> xr.Dataset | None:
    """samples.nc may be large: read only the variables the table uses."""
    keep = ("max_cfl", "u", "u_plane", "w", "E_splash", "E_impact") + _MOMENTUM_NAMES
    try:
        with NC_LOCK:
            with xr.open_dataset(path, engine="netcdf4") as ds:
                sub = ds[[v for v in keep if v in ds.variables]].load()
                sub.attrs = dict(ds.attrs)
                return sub
    except Exception:
        return None


def stability_rows(runs: dict[str, RunData], failures: dict[str, str] | None = None,
                   samples: dict[str, str | Path | None] | None = None) -> list[dict[str, Any]]:
    failures = failures or {}
    samples = samples or {}
    rows = []
    for label, r in runs.items():
        row: dict[str, Any] = {"label": label}
        if label in failures:
            row["status"] = "failed"
            row["error"] = str(failures[label])
        elif r.ok:
            row["status"] = "completed"
        else:
            row["status"] = f"no result ({r.status})"
        _from_ds(r.ds, row, "analysis.nc")
        sp = samples.get(label) or (r.ds.attrs.get("samples_path") if r.ds is not None else None)
        if sp and Path(sp).is_file():
            _from_ds(_open_samples(Path(sp)), row, "samples.nc")
        _snapshot_fallback(r.ds, row)
        if math.isfinite(r.wall_time_s):
            row["wall_time_s"] = r.wall_time_s
        rows.append(row)
    return rows


def _cell(row: dict, key: str) -> str:
    if key == "status":
        return row["status"]
    v = row.get(key)
    return fmt(v) if isinstance(v, (int, float)) and math.isfinite(v) else "n/a"


def build_stability_report(runs: dict[str, str | Path | None] | dict[str, RunData], report_dir: Path,
                           failures: dict[str, str] | None = None,
                           samples: dict[str, str | Path | None] | None = None,
                           wall_times: dict[str, float] | None = None) -> dict[str, Any]:
    """Write ``stability.md`` and ``stability.json`` in ``report_dir``; return {"rows", "html", "files"}."""
    report_dir = Path(report_dir)
    report_dir.mkdir(parents=True, exist_ok=True)
    if runs and all(isinstance(v, RunData) for v in runs.values()):
        loaded = dict(runs)  # type: ignore[arg-type]
    else:
        loaded = load_runs(runs, {"wall_times": wall_times or {}})
    for label in failures or {}:
        if label not in loaded:
            loaded[label] = RunData(label, None, None, status="no archive")
    rows = stability_rows(loaded, failures, samples)
    heads = ["scene"] + [h for _, h in STABILITY_COLUMNS]
    md = ["# Stability of extreme scenes", "",
          "| " + " | ".join(heads) + " |", "|" + "---|" * len(heads)]
    for row in rows:
        md.append("| " + " | ".join([row["label"]] + [_cell(row, k) for k, _ in STABILITY_COLUMNS]) + " |")
    errs = [r for r in rows if r.get("error")]
    if errs:
        md += ["", "## Failures", ""] + [f"* **{r['label']}**: `{r['error']}`" for r in errs]
    md += ["", "Sources of each value (n/a: not found in the archives):", ""]
    for row in rows:
        src = row.get("_sources", {})
        if src:
            md.append(f"* {row['label']}: " + "; ".join(f"{k} ← {v}" for k, v in src.items()))
    (report_dir / "stability.md").write_text("\n".join(md) + "\n", encoding="utf-8")
    clean = [{k: (v if not (isinstance(v, float) and not math.isfinite(v)) else None)
              for k, v in row.items()} for row in rows]
    (report_dir / "stability.json").write_text(json.dumps(clean, indent=2, allow_nan=False) + "\n",
                                               encoding="utf-8")
    e = html.escape
    h = ["<table><thead><tr>" + "".join(f"<th>{e(x)}</th>" for x in heads) + "</tr></thead><tbody>"]
    for row in rows:
        cls = "bad" if row["status"] != "completed" else ""
        h.append(f"<tr><td>{e(row['label'])}</td>" + "".join(
            f"<td class='{cls if k == 'status' else ''}'>{e(_cell(row, k))}</td>" for k, _ in STABILITY_COLUMNS)
            + "</tr>")
    h.append("</tbody></table>")
    if errs:
        h.append("<ul>" + "".join(f"<li><b>{e(r['label'])}</b>: <code>{e(r['error'])}</code></li>"
                                  for r in errs) + "</ul>")
    return {"rows": rows, "html": "".join(h),
            "files": [report_dir / "stability.md", report_dir / "stability.json"]}
