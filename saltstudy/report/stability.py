"""Stability report for a study of extreme scenes: did each run complete (a failure with the
solver's diagnostic and the checkpoint kept), and how close to the edge (``STABILITY_COLUMNS``,
from the analysis archive and ``samples.nc``; "n/a" if not found).

Column stress residual. In a steady, horizontally homogeneous layer driven from above with no
pressure gradient, the total stress tau(z) = -rho <u'w'> (resolved + SGS) + tau_p (grains) is the
same at every height below the drive. The residual is max |tau(z) / mean(tau) - 1| over the levels
from the second to the u* height: it measures what the sampled window leaves unbalanced
(unsteadiness and sampling noise), not round-off.
"""
from __future__ import annotations

import html
import math
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..ncio import NC_LOCK
from .data import RunData, load_runs
from .plotting import save_figure
from .tables import figure_html, fmt, html_table, md_table, write_json

__all__ = ["stability_rows", "build_stability_report", "STABILITY_COLUMNS"]

STABILITY_COLUMNS = (
    ("status", "status"), ("finite", "finite"), ("limiting_step", "step limited by"),
    ("dt_median", "median Δt [s]"), ("max_cfl", "max CFL"),
    ("loading_max", "max mass loading [-]"), ("dt_over_tau_c", "max Δt/τ_c [-]"),
    ("parcel_balance", "parcel balance [-]"), ("column_stress_residual", "column stress residual [-]"),
    ("u_min", "u min [m s⁻¹]"), ("u_max", "u max [m s⁻¹]"), ("w_absmax", "|w| max [m s⁻¹]"),
    ("E_splash_over_E_impact", "E_splash/E_impact [-]"), ("wall_time_s", "wall time [s]"),
)


def _put(out: dict[str, Any], key: str, value: float, source: str) -> None:
    """``out[key] = value`` and where it came from, unless set already or not finite."""
    if key not in out and math.isfinite(value):
        out[key] = value
        out.setdefault("_sources", {})[key] = source


def _from_ds(ds: xr.Dataset | None, out: dict[str, Any], source: str) -> None:
    """Fill what ``ds`` provides into ``out`` (keys not yet set only)."""
    if ds is None:
        return
    if "max_cfl" in ds.variables:
        _put(out, "max_cfl", float(np.nanmax(ds["max_cfl"].values)), f"{source}: max of max_cfl")
    for var in ("u", "u_plane"):
        if var in ds.variables and ds[var].ndim >= 2:
            vals = ds[var].values
            _put(out, "u_min", float(np.nanmin(vals)), f"{source}: min of {var}")
            _put(out, "u_max", float(np.nanmax(vals)), f"{source}: max of {var}")
    if "w" in ds.variables and ds["w"].ndim >= 2:
        _put(out, "w_absmax", float(np.nanmax(np.abs(ds["w"].values))), f"{source}: max |w|")
    if "E_splash_over_E_impact" in ds.variables and ds["E_splash_over_E_impact"].ndim == 0:
        _put(out, "E_splash_over_E_impact", float(ds["E_splash_over_E_impact"].values),
             f"{source}: scalar")
    if "E_splash" in ds.variables and "E_impact" in ds.variables:
        es, ei = np.asarray(ds["E_splash"].values, float), np.asarray(ds["E_impact"].values, float)
        if es.size and ei.size and np.isfinite(ei[-1]) and ei[-1] > 0:
            _put(out, "E_splash_over_E_impact", float(es[-1] / ei[-1]),
                 f"{source}: E_splash/E_impact at the end")


_LIMITS = ("courant", "diffusion", "grains", "dt_max")


def _health(ds: xr.Dataset | None, out: dict[str, Any], dt_max: float | None,
            dt_fixed: float | None) -> None:
    """Step limits, loading, stiffness and parcel balance from the series (solver/diagnostics/health.py)."""
    from ..analysis.series import limiting_step
    if ds is None or "dt_courant" not in ds.variables:
        return
    cand = np.stack([np.asarray(ds[f"dt_{k}"].values, float) for k in ("courant", "diffusion", "grains")]
                    + [np.full(ds["dt_courant"].shape, dt_max if dt_max else np.inf)])
    cand = np.where(np.isfinite(cand), cand, np.inf)
    ok = np.isfinite(cand).any(axis=0)
    if dt_fixed is not None:
        out["limiting_step"] = "fixed"
        used = np.full(cand.shape[1], float(dt_fixed))
    elif ok.any():
        which = [limiting_step(*cand[:, i]) for i in np.flatnonzero(ok)]
        shares = {k: which.count(k) / len(which) for k in _LIMITS}
        k = max(shares, key=shares.get)
        out["limiting_step"] = f"{k} ({100.0 * shares[k]:.0f} %)"
        out["limiting_step_shares"] = shares
        used = cand.min(axis=0)
    else:
        return
    src = out.setdefault("_sources", {})
    src["limiting_step"] = "samples.nc: argmin of dt_courant, dt_diffusion, dt_grains, dt_max per record"
    used = np.where(ok, used, np.nan)
    if np.isfinite(used).any():
        out["dt_median"] = float(np.nanmedian(used))
    series = {k: np.asarray(ds[k].values, float) for k in ("loading_max", "parcel_balance")
              if k in ds.variables}
    lm, pb = series.get("loading_max"), series.get("parcel_balance")
    if lm is not None and np.isfinite(lm).any():
        _put(out, "loading_max", float(np.nanmax(lm)),
             "samples.nc: max over the run of loading_max")
        # the overshoot of the first seconds loads the cells most; the second half is the
        # layer near its equilibrium
        late = lm[lm.size // 2:]
        if np.isfinite(late).any():
            out["loading_max_second_half"] = float(np.nanmedian(late))
    if lm is not None and np.isfinite(r := used / np.asarray(ds["tau_c_min"].values, float)).any():
        _put(out, "dt_over_tau_c", float(np.nanmax(r)),
             "samples.nc: max over the run of (allowed step) / tau_c_min")
    if pb is not None and np.isfinite(pb).any():
        _put(out, "parcel_balance", float(np.nanmax(np.abs(pb))),
             "samples.nc: max |parcel_balance|")
    fields = [v for v in ("u", "v", "w", "e") if v in ds.variables]
    series = [v for v in ("dt_courant", "u_star_ref", "G_tot_series") if v in ds.variables]
    if fields or series:
        out["finite"] = bool(all(np.isfinite(ds[v].values).all() for v in fields)
                             and all(np.isfinite(ds[v].values[1:]).all() for v in series))
        src["finite"] = "samples.nc: " + ", ".join(fields + series)


def _column_stress(ds: xr.Dataset | None, out: dict[str, Any]) -> None:
    """Column stress residual (module docstring) from analysis.nc's uw_flux and tau_p; the u range
    of the last u(0.1 m) plane where the samples give none."""
    if ds is None:
        return
    if "u_snapshot" in ds.variables:
        v = ds["u_snapshot"].values
        _put(out, "u_min", float(np.nanmin(v)), "analysis.nc: last u(0.1 m) plane only")
        _put(out, "u_max", float(np.nanmax(v)), "analysis.nc: last u(0.1 m) plane only")
    if "uw_flux" not in ds.variables or "tau_p" not in ds.variables:
        return
    z = np.asarray(ds["z"].values, float)
    zr = float(ds.attrs.get("z_ref_eff", ds["z_ref_eff"].values if "z_ref_eff" in ds.variables else 2.0))
    tau = (-float(ds.attrs.get("rho", 1.2)) * np.asarray(ds["uw_flux"].values, float)
           + np.asarray(ds["tau_p"].values, float))
    use = (z <= zr + 1e-9) & np.isfinite(tau)
    use[:1] = False        # the first level's stress is the wall model's, not a resolved flux
    if use.sum() >= 3 and (mean := float(np.mean(tau[use]))) > 0:
        _put(out, "column_stress_residual", float(np.max(np.abs(tau[use] / mean - 1.0))),
             "analysis.nc: -rho uw_flux + tau_p, levels 2 to z_ref_eff")


def _open_samples(path: Path) -> xr.Dataset | None:
    """samples.nc may be large: read only the variables the table uses."""
    keep = ("max_cfl", "u", "v", "w", "e", "E_splash", "E_impact", "dt_courant",
            "dt_diffusion", "dt_grains", "loading_max", "tau_c_min", "parcel_balance", "u_star_ref",
            "G_tot_series")
    try:
        with NC_LOCK, xr.open_dataset(path, engine="netcdf4") as ds:
            sub = ds[[v for v in keep if v in ds.variables]].load()
            sub.attrs = dict(ds.attrs)
            return sub
    except Exception:
        return None


def _samples_of(runs: dict[str, RunData],
                samples: dict[str, str | Path | None] | None) -> dict[str, xr.Dataset | None]:
    """Each run's samples.nc (the table's variables only), opened once."""
    paths = {label: (samples or {}).get(label) or (r.ds.attrs.get("samples_path") if r.ok else None)
             for label, r in runs.items()}
    return {label: _open_samples(Path(p)) for label, p in paths.items() if p and Path(p).is_file()}


def stability_rows(runs: dict[str, RunData], failures: dict[str, str] | None = None,
                   samples: dict[str, str | Path | None] | None = None,
                   checkpoints: dict[str, dict] | None = None,
                   expect_blowup: set[str] | frozenset[str] = frozenset(),
                   opened: dict[str, xr.Dataset | None] | None = None) -> list[dict[str, Any]]:
    """One row per run; ``opened`` (label -> samples dataset) saves reopening what the caller has."""
    failures, checkpoints = failures or {}, checkpoints or {}
    opened = _samples_of(runs, samples) if opened is None else opened
    rows = []
    for label, r in runs.items():
        row: dict[str, Any] = {"label": label}
        blew = label in failures and "SolverBlowUp" in str(failures[label])
        row["status"] = ("failed" if label in failures else "completed" if r.ok else
                         f"no result ({r.status})")
        if label in expect_blowup:
            row["expected"] = "blow-up"
            row["status"] = ("blew up as expected" if blew else
                             "failed (not by a blow-up)" if label in failures else
                             "completed: the expected blow-up did not happen")
        if label in failures:
            row["error"] = str(failures[label])
            row["finite"] = False if blew else None
        if label in checkpoints:
            row["checkpoint_kept"] = checkpoints[label]
        _from_ds(r.ds, row, "analysis.nc")
        sds = opened.get(label)
        if sds is not None:
            _from_ds(sds, row, "samples.nc")
            if r.scene:
                fid = r.scene.get("fidelity") or {}
                t = fid.get("time") or {}
                dt_fixed = fid.get("saltation_dt_fixed") or t.get("dt_fixed")
                _health(sds, row, t.get("dt_max"), dt_fixed)
        _column_stress(r.ds, row)
        if math.isfinite(r.wall_time_s):
            row["wall_time_s"] = r.wall_time_s
        rows.append(row)
    return rows


def _ckpt_text(row: dict) -> str:
    c = row.get("checkpoint_kept")
    if not c:
        return " No checkpoint was kept."
    t = c.get("t_since_activation")
    when = f" at {t:.3f} s after activation" if isinstance(t, (int, float)) and math.isfinite(t) else ""
    return f" Checkpoint kept{when}: {c.get('path')}."


def _figure(series: dict[str, xr.Dataset]):
    """Per scene: the step each limit allows (a) and the most loaded cell's grain-to-air mass ratio
    (b) over the saltation run. Returns None when no run recorded them."""
    from matplotlib.figure import Figure
    runs = {k: v for k, v in series.items() if v is not None and "dt_courant" in v.variables}
    if not runs:
        return None
    fig = Figure(figsize=(11, 4.4), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2, sharex=True)
    colours = [f"C{i}" for i in range(10)]
    for (label, ds), c in zip(runs.items(), colours):
        t = np.asarray(ds["time_series"].values, float)
        ax1.plot(t, ds["dt_diffusion"].values, color=c, lw=1.2, label=label)
        ax1.plot(t, ds["dt_courant"].values, color=c, lw=0.8, ls=":")
        ax2.plot(t, ds["loading_max"].values, color=c, lw=1.0, label=label)
    ax1.set(yscale="log", xlabel="time since activation [s]", ylabel="allowed step [s]")
    ax1.set_title("(a) diffusion limit (solid), Courant limit (dotted)")
    ax2.set(yscale="log", xlabel="time since activation [s]",
            ylabel="largest grain / air mass in a cell [-]")
    ax2.set_title("(b) mass loading of the most loaded cell")
    ax2.legend(fontsize=7, loc="upper right")
    return fig


def _cell(row: dict, key: str) -> str:
    v = row.get(key)
    if key == "finite":
        return "n/a" if v is None else ("yes" if v else "no")
    if key in ("status", "limiting_step"):
        return str(v or "n/a")
    return fmt(v) if isinstance(v, (int, float)) and math.isfinite(v) else "n/a"


def build_stability_report(runs: dict[str, str | Path | None] | dict[str, RunData], report_dir: Path,
                           failures: dict[str, str] | None = None,
                           samples: dict[str, str | Path | None] | None = None,
                           wall_times: dict[str, float] | None = None,
                           checkpoints: dict[str, dict] | None = None,
                           expect_blowup: set[str] | frozenset[str] = frozenset(),
                           provenance: dict[str, Any] | None = None) -> dict[str, Any]:
    """Write ``stability.md`` and ``stability.json`` (``{**provenance, "scenes": [row, ...]}``)
    in ``report_dir``; return {"rows", "html", "files"}."""
    report_dir = Path(report_dir)
    report_dir.mkdir(parents=True, exist_ok=True)
    loaded = load_runs(runs, {"wall_times": wall_times or {}})
    for label in failures or {}:
        if label not in loaded:
            loaded[label] = RunData(label, None, None, status="no archive")
    opened = _samples_of(loaded, samples)
    rows = stability_rows(loaded, failures, samples, checkpoints, expect_blowup, opened)
    files = [report_dir / "stability.md", report_dir / "stability.json"]
    fig_html = ""
    fig = _figure(opened)
    if fig is not None:
        files += save_figure(fig, report_dir, "stability", 110)
        fig_html = figure_html("stability", "allowed steps and mass loading per scene")
    heads = ["scene"] + [h for _, h in STABILITY_COLUMNS]
    cells = [[row["label"]] + [_cell(row, k) for k, _ in STABILITY_COLUMNS] for row in rows]
    md = ["# Stability of extreme scenes", "", *md_table(heads, cells)]
    errs = [r for r in rows if r.get("error")]
    if errs:
        md += ["", "## Failures", ""] + [f"* **{r['label']}** ({r['status']}): `{r['error']}`"
                                         + _ckpt_text(r) for r in errs]
    md += ["", "Sources of each value (n/a: not found in the archives):", ""]
    md += [f"* {row['label']}: " + "; ".join(f"{k} ← {v}" for k, v in row["_sources"].items())
           for row in rows if row.get("_sources")]
    (report_dir / "stability.md").write_text("\n".join(md) + "\n", encoding="utf-8")
    write_json(report_dir / "stability.json", {**(provenance or {}), "scenes": rows})
    bad = [row["status"] not in ("completed", "blew up as expected") for row in rows]
    e = html.escape
    h = html_table(heads, cells, lambda i, j: "bad" if i >= 0 and j == 1 and bad[i] else "")
    if errs:
        h += "<ul>" + "".join(f"<li><b>{e(r['label'])}</b> ({e(r['status'])}): "
                              f"<code>{e(r['error'])}</code>{e(_ckpt_text(r))}</li>"
                              for r in errs) + "</ul>"
    return {"rows": rows, "html": fig_html + h, "files": files}
