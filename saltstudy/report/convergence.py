"""Error against run time for a convergence ladder (one case at a ladder of fidelities).

Per statistic (``CONV_STATS``) and rung: its value ± the larger of two noise estimates
(``NOISE_NOTE``); the relative difference from the reference rung (the study's ``reference``
fidelity, else the finest: the declared order's last, else the largest wall time) and, where the
paper gives a value, from the paper (:func:`_paper_error`); both against the rung's wall time
(spin-up + saltation); the cheapest rung within 10 % and 25 % of the reference among those
whose own bar is no wider than the threshold (:func:`_resolves`). ``N_air`` (mean parcel count x
Q) compares across parcel weights. Each case is compared with its own run at that fidelity.
"""
from __future__ import annotations

import copy
import html
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from matplotlib.figure import Figure

from .data import RunData, load_runs
from .plotting import save_figure
from .reference import PAPER_COLOR, PAPER_LABEL, paper_results, paper_table2
from .tables import figure_html, fmt, html_table, md_table, st_below_one_height, write_json

__all__ = ["CONV_STATS", "ConvergenceResult", "convergence_analysis", "convergence_by_case",
           "build_convergence_report", "ladder_summary", "sampled_extent", "seed_noise"]

#: statistic -> (label, paper Table 2 key or None)
CONV_STATS: dict[str, tuple[str, str | None]] = {
    "u_star_s_stress": ("u*s (stress at 2 m)", "u_star_s"), "u_star_s": ("u*s (free fit)", "u_star_s"),
    "z0s_stress": ("z0s", None), "z_m": ("z_m", "fig4"),
    "G_tot": ("G_tot", None), "G_decay_height": ("z_q", None),
    "sigma_G_over_G_tot": ("σG/G_tot", "range"),
    "lambda_x": ("λx", "lambda_x_m"), "lambda_y": ("λy", "lambda_y_m"), "delta_y": ("δy", "delta_y_m"),
    "tau_p_surface_fraction": ("τp(0)/ρu*s²", "tau_p6"), "R_cu_upper": ("R_cu upper", "rcu"),
    "St_height": ("St < 1 above z/z_m", "st"), "N_air": ("N_air", None),
}
THRESHOLDS = (0.10, 0.25)
NOISE_NOTE = ("Each value ± the larger of two estimates of one run's noise: half the difference "
              "between its two half-window values, and, for a case whose study repeats a run with "
              "only the seed changed, the seeds' standard deviation scaled to the run's sampled "
              "extent (duration x box area; variance taken inversely proportional to it). * marks a "
              "difference from the reference inside the two runs' bars added in quadrature. The "
              "half windows alone understate the scatter: two windows of the same run of case 2 "
              "differed by 10 % in u*s read at 2 m against bars of 2-5 % "
              "(reports/investigations/knobs/FINDINGS.md).")


@dataclass
class ConvergenceResult:
    rungs: list[dict[str, Any]]                # ordered coarse -> fine
    finest: str | None                         # the reference rung (see module docstring)
    cheapest: dict[str, dict[str, str | None]]  # stat -> {"10%": label, "25%": label}
    named_reference: bool = False              # a sensitivity study: rungs are not a sequence
    seed_groups: list[list[str]] = field(default_factory=list)  # runs differing only in the seed
    on_ladder: list[str] = field(default_factory=list)   # the declared rungs (not extra scenes)


#: the text's statements a statistic is compared with: key -> (its name in the paper's results,
#: whether it holds for a run of that case and mu1 [m])
_STATED = {
    # the paper's ~0.1 z_m holds for soils with mu1 >= 200 um (its Fig. 12)
    "st": ("fig12_St_below_1_above_z_over_zm", lambda case, mu1: mu1 >= 200e-6 * (1 - 1e-9)),
    "rcu": ("fig11_Rcu_upper_layer", lambda case, mu1: (case or 0) <= 6),
    "tau_p6": ("fig6_taup_surface_fraction_case6", lambda case, mu1: case == 6),   # case 6 only
}


def _paper_error(stat: str, value: float, case: int | None, mu1: float = math.nan) -> float:
    key = CONV_STATS[stat][1]
    if key is None or not math.isfinite(value):
        return math.nan
    if key in _STATED:
        name, applies = _STATED[key]
        ref = float(paper_results().get(name, math.nan))
        return abs(value - ref) / ref if applies(case, mu1) and math.isfinite(ref) else math.nan
    if key == "fig4":       # z_m on the paper's Fig. 4 line: linear in u*s over cases 1-6
        if case is None or not 1 <= case <= 6:
            return math.nan
        lo, hi = paper_results().get("fig4_zm_cases_1_to_6_m", [math.nan, math.nan])
        u, u1, u6 = (paper_table2().get(c, {}).get("u_star_s", math.nan) for c in (case, 1, 6))
        ref = lo + (hi - lo) * (u - u1) / (u6 - u1)
        return abs(value - ref) / ref if math.isfinite(ref) else math.nan
    if key == "range":
        lo, hi = paper_results().get("fig13_sigmaG_over_Gtot", [math.nan, math.nan])
        if lo <= value <= hi:
            return 0.0
        b = lo if value < lo else hi
        return abs(value - b) / b
    ref = paper_table2().get(case or -1, {}).get(key, math.nan)
    return abs(value - ref) / abs(ref) if math.isfinite(ref) and ref != 0 else math.nan


def _error_bar(r: RunData, stat: str) -> float:
    """Half the difference between the statistic over the two halves of the sampling window
    (analysis ``<stat>_halves``): the noise of one window. NaN where not recorded."""
    v = r.var(f"{stat}_halves")
    a = np.asarray(v.values if v is not None else [], dtype=np.float64)
    return float(abs(a[1] - a[0]) / 2.0) if a.size == 2 and np.isfinite(a).all() else math.nan


def sampled_extent(r: RunData) -> float:
    """The run's sampled duration x horizontal box area [s m2], read from its scene: the number of
    roughly independent pieces of turbulence a window average holds grows with it. NaN if the
    archive does not say."""
    fid = r.scene.get("fidelity") or {}
    smp, grid = fid.get("sampling") or {}, fid.get("grid") or {}
    dur = float(smp.get("interval", math.nan)) * (float(smp.get("count", math.nan)) - 1)
    area = float(grid.get("Lx", math.nan)) * float(grid.get("Ly", math.nan))
    return dur * area if dur > 0 and area > 0 else math.nan


def _replicate_key(r: RunData) -> str | None:
    """The run's configuration without its seed and names: equal keys and different seeds make
    two realizations of one run."""
    if not r.ok or "case" not in r.scene or "fidelity" not in r.scene:
        return None
    sc = copy.deepcopy(r.scene)
    sc.pop("label", None)
    for k in ("seed", "name", "description"):
        sc["case"].pop(k, None)
    return json.dumps(sc, sort_keys=True, default=str)


def seed_noise(runs: dict[str, RunData]) -> tuple[dict[str, float], list[list[str]]]:
    """({stat: the seeds' relative variance x sampled extent, pooled}, [labels of each group of
    runs alike but for the seed]) (docs/ARCHITECTURE.md, "analysis.nc"). The variance of a
    space-time average falls as 1/extent only once the window and box hold many correlation
    lengths: not in boxes a few streamers wide (smoke, quick)."""
    groups: dict[str, dict[str, RunData]] = {}
    for r in runs.values():
        k = _replicate_key(r)
        if k is not None:
            # one run per seed: a run listed twice (e.g. an archive kept under two labels) is the
            # same realization and would shrink the scatter
            seed = json.dumps(r.scene["case"].get("seed"), default=str)
            groups.setdefault(k, {}).setdefault(seed, r)
    reps = [list(g.values()) for g in groups.values() if len(g) >= 2]
    pooled: dict[str, float] = {}
    for s in CONV_STATS:
        acc = []
        for g in reps:
            v = np.array([_value(r, s) for r in g], float)
            ext = sampled_extent(g[0])
            if np.isfinite(v).all() and math.isfinite(ext) and abs(v.mean()) > 0:
                acc.append(float(np.var(v, ddof=1)) / v.mean() ** 2 * ext)
        pooled[s] = float(np.mean(acc)) if acc else math.nan
    return pooled, [sorted(r.label for r in g) for g in reps]


def _noise(bars: tuple[float, ...]) -> float:
    return max((b for b in bars if math.isfinite(b)), default=math.nan)


def _value(r: RunData, stat: str) -> float:
    if stat == "N_air":
        return r.scalar("n_parcels_mean") * r.attr("Q")
    if stat == "St_height":
        return st_below_one_height(r) if r.ok else math.nan
    return r.scalar(stat)


def _grid_of(r: RunData) -> dict[str, float]:
    """The rung's cost knobs read from its archive: horizontal spacing, first-level thickness [m]
    and real grains per parcel."""
    z_w, z = r.var("z_w"), r.var("z")
    dz1 = (float(z_w[1] - z_w[0]) if z_w is not None and z_w.size > 1 else
           2.0 * float(z[0]) if z is not None and z.size else math.nan)  # a centre: half its level
    # a level's thickness is a difference of stretched heights: 0.010000000000000021 is 1 cm
    dz1 = float(f"{dz1:.10g}")
    return {"dx": r.attr("dx"), "dy": r.attr("dy"), "dz_bottom": dz1, "Q": r.attr("Q")}


def convergence_by_case(runs: dict[str, RunData], order: list[str] | None = None,
                        reference: str | None = None, prior: dict[str, Any] | None = None
                        ) -> dict[int | None, ConvergenceResult]:
    """:func:`convergence_analysis` for each case's runs, primary case first (most rungs, then the
    lowest case number). ``reference`` names one run; each case is compared with its run at the
    same fidelity (the label's part after ``@``). ``prior``: an earlier ``convergence.json`` whose
    rungs of each case this study's runs top (:func:`prior_rungs`)."""
    groups: dict[int | None, dict[str, RunData]] = {}
    for label, r in runs.items():
        groups.setdefault(r.case, {})[label] = r
    below = prior_rungs(prior) if prior else {}
    for case in below:
        groups.setdefault(case, {})
    ref_rung = reference.split("@", 1)[1] if reference and "@" in reference else None
    out: dict[int | None, ConvergenceResult] = {}
    size = {c: len(groups[c]) + (len(below[c].rungs) if c in below else 0) for c in groups}
    for case in sorted(groups, key=lambda c: (-size[c], c if c is not None else -1)):
        grp = groups[case]
        ref = reference if reference in grp else next(
            (l for l in grp if ref_rung is not None and l.endswith("@" + ref_rung)), None)
        out[case] = convergence_analysis(grp, [l for l in order or () if l in grp] or None, ref,
                                         below.get(case))
    return out


class PriorCase(NamedTuple):
    """One case of an earlier ``convergence.json``: its rungs as measured (coarse -> fine, without
    the comparison with its reference), that reference, its seed groups and its declared ladder."""
    rungs: list[dict[str, Any]]
    reference: str | None
    seed_groups: list[list[str]]
    ladder: set[str]


#: a row's numbers outside the per-statistic cells (JSON writes NaN as null)
_ROW_NUMBERS = ("wall_time_s", "dx", "dy", "dz_bottom", "Q", "spinup_wall_time_s",
                "sampled_extent_s_m2")


def prior_rungs(table: dict[str, Any]) -> dict[int | None, PriorCase]:
    """:class:`PriorCase` per case of an earlier ``convergence.json``. A rung's value, bars and
    error against the paper do not depend on the reference, so they are kept as recorded."""
    out: dict[int | None, PriorCase] = {}
    cases = table.get("cases") or {}
    for row in table.get("rungs") or []:
        case = row.get("case")
        meta = cases.get(str(case), {})
        if case not in out:
            ref = meta.get("reference")
            out[case] = PriorCase([], ref, [list(g) for g in meta.get("seed_replicates", [])],
                                  {x["label"] for x in meta.get("ladder_summary", [])} | {ref})
        kept = {k: v for k, v in row.items() if k not in ("reference", "err_finest", "within_noise")}
        for k, v in kept.items():
            if isinstance(v, dict):
                kept[k] = {s: math.nan if x is None else float(x) for s, x in v.items()}
            elif k in _ROW_NUMBERS and v is None:
                kept[k] = math.nan
        out[case].rungs.append(kept)
    return out


def _time_key(t: float) -> float:
    """A wall time to sort by, an unknown one last."""
    return t if math.isfinite(t) else math.inf


def _measure(r: RunData, pooled: dict[str, float]) -> dict[str, Any]:
    """A rung's row as it stands alone: settings, cost, and per statistic its value, its two noise
    estimates and the larger of them, and its error against the paper."""
    ext = sampled_extent(r)
    row: dict[str, Any] = {"label": r.label, "case": r.case, "fidelity": r.fidelity,
                           "status": r.status, "wall_time_s": r.wall_time_s, **_grid_of(r),
                           "spinup_wall_time_s": r.attr("spinup_wall_time_s"),
                           "sampled_extent_s_m2": ext, "values": {}, "error_bar": {},
                           "half_window_bar": {}, "seed_bar": {}, "err_paper": {}}
    for s in CONV_STATS:
        v = _value(r, s)
        # the seeds' bar: |value| sqrt(pooled / extent) (NaN where unknown)
        sb = abs(v) * math.sqrt(pooled[s] / ext)
        row["values"][s] = v
        row["half_window_bar"][s], row["seed_bar"][s] = hw, sb = (
            _error_bar(r, s), sb if math.isfinite(sb) else math.nan)
        row["error_bar"][s] = _noise((hw, sb))
        row["err_paper"][s] = _paper_error(s, v, r.case, r.mu1 if r.ok else math.nan)
    return row


def _pooled_of(rows: list[dict[str, Any]]) -> dict[str, float]:
    """The seeds' pooled relative variance x extent a table's rows were barred with
    (seed_bar = |value| sqrt(pooled / extent), :func:`seed_noise`)."""
    out = {}
    for s in CONV_STATS:
        est = [(row["seed_bar"][s] / row["values"][s]) ** 2 * row["sampled_extent_s_m2"]
               for row in rows if math.isfinite(row["seed_bar"].get(s, math.nan))
               and row["values"].get(s) and math.isfinite(row["sampled_extent_s_m2"])]
        out[s] = float(np.median(est)) if est else math.nan
    return out


def convergence_analysis(runs: dict[str, RunData], order: list[str] | None = None,
                         reference: str | None = None,
                         prior: PriorCase | None = None) -> ConvergenceResult:
    """``runs`` compared with the reference (module doc); ``prior``: an earlier table's rungs of
    this case (:func:`prior_rungs`), which ``runs`` top: the reference is then ``reference``, else
    the costliest of ``runs``, else the table's own."""
    present = [r for r in runs.values() if r.ok]
    if order:
        ranked = [runs[l] for l in order if l in runs]
        ranked += [r for r in runs.values() if r.label not in order]
    else:
        ranked = sorted(runs.values(), key=lambda r: _time_key(r.wall_time_s))
    finest = runs[reference] if reference in runs and runs[reference].ok else None
    if finest is None and order:
        finest = next((runs[l] for l in reversed(order) if l in runs and runs[l].ok), None)
    if finest is None and present:
        timed = [r for r in present if math.isfinite(r.wall_time_s)]
        finest = max(timed, key=lambda r: r.wall_time_s) if timed else present[-1]
    pooled, seed_groups = seed_noise(runs)
    below, ladder = [], set(order) if order else {r.label for r in runs.values()}
    ref_label = finest.label if finest is not None else None
    if prior is not None:
        below = [row for row in prior.rungs if row["label"] not in runs]
        kept = _pooled_of(below)
        pooled = {s: v if math.isfinite(v) else kept[s] for s, v in pooled.items()}
        seed_groups = prior.seed_groups + seed_groups
        ladder |= prior.ladder
        ref_label = ref_label or prior.reference
    rungs = below + [_measure(r, pooled) for r in ranked]
    ref = next((row for row in rungs if row["label"] == ref_label), None)
    for row in rungs:
        row["err_finest"], row["within_noise"] = {}, {}
        for s in CONV_STATS:
            v, eb = row["values"][s], row["error_bar"][s]
            f, ebf = (ref["values"][s], ref["error_bar"][s]) if ref is not None else (math.nan,) * 2
            row["err_finest"][s] = (abs(v - f) / abs(f)) if math.isfinite(v) and math.isfinite(f) \
                and f != 0 else math.nan
            # a difference from the reference inside the two runs' combined noise is not one
            noise = math.hypot(eb, ebf) if math.isfinite(eb) and math.isfinite(ebf) else math.nan
            row["within_noise"][s] = (bool(abs(v - f) <= noise) if math.isfinite(noise)
                                      and math.isfinite(v) and math.isfinite(f) else None)
    # the cheapest rung is read off the declared ladder: a study's extra scenes (a knob's
    # variant, a second seed) are rows to compare, not cheaper ways to the reference
    cheapest: dict[str, dict[str, str | None]] = {}
    for s in CONV_STATS:
        cheapest[s] = {}
        for th in THRESHOLDS:
            ok = [row for row in rungs if row["label"] in ladder and row["status"] == "ok"
                  and math.isfinite(row["err_finest"][s]) and row["err_finest"][s] <= th
                  and _resolves(row, s, th)]
            ok.sort(key=lambda row: _time_key(row["wall_time_s"]))
            cheapest[s][f"{th:.0%}"] = ok[0]["label"] if ok else None
    # a reference that is the top of the declared ladder is its finest rung, not a base of variants
    named = (prior is None and finest is not None and finest.label == reference
             and not (order and order[-1] == reference))
    return ConvergenceResult(rungs, ref_label, cheapest, named, seed_groups,
                             [row["label"] for row in rungs if row["label"] in ladder])


def _rung_name(row: dict[str, Any]) -> str:
    label = row["label"]
    if "@" in label:
        return label.split("@", 1)[1]
    # a named scene (a seed replicate) shares its rung's fidelity: name both, or two rungs read alike
    return f"{row['fidelity']} ({label})" if row.get("fidelity") else label


_STAT_COLORS = dict(zip(CONV_STATS, ("#1f77b4", "#aec7e8", "#ff7f0e", "#2ca02c", "#d62728",
                                     "#ff9896", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
                                     "#bcbd22", "#dbdb8d", "#98df8a", "#17becf"), strict=True))


def _figure(res: ConvergenceResult, case: int | None) -> Figure:
    fig = Figure(figsize=(11, 5.4), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2, sharex=True)
    fig.suptitle("Error against wall-clock time (spin-up + saltation)"
                 + (f", case {case}" if case is not None else ""))
    t = np.array([row["wall_time_s"] for row in res.rungs], float)
    not_finest = np.array([row["label"] != res.finest for row in res.rungs])
    markers = "osD^v<>PX*"
    floor = 1e-4   # an error of exactly 0 (inside the paper's range) is drawn here, hollow, unjoined
    for i, s in enumerate(CONV_STATS):
        lab, col, mk = CONV_STATS[s][0], _STAT_COLORS[s], markers[i % len(markers)]
        noise = np.array([row["within_noise"][s] is True for row in res.rungs])
        for ax, key, keep in ((ax1, "err_finest", not_finest), (ax2, "err_paper", True)):
            e = np.array([row[key][s] for row in res.rungs], float)
            ok = np.isfinite(e) & np.isfinite(t) & keep
            pos = ok & (e > 1e-9)      # below: round-off, shown as 0
            zero = ok & (e <= 1e-9)
            if pos.any():
                order = np.argsort(t[pos])
                # one-knob variants of a named reference are not a ladder: markers only
                ax.plot(t[pos][order], e[pos][order], marker=mk, color=col, lw=1.2, label=lab,
                        ls="none" if res.named_reference else "-")
                quiet = pos & noise
                if ax is ax1 and quiet.any():
                    # a difference inside the two runs' noise is not an error: its marker is hollow
                    ax.plot(t[quiet], e[quiet], marker=mk, color=col, mfc="white", ls="none")
            if zero.any():
                ax.plot(t[zero], np.full(zero.sum(), floor), marker=mk, mfc="none", color=col, ls="none",
                        label=None if pos.any() else f"{lab} (0)")
    for ax in (ax1, ax2):
        ax.set(xscale="log", yscale="log", xlabel="wall-clock time of the run [s]")
        if not ax.lines:           # nothing finite to draw (e.g. only a missing run): fixed limits
            ax.set(xlim=(1.0, 1e4), ylim=(1e-4, 2.0))
        ax.axhline(0.10, color="0.5", ls=":", lw=1)
        ax.axhline(0.25, color="0.5", ls="--", lw=1)
        ax.grid(alpha=0.3, which="both")
    # one key for both panels (a statistic has the same colour and marker in each), below them:
    # inside, fourteen entries hid the rungs that cost about the same
    handles = {lab: h for ax in (ax1, ax2) for h, lab in zip(*ax.get_legend_handles_labels())}
    if handles:
        fig.legend(list(handles.values()), list(handles.keys()), loc="outside lower center",
                   ncol=min(7, len(handles)), fontsize=8)
    ax1.set_ylabel("|relative difference| [-]   (10 % dotted, 25 % dashed)")
    ax1.set_title(f"(a) against the reference rung ({res.finest})", loc="left", fontsize=9)
    ax2.set_title(f"(b) against {PAPER_LABEL} (σG/G_tot: distance to 10–20 %)",
                  loc="left", fontsize=9, color="0.3")
    for row, tt in zip(res.rungs, t):
        if math.isfinite(tt):
            for ax in (ax1, ax2):
                ax.axvline(tt, color="0.85", lw=0.8, zorder=0)
                ax.annotate(_rung_name(row) + (" (reference)" if row["label"] == res.finest else ""),
                            (tt, 1.0), xycoords=("data", "axes fraction"), textcoords="offset points",
                            xytext=(2, -4), fontsize=7, rotation=90, va="top", color="0.4")
    ax2.text(0.02, 0.02, f"hollow markers: error 0, drawn at {floor:g}", transform=ax2.transAxes,
             fontsize=7, color=PAPER_COLOR)
    ax1.text(0.02, 0.02, "hollow markers: inside the two runs' noise (not an error)",
             transform=ax1.transAxes, fontsize=7, color="0.3")
    return fig


def ladder_summary(res: ConvergenceResult) -> list[dict[str, Any]]:
    """Per declared rung (the reference excluded): its wall time, the median over the statistics of
    its relative difference from the reference and of the two runs' combined relative noise, and
    the share of statistics within 10 % and 25 % of the reference (of those both runs give)."""
    ref = next((row for row in res.rungs if row["label"] == res.finest), None)
    out = []
    for row in res.rungs:
        if row["label"] not in res.on_ladder or ref is None or row is ref:
            continue
        errs, noise = [], []
        for s in CONV_STATS:
            e, f = row["err_finest"][s], ref["values"][s]
            if not math.isfinite(e):
                continue
            errs.append(e)
            eb, ebf = row["error_bar"][s], ref["error_bar"][s]
            if math.isfinite(eb) and math.isfinite(ebf) and f != 0:
                noise.append(math.hypot(eb, ebf) / abs(f))
        e = np.array(errs)
        out.append({"label": row["label"], "rung": _rung_name(row), "wall_time_s": row["wall_time_s"],
                    "n_stats": int(e.size),
                    "median_error": float(np.median(e)) if e.size else math.nan,
                    "median_noise": float(np.median(noise)) if noise else math.nan,
                    "share_within_10": float(np.mean(e <= 0.10)) if e.size else math.nan,
                    "share_within_25": float(np.mean(e <= 0.25)) if e.size else math.nan})
    return out


def _summary_figure(results: dict[int | None, ConvergenceResult]) -> Figure:
    """Every case's ladder in one figure: the typical error of a rung against what it costs."""
    fig = Figure(figsize=(11, 4.6), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2, sharex=True)
    fig.suptitle("The ladder at a glance: typical difference from the reference rung against wall-clock time")
    colors = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b")
    for i, (case, res) in enumerate(results.items()):
        rows = sorted((r for r in ladder_summary(res) if math.isfinite(r["wall_time_s"])),
                      key=lambda r: r["wall_time_s"])
        if not rows:
            continue
        col = colors[i % len(colors)]
        name = f"case {case}" if case is not None else "no case"
        t = np.array([r["wall_time_s"] for r in rows])
        med = np.array([r["median_error"] for r in rows])
        ax1.plot(t, med, "o-", color=col, label=f"{name}: median over the statistics")
        ax1.plot(t, [r["median_noise"] for r in rows], ":", color=col, label=f"{name}: median noise")
        for r, tt, m in zip(rows, t, med):
            if math.isfinite(m) and m > 0:
                ax1.annotate(r["rung"], (tt, m), textcoords="offset points", xytext=(3, 3), fontsize=7,
                             color=col)
        ax2.plot(t, [r["share_within_25"] for r in rows], "o-", color=col, label=f"{name}: within 25 %")
        ax2.plot(t, [r["share_within_10"] for r in rows], "s--", color=col, label=f"{name}: within 10 %")
        # what the reference itself costs, for the eye to measure the saving against
        t_ref = next((row["wall_time_s"] for row in res.rungs if row["label"] == res.finest), math.nan)
        if math.isfinite(t_ref):
            for ax in (ax1, ax2):
                ax.axvline(t_ref, color=col, ls="-.", lw=0.9)
                # the references cost about the same: stagger their labels so that they stay legible
                ax.annotate(f"{name}: reference", (t_ref, 0.2 + (0.27 * i) % 0.8),
                            xycoords=("data", "axes fraction"), rotation=90, fontsize=7, color=col,
                            ha="right", va="center")
    for y in (0.10, 0.25):
        ax1.axhline(y, color="0.5", ls=":" if y < 0.2 else "--", lw=1)
    ax1.set(yscale="log", ylabel="|relative difference from the reference| [-]")
    ax1.set_title("(a) median over the statistics; dotted: the two runs' median noise",
                  loc="left", fontsize=9)
    ax2.set_ylim(-0.03, 1.03)
    ax2.set_ylabel("share of the statistics [-]")
    ax2.set_title("(b) statistics within 10 % / 25 % of the reference", loc="left", fontsize=9)
    for ax in (ax1, ax2):
        ax.set(xscale="log", xlabel="wall-clock time of the run [s] (spin-up + saltation)")
        ax.grid(alpha=0.3, which="both")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    return fig


def _knobs(row: dict[str, Any]) -> str:
    """Δx, first level, grains per parcel of a rung, as one short cell."""
    dz = f"{row['dz_bottom'] * 100:.3g} cm" if math.isfinite(row["dz_bottom"]) else "—"
    return f"{fmt(row['dx'])} m / {dz} / {fmt(row['Q'])}"


_RUNG_HEADS = ["rung", "fidelity", "Δx / first level / grains per parcel", "status",
               "wall time [s]", "of which spin-up [s]"]
_CHEAPEST_HEADS = ["statistic", "within 10 %", "within 25 %"]
_CHEAPEST_NOTE = ("Cheapest rung within 10 % / 25 % of the reference (among rungs whose own error "
                  "bar is no wider than the threshold: a noisier run agrees by chance)")


def _rung_cells(res: ConvergenceResult) -> list[list[str]]:
    """A row of text cells per rung: its settings, then value ± bar (vs reference / paper)."""
    return [[row["label"], str(row["fidelity"] or "—"), _knobs(row), row["status"],
             fmt(row["wall_time_s"]), fmt(row["spinup_wall_time_s"])]
            + [f"{_pm(row['values'][s], row['error_bar'][s])} ({_p(row['err_finest'][s])}"
               f"{'*' if row['within_noise'][s] else ''} / {_p(row['err_paper'][s])})"
               for s in CONV_STATS] for row in res.rungs]


def _cheapest_cells(res: ConvergenceResult) -> list[list[str]]:
    return [[CONV_STATS[s][0], res.cheapest[s]["10%"] or "none", res.cheapest[s]["25%"] or "none"]
            for s in CONV_STATS]


def _heads() -> list[str]:
    return _RUNG_HEADS + [f"{CONV_STATS[s][0]} (vs reference / paper)" for s in CONV_STATS]


def _resolves(row: dict[str, Any], s: str, threshold: float) -> bool:
    """Whether a rung's own noise is small enough to show agreement to ``threshold``: a run whose
    bar is wider than the threshold (relative to its value) lands within it by chance, and a run
    with no bar cannot show it; such a rung is never named the cheapest."""
    v, eb = row["values"][s], row["error_bar"][s]
    return math.isfinite(v) and math.isfinite(eb) and v != 0 and eb / abs(v) <= threshold


def _pm(v: float, eb: float) -> str:
    return f"{fmt(v)} ± {fmt(eb)}" if math.isfinite(eb) else fmt(v)


def _p(v: float) -> str:
    return f"{v:.1%}" if math.isfinite(v) else "n/a"


def _seed_sentence(res: ConvergenceResult) -> str:
    if not res.seed_groups:
        return "No run of this case is repeated with another seed: its bars are the half windows' only."
    groups = "; ".join(" and ".join(g) for g in res.seed_groups)
    return f"Seed replicates: {groups} (their scatter sets the seed bars)."


def _stem(case: int | None, primary: int | None) -> str:
    """File stem of a case's figure: ``convergence`` for the primary case."""
    if case == primary:
        return "convergence"
    return f"convergence_case{case:02d}" if case is not None else "convergence_nocase"


def build_convergence_report(runs: dict[str, str | Path | None] | dict[str, RunData], report_dir: Path,
                             fidelities: dict[str, str] | None = None,
                             wall_times: dict[str, float] | None = None,
                             order: list[str] | None = None,
                             reference: str | None = None,
                             provenance: dict[str, Any] | None = None,
                             prior: str | Path | None = None) -> dict[str, Any]:
    """Write ``convergence.{png,pdf,md,json}`` in ``report_dir`` (with ``convergence_caseNN`` per
    further case and, for a ladder, ``convergence_summary``). ``runs``: label -> analysis path or
    :class:`RunData`; ``fidelities``/``wall_times`` override the archives'; ``order``: the ladder,
    coarse -> fine; ``reference``: the label compared against (default: the finest);
    ``provenance`` heads ``convergence.json``; ``prior``: an earlier ``convergence.json`` whose
    rungs the runs top (:func:`convergence_by_case`). Returns {"result" (the primary case's), "results",
    "html", "summary_html", "files"}."""
    report_dir = Path(report_dir)
    report_dir.mkdir(parents=True, exist_ok=True)
    loaded = load_runs(runs, {"fidelities": fidelities or {}, "wall_times": wall_times or {}})
    table = json.loads(Path(prior).read_text(encoding="utf-8")) if prior else None
    results = convergence_by_case(loaded, order, reference, table)
    primary = next(iter(results))
    res = results[primary]
    figures = {_stem(case, primary): _figure(r, case) for case, r in results.items()}
    if not any(r.named_reference for r in results.values()):
        figures["convergence_summary"] = _summary_figure(results)
    files = [f for stem, fig in figures.items() for f in save_figure(fig, report_dir, stem, 130)]
    md = ["# Error against run time", "", NOISE_NOTE, ""]
    page = []
    summary_html = ""
    if "convergence_summary" in figures:
        md += ["![the ladder at a glance](convergence_summary.png)", ""]
        summary_html = figure_html(
            "convergence_summary", "the ladder at a glance: median error against wall time",
            "The ladder at a glance: per rung, the median over the statistics of the relative "
            "difference from the reference rung and of the two runs' noise (a), and the share of "
            "statistics within 10 % and 25 % of it (b).")
    for case, r in results.items():
        head = f"Case {case}" if case is not None else "Runs without a case number"
        md += [f"## {head}", "", f"Reference rung: {r.finest}. {_seed_sentence(r)}", "",
               *md_table(_heads(), _rung_cells(r)), "", f"{_CHEAPEST_NOTE}:", "",
               *md_table(_CHEAPEST_HEADS, _cheapest_cells(r)), ""]
        stem = _stem(case, primary)
        page.append((f"<h3>{html.escape(head)}</h3>" if len(results) > 1 else "")
                    + ("" if case == primary else
                       figure_html(stem, f"error against run time, {head}"))
                    + f"<p>{html.escape(_seed_sentence(r))}</p>"
                    + html_table(_heads(), _rung_cells(r))
                    + f"<h4>{html.escape(_CHEAPEST_NOTE)}</h4>"
                    + html_table(_CHEAPEST_HEADS, _cheapest_cells(r)))
    (report_dir / "convergence.md").write_text("\n".join(md), encoding="utf-8")
    write_json(report_dir / "convergence.json", {
        **(provenance or {}),
        # where the rungs below the study's runs were measured
        **({"ladder_table": {"file": Path(prior).name, **{k: table.get(k) for k in (
            "study", "commit", "source_key")}}} if table else {}),
        "primary_case": primary, "finest": res.finest,
        "reference": res.finest, "cheapest": res.cheapest, "error_bar": NOISE_NOTE,
        "cases": {str(case): {"reference": r.finest, "cheapest": r.cheapest,
                              "seed_replicates": r.seed_groups, "ladder_summary": ladder_summary(r)}
                  for case, r in results.items()},
        "rungs": [{**row, "reference": r.finest} for r in results.values() for row in r.rungs]})
    files += [report_dir / "convergence.md", report_dir / "convergence.json"]
    return {"result": res, "results": results, "html": "".join(page), "summary_html": summary_html,
            "files": files}
