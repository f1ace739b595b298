"""Model variants replicated over seeds, side by side: the table of a study whose scene labels read
``c<case>_<variant>_s<seed>`` (workflows/investigations/streamers-box/streamers-box.toml), or
``<variant>_s<seed>`` with the case from the run's own case number (the equilibrium screen's,
reports/investigations/equilibrium/screen).

    saltstudy probe variants-report reports/investigations/streamers/box   # reads summary.json, writes variants.{md,json}

Per case and variant: the mean over seeds of each statistic and half the range between seeds (with
two seeds, the seed-to-seed scatter: a difference between variants smaller than it is not a
result), and the ratio of each variant's mean to the first variant's (the baseline, in the order
the study lists them). Beside the analysis' scalars, from each run's analysis archive:

* ``phi_air`` (2-25 cm): kappa z dU/dz / sqrt|<u'w'>_air|, the air's own non-dimensional shear in
  the grain layer (1 for a log law of the air's stress), mean over the levels between 2 and 25 cm;
* ``N_air``: the real grains in the air, mean parcel count x the parcel weight;
* ``St_height`` and ``eps_drag_share``: where the Stokes number of section 4.2 falls below 1 and
  which of eq. 13's two sinks makes the eddies short-lived at 0.1 z_m (``stokes_budget``).
"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .streaks import VariantGrid, streak_curves, streaks_figure

__all__ = ["LABEL", "STATS", "variants_table", "build_variants_report", "phi_air", "stokes_budget",
           "layer_figure", "variant_runs"]

#: c<case>_<variant>_s<seed>, or <variant>_s<seed>
LABEL = re.compile(r"^(?:c(?P<case>\d+)_)?(?P<variant>[A-Za-z0-9.\-]+)_s(?P<seed>\d+)$")
#: the statistics of the table: key -> (heading, scale, unit)
STATS: dict[str, tuple[str, float, str]] = {
    "u_star_s_stress": ("u* at z_ref (stress)", 1.0, "m/s"),
    "z0s_stress": ("z0s (stress reading)", 1e3, "mm"),
    "z_m": ("z_m", 1.0, "m"),
    "G_tot": ("G_tot", 1e3, "g/m/s"),
    "G_decay_height": ("G e-folding height", 1e2, "cm"),
    "N_air": ("grains in the air", 1e-6, "millions"),
    "n_parcels_per_m2_at_Q": ("airborne parcels per m2 at the case's Q", 1.0, "m-2"),
    "first_cell_parcel_fraction": ("share of them in the first cell", 1.0, "-"),
    "impact_speed_mean": ("mean impact speed", 1.0, "m/s"),
    "replacement_mean": ("grains back per impact", 1.0, "-"),
    "hop_time_median": ("median hop flight time", 1e3, "ms"),
    "hop_length_median": ("median hop length", 1e2, "cm"),
    "phi_air": ("phi_air 2-25 cm", 1.0, "-"),
    "tau_p_surface_fraction": ("tau_p(0)/rho u*^2", 1.0, "-"),
    "bed_fluid_stress_fraction": ("bed fluid stress / rho u*^2", 1.0, "-"),
    "mu_b": ("mu_b from the impacts", 1.0, "-"),
    "mu_b_budget": ("mu_b from the budget", 1.0, "-"),
    "airborne_mass_per_m2": ("airborne mass", 1e3, "g/m2"),
    "n_parcels_per_m2_at_Q_above_first_cell": ("parcels per m2 at Q above the first cell", 1.0,
                                               "m-2"),
    "St_height": ("St < 1 above", 1.0, "z/z_m"),
    "eps_drag_share": ("eps_drag/eps_tot at 0.1 z_m", 1.0, "-"),
    "lambda_y": ("lambda_y", 1.0, "m"),
    "lambda_x": ("lambda_x", 1.0, "m"),
    "lambda_y_paper_count": ("lambda_y, noise of the paper's count", 1.0, "m"),
    "lambda_x_paper_count": ("lambda_x, noise of the paper's count", 1.0, "m"),
    "delta_y": ("delta_y of C_p", 1.0, "m"),
    "delta_y_u": ("delta_y of u at 0.1 m", 1.0, "m"),
}
KAPPA = 0.40


def phi_air(archive: str | Path, z_lo: float = 0.02, z_hi: float = 0.25) -> float:
    """Mean over the levels in [z_lo, z_hi] of kappa z dU/dz / sqrt|<u'w'>| of the air [-]."""
    import xarray as xr

    from ..ncio import NC_LOCK

    with NC_LOCK, xr.open_dataset(archive) as ds:
        z = np.asarray(ds["z"].values, dtype=float)
        u = np.asarray(ds["u_mean"].values, dtype=float)
        uw = ds["uw_flux"]
        # on the cell centres, or on the faces z_w
        tau = (np.abs(uw.values) if uw.dims == ("z",)
               else np.abs(np.interp(z, ds[uw.dims[0]].values, uw.values)))
    # z dU/dz = dU/d ln z: differences in ln z are exact for a log law on any stretched grid
    phi = KAPPA * np.gradient(u, np.log(z)) / np.sqrt(np.maximum(tau, 1e-12))
    sel = (z >= z_lo) & (z <= z_hi)
    return float(phi[sel].mean()) if sel.any() else math.nan


def stokes_budget(archive: str | Path, at: float = 0.1) -> dict[str, float]:
    """From an analysis archive: ``St_height``, the lowest z/z_m above which St < 1 up to z_m
    (the paper's Fig. 12 reading: ≈ 0.1 for grains of 200 µm and more), and ``eps_drag_share``,
    the grains' drag's part eps_drag/eps_tot of eq. 13's dissipation at ``at`` z_m (log-linear
    between the levels) [-]."""
    import xarray as xr

    from ..ncio import NC_LOCK
    from .tables import st_height

    with NC_LOCK, xr.open_dataset(archive) as ds:
        z = np.asarray(ds["z"].values, dtype=float)
        st = np.asarray(ds["St"].values, dtype=float)
        e_d = np.asarray(ds["eps_drag"].values, dtype=float)
        e_t = np.asarray(ds["eps_tot"].values, dtype=float)
        zm = float(ds["z_m"].values)
    share = math.nan
    ok = np.isfinite(e_d) & np.isfinite(e_t) & (e_t > 0)
    if ok.sum() >= 2 and math.isfinite(zm) and zm > 0:
        share = float(np.interp(math.log(at * zm), np.log(z[ok]), e_d[ok] / e_t[ok]))
    return {"St_height": st_height(z, st, zm), "eps_drag_share": share}


def _value(run: dict[str, Any], key: str, q_of: dict[str, float],
           budgets: dict[str, dict[str, float]] | None = None) -> float:
    if key in ("St_height", "eps_drag_share"):
        arch = run.get("archive")
        if not arch:
            return math.nan
        budgets = {} if budgets is None else budgets
        if arch not in budgets:          # both columns from one read of the archive
            try:
                budgets[arch] = stokes_budget(arch)
            except (OSError, KeyError, ValueError):
                budgets[arch] = {}
        return budgets[arch].get(key, math.nan)
    if key == "phi_air":
        arch = run.get("archive")
        try:
            return phi_air(arch) if arch else math.nan
        except (OSError, KeyError, ValueError):
            return math.nan
    if key == "N_air":
        n = run.get("n_parcels_mean")
        q = q_of.get(run.get("label", ""), math.nan)
        return float(n) * q if n is not None else math.nan
    v = run.get(key)
    return float(v) if isinstance(v, (int, float)) else math.nan


def variants_table(summary: dict[str, Any], parcel_weight: dict[str, float] | None = None) -> dict:
    """{"variants": [...], "cases": {case: {variant: {stat: {"mean", "half_range", "n", "ratio"}}}}}
    from a study's summary.json (module doc). ``parcel_weight``: label -> real grains per parcel."""
    q_of = parcel_weight or {}
    groups: dict[int, dict[str, list[dict]]] = {}
    order: list[str] = []
    for run in summary.get("cases", {}).values():
        m = LABEL.match(str(run.get("label", "")))
        if not m or run.get("status") != "ok":
            continue
        number = m["case"] if m["case"] is not None else run.get("case_number")
        if number is None:
            continue
        case, variant = int(number), m["variant"]
        if variant not in order:
            order.append(variant)
        groups.setdefault(case, {}).setdefault(variant, []).append(run)
    out: dict[str, Any] = {"variants": order, "cases": {}}
    budgets: dict[str, dict[str, float]] = {}
    for case in sorted(groups):
        per: dict[str, Any] = {}
        for variant in order:
            runs = groups[case].get(variant, [])
            stats = {}
            for key in STATS:
                vals = np.array([_value(r, key, q_of, budgets) for r in runs], dtype=float)
                vals = vals[np.isfinite(vals)]
                stats[key] = {"mean": float(vals.mean()) if vals.size else math.nan,
                              "half_range": float(0.5 * np.ptp(vals)) if vals.size > 1 else math.nan,
                              "n": int(vals.size), "values": vals.tolist()}
            per[variant] = stats
        base = per[order[0]] if order else {}
        for variant in order:
            for key, st in per[variant].items():
                b = base.get(key, {}).get("mean", math.nan)
                st["ratio"] = st["mean"] / b if (math.isfinite(b) and b != 0) else math.nan
        out["cases"][case] = per
    return out


def _cell(st: dict[str, Any], scale: float) -> str:
    m, h = st["mean"], st["half_range"]
    if not math.isfinite(m):
        return "—"
    txt = f"{m * scale:.3g}"
    if math.isfinite(h):
        txt += f" ± {h * scale:.2g}"
    return txt


def build_variants_report(directory: str | Path, parcel_weight: dict[str, float] | None = None) -> dict:
    """variants.json and variants.md in ``directory`` from its summary.json; returns the table."""
    directory = Path(directory)
    summary = json.loads((directory / "summary.json").read_text(encoding="utf-8"))
    if parcel_weight is None:
        parcel_weight = _parcel_weights(summary)
    table = variants_table(summary, parcel_weight)
    if not table["cases"]:
        raise ValueError(f"{directory}: no run labelled [c<case>_]<variant>_s<seed> in summary.json")
    (directory / "variants.json").write_text(json.dumps(table, indent=1), encoding="utf-8")
    lines = ["Mean over seeds ± half the range between them; (×) the ratio to the first variant.", ""]
    for case, per in table["cases"].items():
        lines += [f"### Case {case}", "",
                  "| statistic | " + " | ".join(table["variants"]) + " |",
                  "|---|" + "---|" * len(table["variants"])]
        for key, (head, scale, unit) in STATS.items():
            cells = []
            for i, v in enumerate(table["variants"]):
                st = per[v][key]
                c = _cell(st, scale)
                if i and math.isfinite(st["ratio"]):
                    c += f" (×{st['ratio']:.2f})"
                cells.append(c)
            lines.append(f"| {head} [{unit}] | " + " | ".join(cells) + " |")
        lines.append("")
    (directory / "variants.md").write_text("\n".join(lines), encoding="utf-8")
    layer_figure(summary, directory / "layer.png")
    streaks_figure(variant_runs(summary, streak_curves), directory / "streaks.png")
    return table


def _parcel_weights(summary: dict[str, Any]) -> dict[str, float]:
    """label -> real grains per parcel, from each run's analysis archive (attribute ``Q``)."""
    import xarray as xr

    from ..ncio import NC_LOCK

    out = {}
    for run in summary.get("cases", {}).values():
        arch = run.get("archive")
        if not arch:
            continue
        try:
            with NC_LOCK, xr.open_dataset(arch) as ds:
                q = ds.attrs.get("Q")
            if q is not None:
                out[str(run.get("label"))] = float(q)
        except OSError:
            continue
    return out


def variant_runs(summary: dict[str, Any], read: Callable[[str], Any]) -> dict[int, list]:
    """case -> [(variant, seed, read(archive))] for every finished run labelled
    ``[c<case>_]<variant>_s<seed>`` whose archive ``read`` can use (not None)."""
    runs: dict[int, list] = {}
    for run in summary.get("cases", {}).values():
        m = LABEL.match(str(run.get("label", "")))
        if not m or run.get("status") != "ok" or not run.get("archive"):
            continue
        number = m["case"] if m["case"] is not None else run.get("case_number")
        cur = read(run["archive"])
        if cur is not None and number is not None:
            runs.setdefault(int(number), []).append((m["variant"], int(m["seed"]), cur))
    return runs


def _layer_curves(archive: str | Path) -> dict[str, np.ndarray] | None:
    """The anatomy arrays of one analysis archive (analysis/layer.py), or None without them."""
    import xarray as xr

    from ..ncio import NC_LOCK

    names = ("band_parcels_per_m2_at_Q", "impact_speed_pdf", "replacement_by_speed",
             "hop_time_pdf", "hop_length_pdf")
    try:
        with NC_LOCK, xr.open_dataset(archive) as ds:
            if any(n not in ds for n in names):
                return None
            out = {n: np.asarray(ds[n].values, dtype=float) for n in names}
            for c in ("v_imp", "hop_time", "hop_length"):
                out[c] = np.asarray(ds[c].values, dtype=float)
    except (OSError, KeyError, ValueError):
        return None
    return out


def layer_figure(summary: dict[str, Any], path: Path) -> Path | None:
    """One row per case; per variant (colour) and seed (line style, bar shade): the airborne
    parcels per m2 at the case's Q by height band, the impact-speed density, the grains back per
    impact against impact speed (1: a steady layer) and the hop flight-time density; the paper's
    ~2,000 parcels per m2 ([28], [31]) beside the bands. None when no run carries the anatomy."""
    from .saltation import paper_parcels_per_m2

    runs = variant_runs(summary, _layer_curves)
    if not runs:
        return None
    grid = VariantGrid(runs)
    variants, colours, seeds = grid.variants, grid.colours, grid.seeds
    width = 0.8 / (len(variants) * len(seeds))
    for row, case in enumerate(grid.cases):
        ax = grid.axes[row]
        for v, seed, c in grid.rows(case):
            k = variants.index(v) * len(seeds) + seeds.index(seed)
            ls = grid.line_style(seed)
            b = c["band_parcels_per_m2_at_Q"]
            x = np.arange(b.size) - 0.4 + (k + 0.5) * width
            ax[0].bar(x, b, width, color=colours[v], alpha=1.0 if seeds.index(seed) == 0 else 0.55,
                      label=f"{v} s{seed} (total {np.nansum(b):,.0f})")
            ax[1].plot(c["v_imp"], c["impact_speed_pdf"], ls, color=colours[v])
            ok = np.isfinite(c["replacement_by_speed"])
            ax[2].plot(c["v_imp"][ok], c["replacement_by_speed"][ok], ls, color=colours[v], lw=1)
            ax[3].plot(1e3 * c["hop_time"], c["hop_time_pdf"] / 1e3, ls, color=colours[v],
                       label=f"{v} s{seed}")
        ax[0].axhline(paper_parcels_per_m2(), color="0.4", lw=2, ls="--",
                      label="Dupont et al. 2013 [28], [31]: ~2,000 (all heights)")
        ax[0].set_xticks(range(3), ["first cell", "to 5 cm", "above"])
        ax[0].set_ylabel(f"case {case}: airborne parcels\nper m$^2$ at the case's Q")
        ax[0].legend(fontsize=7)
        ax[1].set(xlabel="impact speed [m s$^{-1}$]", ylabel="probability density [s m$^{-1}$]",
                  xlim=(0, 5))
        ax[2].axhline(1.0, color="0.5", lw=0.8)
        ax[2].set(xlabel="impact speed [m s$^{-1}$]", ylabel="grains back per impact",
                  xlim=(0, 5), ylim=(0, 5))
        ax[3].set(xlabel="hop flight time [ms]", ylabel="probability density [ms$^{-1}$]",
                  xscale="log")
        ax[3].legend(fontsize=7)
    grid.fig.suptitle("The saltation layer by case (row), variant (colour) and seed (line style, "
                      "bar shade)", fontsize=10)
    return grid.save(path)
