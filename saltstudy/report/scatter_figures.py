"""Figs. 1, 3, 4, 8 and 13 of Dupont et al. (2013): each run drawn whole, as one line or mark:
the parcel count in time (Fig. 1), and z0s, z_m, G_tot, sigma_G/G_tot against u*s/u*t with u*s
the total stress at z_ref and the semi-empirical laws at 200 µm (Figs. 3 and 8).
"""
from __future__ import annotations

import inspect
import math

import numpy as np

from ..physics.laws import GTOT_LAWS, Z0S_LAWS
from .data import ReportContext, RunData
from .plotting import (MARKERS, OWN_COLORS, FigureResult, add_legend, add_notes, case_color,
                       empty_axes, fmt_um, is_200um, new_figure, paper_u_star_ratio, u_star_ratio)
from .reference import PAPER_COLOR, PAPER_LABEL, paper_results
from .saltation import (NO_SALTATION, PAPER_PARCELS_PER_M2, PAPER_PARCELS_SOURCE,
                        n_parcels_per_m2_at_Q, parcels_per_m2_at_Q, saltation_state)

__all__ = ["fig01", "fig03", "fig04", "fig08", "fig13"]


def fig01(ctx: ReportContext) -> FigureResult:
    """Airborne parcels per m² of bed against time since activation, every case at its own Q
    (report/saltation.py), beside the paper's ≈ 2,000 per m² that all its cases hold ([28], [31])."""
    runs = ctx.scatter_runs()
    # the legend sits below the axes, one line per run (two columns past six)
    fig, axes = new_figure(size=(7.2, 5.0 + 0.1 * len(runs)))
    ax = axes[0, 0]
    res = FigureResult(fig)
    ax.set_title("Fig. 1 — airborne parcels per m² of bed, each case at its own Q", fontsize=10)
    drawn: list[str] = []
    for r in runs:
        if not r.has("n_parcels"):
            res.notes.append(f"{r.label}: no n_parcels series")
            continue
        n = r.var("n_parcels")
        t = np.asarray(r.ds[n.dims[0]].values, float)
        y = parcels_per_m2_at_Q(r, n.values)
        if not np.isfinite(y).any():
            res.notes.append(f"{r.label}: domain area or parcel weight unknown")
            continue
        name = f"case {r.case}" if r.case is not None and r.plain_case else r.label
        m = n_parcels_per_m2_at_Q(r)
        tail = f", {NO_SALTATION}" if saltation_state(r).status == NO_SALTATION else ""
        # a case of one's own gets a colour of its own: it may share a paper case's number
        col = case_color(r.paper_case) if r.paper_case is not None else \
            OWN_COLORS[sum(1 for d in drawn if ctx.runs[d].paper_case is None) % len(OWN_COLORS)]
        ax.plot(t, y, color=col, lw=1.2, ls=":" if tail else "-",
                label=f"{name}: mean {m:.3g} m⁻²{tail}")
        res.data[f"t_{r.label}"] = t
        res.data[f"per_m2_{r.label}"] = y
        res.data[f"mean_per_m2_{r.label}"] = np.array([m])
        drawn.append(r.label)
    if not drawn:
        res.notes.extend(f"{r.label}: {r.status}" for r in ctx.runs.values() if not r.ok)
        empty_axes(ax, "\n".join(res.notes) or "no run with an n_parcels series")
        return res
    ref = paper_results()
    per_m2 = PAPER_PARCELS_PER_M2
    if math.isfinite(per_m2):
        res.data["paper_per_m2"] = np.array([per_m2])
        ax.axhline(per_m2, color=PAPER_COLOR, lw=3, alpha=0.6,
                   label=f"{PAPER_PARCELS_SOURCE}: ≈{per_m2:,.0f} parcels per m² at each case's Q\n"
                         "(≈6×10⁵ on 20 × 15 m² in case 2, [31]; similar in all cases, [28])")
    teq = ref.get("fig1_equilibrium_reached_after_s")
    t_end = max(float(np.nanmax(res.data[f"t_{l}"])) for l in drawn)
    if teq and teq <= t_end:
        ax.axvline(teq, color=PAPER_COLOR, ls=":", lw=1.5,
                   label=f"{PAPER_LABEL}: equilibrium after ≈{teq:g} s (case 2)")
    elif teq:   # said, not drawn: a line past the runs' end would squeeze them to the left
        ax.plot([], [], ls="none", label=f"{PAPER_LABEL}: equilibrium after ≈{teq:g} s (case 2), "
                                         f"past these runs' {t_end:g} s")
    ax.set(xlabel="time since saltation activation t [s]",
           ylabel="airborne parcels (of the case's Q) per m² [m⁻²]")
    ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 4))
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    add_legend(ax, below=True, fontsize=7, ncol=2 if len(drawn) > 6 else 1)
    add_notes(ax, res.notes, "upper right")
    ax.grid(alpha=0.3)
    return res


def _scatter(ctx: ReportContext, ax, var: str, res: FigureResult) -> None:
    """Computed ``var`` vs u*s/u*t for every run, dots; 200 um cases circles, others squares."""
    xs, ys = [], []
    others: dict[str, str] = {}
    seen_groups: set[str] = set()
    for r in ctx.scatter_runs():
        if saltation_state(r).status == NO_SALTATION:
            res.notes.append(f"{r.label}: {NO_SALTATION}, not drawn")
            continue
        x, y = u_star_ratio(r), r.scalar(var)
        if not (math.isfinite(x) and math.isfinite(y)):
            res.notes.append(f"{r.label}: {var} or u*s(z_ref)/u*t undefined")
            continue
        group = (("200" if is_200um(r) else "other")
                 if r.case is not None and (r.plain_case or "@" in r.label) else "scene")
        col = case_color(r.case, soil=not is_200um(r))
        lab = {"200": "this study, µ1 = 200 µm (cases 1–6)", "other": "this study, µ1 ≠ 200 µm (cases 7–10)",
               "scene": "this study, other scenes"}[group]
        ax.plot([x], [y], marker=MARKERS[group], ls="none", ms=8, mfc=col, mec="k",
                label=None if group in seen_groups else lab)
        seen_groups.add(group)
        tag = str(r.case) if group != "scene" else r.label
        if group == "other":
            others[tag] = fmt_um(r.mu1)
        ax.annotate(tag, (x, y), textcoords="offset points", xytext=(5, 4), fontsize=7.5)
        xs.append(x)
        ys.append(y)
    res.data["x_ratio"] = np.array(xs)
    res.data[var] = np.array(ys)
    if others:  # a legend entry, not a box over the data
        ax.plot([], [], ls="none", label="µ1 ≠ 200 µm: " + ", ".join(
            f"case {k} {v}" for k, v in others.items()))
    res.notes += [note for n in range(1, 11) if (note := ctx.missing_note(n))]
    ax.set_xlabel(r"$u_{*s}/u_{*t}$ [-], $u_{*s}$ from the total stress at $z_{ref}$")
    ax.grid(alpha=0.3, which="both")


def _ref_threshold(ctx: ReportContext) -> tuple[float, RunData | None]:
    """u*t, and the run it came from, for the laws at mu1 = 200 um (case 2 first, then 1-6)."""
    runs = [ctx.by_case(n) for n in (2, 1, 3, 4, 5, 6)]
    runs += [r for r in ctx.runs.values() if is_200um(r)]
    r = next((r for r in runs if r is not None and r.ok and math.isfinite(r.scalar("u_star_t"))),
             None)
    return (r.scalar("u_star_t"), r) if r is not None else (math.nan, None)


def _draw_laws(ctx, ax, laws: dict, res: FigureResult, d: float) -> None:
    """The semi-empirical laws (``physics.laws``: name -> (law, citation)) at the u*t of a
    200 µm case; each law takes the quantities whose names its keywords have."""
    ut, src = _ref_threshold(ctx)
    if not math.isfinite(ut) or src is None:
        res.notes.append("semi-empirical laws not drawn: no u*t for µ1 = 200 µm")
        return
    xs = res.data.get("x_ratio", np.array([]))
    ratio = np.linspace(1.0, max(4.5, float(np.nanmax(xs)) * 1.1) if xs.size else 4.5, 200)
    q = dict(d=d, rho=src.rho, rho_p=src.attr("rho_p", 2650.0), g=src.attr("g", 9.81),
             z0=src.attr("z0", 1e-5), nu=src.attr("nu", 1.5e-5))
    styles = ["-", "--", "-.", ":", (0, (5, 1)), (0, (3, 1, 1, 1, 1, 1))]
    colors = ["#1f77b4", "#9467bd", "#8c564b", "#d62728", "#17becf", "#bcbd22"]
    for i, (name, (fn, cite)) in enumerate(laws.items()):
        takes = inspect.signature(fn).parameters
        y = np.asarray(fn(ratio * ut, ut, **{k: v for k, v in q.items() if k in takes}), dtype=float)
        ax.plot(ratio, y, color=colors[i % len(colors)], ls=styles[i % len(styles)], lw=1.2,
                label=str(cite))
        res.data[f"law_{name}"] = y


def _scatter_figure(ctx: ReportContext, var: str, size=(6.4, 4.6)) -> tuple[object, FigureResult]:
    """(axes, result) of a figure of ``var`` against u*s/u*t with every run drawn (:func:`_scatter`)."""
    fig, axes = new_figure(size=size)
    res = FigureResult(fig)
    _scatter(ctx, axes[0, 0], var, res)
    return axes[0, 0], res


def _finish(ax, res: FigureResult, ylabel: str, notes_at: str, legend_size: float) -> FigureResult:
    ax.set_ylabel(ylabel)
    add_legend(ax, below=True, fontsize=legend_size)
    add_notes(ax, res.notes, notes_at)
    return res


def fig03(ctx: ReportContext) -> FigureResult:
    ax, res = _scatter_figure(ctx, "z0s", size=(7.2, 5.2))
    _draw_laws(ctx, ax, Z0S_LAWS, res, d=200e-6)
    if any(np.any(np.asarray(v) > 0) for v in res.data.values()):
        ax.set_yscale("log")
    ax.set_title("Fig. 3 — z0s vs u*s/u*t (laws at µ1 = 200 µm, u*t of case 2)", fontsize=10)
    return _finish(ax, res, r"saltation roughness length $z_{0s}$ [m]", "upper left", 7)


def fig04(ctx: ReportContext) -> FigureResult:
    ax, res = _scatter_figure(ctx, "z_m")
    rng = paper_results().get("fig4_zm_cases_1_to_6_m")
    if rng:
        xr_ = [paper_u_star_ratio(1), paper_u_star_ratio(6)]
        ax.plot(xr_, rng, color=PAPER_COLOR, ls="--", lw=2, marker="D", ms=7, alpha=0.8,
                label=f"{PAPER_LABEL}: z_m {rng[0]:g}–{rng[1]:g} m, linear, cases 1–6")
    ax.set_ylim(bottom=0)
    ax.set_title("Fig. 4 — saltation height z_m\n(τp = 0.1 % of ρu*s², u*s from the stress at z_ref)")
    return _finish(ax, res, r"saltation height $z_m$ [m]", "lower right", 7.5)


def fig08(ctx: ReportContext) -> FigureResult:
    ax, res = _scatter_figure(ctx, "G_tot", size=(7.2, 5.2))
    _draw_laws(ctx, ax, GTOT_LAWS, res, d=200e-6)
    ax.set_ylim(bottom=0)
    ax.set_title("Fig. 8 — G_tot vs u*s/u*t (laws at µ1 = 200 µm)", fontsize=10)
    ax.plot([], [], ls="none", label=f"{PAPER_LABEL}: G_tot close to Bagnold (1937) at low u*s,\n"
                                     "close to Sørensen (2004) at high u*s")
    return _finish(ax, res, r"total saltation flux $\langle G_{tot}\rangle$ [kg m⁻¹ s⁻¹]",
                   "upper right", 7)


def fig13(ctx: ReportContext) -> FigureResult:
    ax, res = _scatter_figure(ctx, "sigma_G_over_G_tot")
    band = paper_results().get("fig13_sigmaG_over_Gtot")
    if band:
        ax.axhspan(band[0], band[1], color=PAPER_COLOR, alpha=0.25, zorder=0,
                   label=f"{PAPER_LABEL}: {band[0]:.0%}–{band[1]:.0%}")
    ax.set_ylim(bottom=0)
    ax.set_title("Fig. 13 — relative standard deviation of the saltation flux")
    return _finish(ax, res, r"$\sigma_G / \langle G_{tot}\rangle$ [-]", "lower right", 7.5)
