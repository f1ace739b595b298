"""Figures 1-13 of Dupont et al. (2013), drawn from analysis archives.

Each ``figNN(ctx)`` returns a :class:`FigureResult`: the matplotlib ``Figure`` (made without pyplot,
so it is safe in worker threads and needs no display), the arrays it plotted (``data``), and the
notes it printed (missing cases, undefined quantities). The paper's own numbers appear only as grey
reference marks labelled "Dupont et al. 2013".

Axes, normalisations and case groupings follow the paper's captions:
  1 parcels per m2 at Q vs t (every case)        8 G_tot vs u*s/u*t with G_tot laws (200 um)
  2 <u>/u_ref and <u'w'> vs z, with/without grains 9 C_p/C_pmax and u/u_max at 0.1 m, cases 1, 4, 6
  3 z0s vs u*s/u*t with z0s laws                  10 spanwise spectra of C_p and u(0.1 m)
  4 z_m vs u*s/u*t                                11 R_cu vs z/z_m
  5 size distribution in air vs bed (90/200/400)  12 St vs z/z_m
  6 tau_p/(rho u*s^2) vs z/z_m                    13 sigma_G/G_tot vs u*s/u*t
  7 <G>/<G_tot> vs z/z_m
Panels (a) of Figs 6, 7, 10-12 hold cases 1-6 (various u*s), panels (b) cases 2, 7-10 (various mu1).
In these, in Fig. 9's rows, in Fig. 2 (case 2) and in Fig. 5's panels (cases 7, 2, 10: mu1 = 90,
200, 400 um), a case the study lacks gives its place to the study's nearest run along the
figure's parameter, labelled as standing in for it, or is left out (report/panels.py); a panel
or row with no run to draw is not drawn.
"""
from __future__ import annotations

import hashlib
import math
from typing import Callable

import numpy as np
from matplotlib import colormaps
from matplotlib.figure import Figure

from .data import ReportContext, RunData, profile
from .laws import evaluate_law, load_laws
from .panels import BY_MU1, BY_U_STAR_S, panel_runs
from .plotting import (MARKERS, OWN_COLORS, FigureResult, add_legend, add_notes, case_color,
                       case_label, empty_axes, fmt_um, has_stress_u_star, is_200um, lacks,
                       new_figure, nothing_to_draw, paper_u_star_ratio, plain_log, u_star_ratio,
                       u_star_stress)
from .reference import CASES_SOIL, CASES_WIND, PAPER_COLOR, PAPER_LABEL, paper_results, paper_table2
from .saltation import (NO_SALTATION, PAPER_PARCELS_SOURCE, n_parcels_per_m2_at_Q,
                        paper_parcels_per_m2, parcels_per_m2_at_Q, saltation_state)
from .streaks import premultiplied_over_variance

__all__ = ["FigureResult", "FIGURES", "CAPTIONS", "make_figures", "figure_data_digest"]


# ------------------------------------------------------------------------------------------------
# Fig 1
# ------------------------------------------------------------------------------------------------
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
    means: list[float] = []
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
        state = saltation_state(r)
        tail = f", {NO_SALTATION}" if state.status == NO_SALTATION else ""
        # a case of one's own gets a colour of its own: it may share a paper case's number
        col = case_color(r.paper_case) if r.paper_case is not None else \
            OWN_COLORS[sum(1 for d in drawn if ctx.runs[d].paper_case is None) % len(OWN_COLORS)]
        ax.plot(t, y, color=col, lw=1.2, ls=":" if tail else "-",
                label=f"{name}: mean {m:.3g} m⁻²{tail}")
        res.data[f"t_{r.label}"] = t
        res.data[f"per_m2_{r.label}"] = y
        drawn.append(r.label)
        means.append(m)
    if not drawn:
        res.notes.extend(f"{r.label}: {r.status}" for r in ctx.runs.values() if not r.ok)
        empty_axes(ax, "\n".join(res.notes) or "no run with an n_parcels series")
        return res
    for label, m in zip(drawn, means):
        res.data[f"mean_per_m2_{label}"] = np.array([m])
    ref = paper_results()
    per_m2 = paper_parcels_per_m2()
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
    ax.set_xlabel("time since saltation activation t [s]")
    ax.set_ylabel("airborne parcels (of the case's Q) per m² [m⁻²]")
    ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 4))
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    add_legend(ax, below=True, fontsize=7, ncol=2 if len(drawn) > 6 else 1)
    add_notes(ax, res.notes, "upper right")
    ax.grid(alpha=0.3)
    return res


# ------------------------------------------------------------------------------------------------
# Fig 2
# ------------------------------------------------------------------------------------------------
def _interp_log(z: np.ndarray, v: np.ndarray, z0: float) -> float:
    ok = np.isfinite(v) & (z > 0)
    if ok.sum() < 2:
        return math.nan
    return float(np.interp(np.log(z0), np.log(z[ok]), v[ok]))


#: the wind and stress profiles of Fig. 2, with saltation and without (the spin-up)
FIG2_PROFILES = ("u_mean", "uw_flux", "u_mean_spinup", "uw_flux_spinup")


def fig02(ctx: ReportContext) -> FigureResult:
    """(a) ⟨u⟩/u_ref and (b) ⟨u'w'⟩ against height, with and without saltation, of the paper's
    case 2, or of the study's nearest run by u*s at µ1 = 200 µm (``panels.py``), labelled as
    standing in for it: the paper's case 2 is its 200 µm case at u*s = 0.54 m s⁻¹, and a run of
    another grain size would change the saltation layer the figure shows. A study with no such
    run has no Fig. 2 frames, only a sentence saying so."""
    def usable(r: RunData) -> str | None:
        return None if any(profile(r, n) is not None for n in FIG2_PROFILES) else \
            "no wind or stress profile"

    panel = panel_runs(ctx, (2,), BY_U_STAR_S, usable)
    fig, axes = new_figure(2, 1, size=(10, 4.8), sharey=True)
    res = FigureResult(fig)
    res.notes.extend(panel.notes)
    if not panel.runs:
        for ax in axes.ravel():
            ax.remove()
        nothing_to_draw(fig, "Fig. 2: no run of this study at µ1 = 200 µm has wind or stress "
                              "profiles" + ("\n" + "\n".join(panel.notes) if panel.notes else ""))
        return res
    place = panel.runs[0]
    r = place.run
    ax_u, ax_f = axes[0]
    fig.suptitle("Fig. 2 — mean wind and momentum flux with and without saltation\n"
                 + case_label(r, place=place))
    zref, why = r.z_ref()
    zm = r.scalar("z_m")
    ztop = np.nan
    styles = (("u_mean", "uw_flux", "with saltation", "k", "-"),
              ("u_mean_spinup", "uw_flux_spinup", "without saltation (spin-up)", "tab:blue", "--"))
    for uname, fname, lab, col, ls in styles:
        pu = profile(r, uname)
        if pu is not None:
            z, u = pu
            uref = _interp_log(z, u, zref)
            if math.isfinite(uref) and uref != 0:
                ax_u.plot(u / uref, z, color=col, ls=ls, lw=1.5, label=lab)
                res.data[f"{uname}_norm"] = u / uref
                res.data["z"] = z
                ztop = np.nanmax(z)
            else:
                res.notes.append(f"{uname}: u_ref undefined")
        else:
            res.notes.append(f"{uname}: not in archive")
        pf = profile(r, fname)
        if pf is not None:
            z, f = pf
            ax_f.plot(f, z, color=col, ls=ls, lw=1.5, label=lab)
            res.data[fname] = f
        else:
            res.notes.append(f"{fname}: not in archive")
    for ax in (ax_u, ax_f):
        if math.isfinite(zm) and zm > 0:
            ax.axhspan(1e-6, zm, color="0.85", zorder=0,
                       label=f"saltation layer (z < z_m = {zm:.2f} m)")
        zlog = paper_results().get("fig2_log_layer_above_m")
        if zlog:
            ax.axhline(zlog, color=PAPER_COLOR, ls=":", lw=1.5,
                       label=f"{PAPER_LABEL}: log law, constant stress above ≈{zlog:g} m"
                             + (" (its case 2)" if place.substitute else ""))
        ax.set_yscale("log")
        ax.grid(alpha=0.3, which="both")
    ax_u.axhline(zref, color="tab:red", lw=0.8, ls="-.", label=f"z_ref = {why}")
    grid = r.scene.get("fidelity", {}).get("grid", {})
    lz, damp = float(grid.get("Lz", r.attr("Lz"))), r.damping_depth()
    if math.isfinite(lz) and damp > 0:
        for ax in (ax_u, ax_f):
            ax.axhspan(lz - damp, lz, facecolor="none", edgecolor="0.6", hatch="//", lw=0,
                       label=f"Rayleigh damping layer (z > {lz - damp:g} m)")
    zs = res.data.get("z")
    if zs is not None:
        ax_u.set_ylim(max(1e-3, 0.5 * float(np.nanmin(zs))), 1.2 * ztop)
    ax_u.set_xlabel(r"$\langle u\rangle / u_{ref}$ [-]")
    ax_u.set_ylabel("z [m]")
    ax_u.set_title("(a)", loc="left")
    ax_f.set_xlabel(r"$\langle u'w'\rangle$ (resolved + SGS) [m² s⁻²]")
    ax_f.set_title("(b)", loc="left")
    add_legend(ax_u, fontsize=7.5, loc="best", framealpha=0.9)
    add_legend(ax_f, fontsize=7.5, loc="best", framealpha=0.9)
    add_notes(ax_f, res.notes)
    res.data["u_ref_height"] = np.array([zref])
    return res


# ------------------------------------------------------------------------------------------------
# scatter figures: 3, 4, 8, 13
# ------------------------------------------------------------------------------------------------
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
        if r.case is not None and r.plain_case or (r.case is not None and "@" in r.label):
            group = "200" if is_200um(r) else "other"
        else:
            group = "scene"
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
    for n in range(1, 11):
        note = ctx.missing_note(n)
        if note and ctx.by_case(n) is not None:
            res.notes.append(note)
    ax.set_xlabel(r"$u_{*s}/u_{*t}$ [-], $u_{*s}$ from the total stress at $z_{ref}$")
    ax.grid(alpha=0.3, which="both")


def _law_range(res: FigureResult) -> np.ndarray:
    xs = res.data.get("x_ratio", np.array([]))
    hi = max(4.5, float(np.nanmax(xs)) * 1.1) if xs.size else 4.5
    return np.linspace(1.0, hi, 200)


def _ref_threshold(ctx: ReportContext) -> tuple[float, RunData | None]:
    """u*t, and the run it came from, for the laws at mu1 = 200 um (case 2 first, then 1-6)."""
    for n in (2, 1, 3, 4, 5, 6):
        r = ctx.by_case(n)
        if r is not None and r.ok and math.isfinite(r.scalar("u_star_t")):
            return r.scalar("u_star_t"), r
    for r in ctx.runs.values():
        if r.ok and is_200um(r) and math.isfinite(r.scalar("u_star_t")):
            return r.scalar("u_star_t"), r
    return math.nan, None


def _draw_laws(ctx, ax, laws: dict, reason: str | None, res: FigureResult, d: float) -> None:
    ut, src = _ref_threshold(ctx)
    if reason:
        res.notes.append("semi-empirical laws not drawn: physics.laws unavailable")
        return
    if not math.isfinite(ut) or src is None:
        res.notes.append("semi-empirical laws not drawn: no u*t for µ1 = 200 µm")
        return
    ratio = _law_range(res)
    q = dict(u_star_t=ut, d=d, rho=src.rho, rho_p=src.attr("rho_p", 2650.0), g=src.attr("g", 9.81),
             z0=src.attr("z0", 1e-5), kappa=src.attr("kappa", 0.4), nu=src.attr("nu", 1.5e-5))
    styles = ["-", "--", "-.", ":", (0, (5, 1)), (0, (3, 1, 1, 1, 1, 1))]
    colors = ["#1f77b4", "#9467bd", "#8c564b", "#d62728", "#17becf", "#bcbd22"]
    for i, (name, entry) in enumerate(laws.items()):
        fn, cite = (entry if isinstance(entry, tuple) else (entry, name))
        try:
            y = evaluate_law(fn, ratio * ut, **q)
        except Exception as exc:
            res.notes.append(f"law {name} not drawn ({type(exc).__name__})")
            continue
        ax.plot(ratio, y, color=colors[i % len(colors)], ls=styles[i % len(styles)], lw=1.2,
                label=str(cite))
        res.data[f"law_{name}"] = y


def fig03(ctx: ReportContext) -> FigureResult:
    fig, axes = new_figure(size=(7.2, 5.2))
    ax = axes[0, 0]
    res = FigureResult(fig)
    _scatter(ctx, ax, "z0s", res)
    z0s_laws, _, reason = load_laws()
    _draw_laws(ctx, ax, z0s_laws, reason, res, d=200e-6)
    if any(np.any(np.asarray(v) > 0) for v in res.data.values()):
        ax.set_yscale("log")
    ax.set_ylabel(r"saltation roughness length $z_{0s}$ [m]")
    ax.set_title("Fig. 3 — z0s vs u*s/u*t (laws at µ1 = 200 µm, u*t of case 2)", fontsize=10)
    add_legend(ax, below=True, fontsize=7)
    add_notes(ax, res.notes, "upper left")
    return res


def fig04(ctx: ReportContext) -> FigureResult:
    fig, axes = new_figure()
    ax = axes[0, 0]
    res = FigureResult(fig)
    _scatter(ctx, ax, "z_m", res)
    rng = paper_results().get("fig4_zm_cases_1_to_6_m")
    if rng:
        xr_ = [paper_u_star_ratio(1), paper_u_star_ratio(6)]
        ax.plot(xr_, rng, color=PAPER_COLOR, ls="--", lw=2, marker="D", ms=7, alpha=0.8,
                label=f"{PAPER_LABEL}: z_m {rng[0]:g}–{rng[1]:g} m, linear, cases 1–6")
    ax.set_ylabel(r"saltation height $z_m$ [m]")
    ax.set_ylim(bottom=0)
    ax.set_title("Fig. 4 — saltation height z_m (τp = 0.1 % of ρu*s², u*s from the stress at z_ref)")
    add_legend(ax, below=True, fontsize=7.5)
    add_notes(ax, res.notes, "lower right")
    return res


def fig08(ctx: ReportContext) -> FigureResult:
    fig, axes = new_figure(size=(7.2, 5.2))
    ax = axes[0, 0]
    res = FigureResult(fig)
    _scatter(ctx, ax, "G_tot", res)
    _, gtot_laws, reason = load_laws()
    _draw_laws(ctx, ax, gtot_laws, reason, res, d=200e-6)
    ax.set_ylabel(r"total saltation flux $\langle G_{tot}\rangle$ [kg m⁻¹ s⁻¹]")
    ax.set_ylim(bottom=0)
    ax.set_title("Fig. 8 — G_tot vs u*s/u*t (laws at µ1 = 200 µm)", fontsize=10)
    ax.plot([], [], ls="none", label=f"{PAPER_LABEL}: G_tot close to Bagnold (1937) at low u*s,\n"
                                     "close to Sørensen (2004) at high u*s")
    add_legend(ax, below=True, fontsize=7)
    add_notes(ax, res.notes, "upper right")
    return res


def fig13(ctx: ReportContext) -> FigureResult:
    fig, axes = new_figure()
    ax = axes[0, 0]
    res = FigureResult(fig)
    _scatter(ctx, ax, "sigma_G_over_G_tot", res)
    band = paper_results().get("fig13_sigmaG_over_Gtot")
    if band:
        ax.axhspan(band[0], band[1], color=PAPER_COLOR, alpha=0.25, zorder=0,
                   label=f"{PAPER_LABEL}: {band[0]:.0%}–{band[1]:.0%}")
    ax.set_ylabel(r"$\sigma_G / \langle G_{tot}\rangle$ [-]")
    ax.set_ylim(bottom=0)
    ax.set_title("Fig. 13 — relative standard deviation of the saltation flux")
    add_legend(ax, below=True, fontsize=7.5)
    add_notes(ax, res.notes, "lower right")
    return res


# ------------------------------------------------------------------------------------------------
# Fig 5
# ------------------------------------------------------------------------------------------------
#: the paper's Fig. 5 panels: (letter, grain size µ1 [µm], the paper's case drawn)
FIG5_PANELS = (("a", 90, 7), ("b", 200, 2), ("c", 400, 10))


def fig05(ctx: ReportContext) -> FigureResult:
    """Grain-size distribution in the air, by height band, against the bed's: a panel per grain
    size of the paper (µ1 = 90, 200, 400 µm: its cases 7, 2, 10).

    Each panel is a soil, so a run fills it only if its µ1 is within ``panels.HELD_TOLERANCE``
    (10 %) of the panel's grain size: the paper's case if the study has it, else, among the runs
    of that grain size, the one nearest the paper's case in target u*s (``panels.py``, held µ1,
    varied u*s), labelled as standing in for it. u*s decides within a panel because, once the
    soil is the same, the wind is what changes how high and how unevenly the sizes are lifted;
    a run of another grain size (case 8's 100 µm for 90 µm, case 9's 300 µm for 400 µm) would
    show a different soil under the panel's title. A panel no run fills is left out."""
    def usable(r: RunData) -> str | None:
        return None if r.has("psd_air", "psd_bed", "d_bin") else "no size distribution"

    panel = panel_runs(ctx, tuple(n for _, _, n in FIG5_PANELS), BY_U_STAR_S, usable)
    chosen = {place.paper_case: place for place in panel.runs}
    drawn = [(letter, um, chosen[n]) for letter, um, n in FIG5_PANELS if n in chosen]
    fig, axes = new_figure(max(1, len(drawn)), 1, size=(max(6.0, 0.5 + 4.2 * len(drawn)), 4.8))
    res = FigureResult(fig)
    res.notes.extend(panel.notes)
    fig.suptitle("Fig. 5 — grain-size distribution in the saltation layer (by height band)"
                 + ("\n" if len(drawn) < 3 else " ") + "vs the bed")
    if not drawn:
        axes[0, 0].remove()
        nothing_to_draw(fig, "no run of this study at µ1 = 90, 200 or 400 µm (±10 %) has size "
                              "distributions in the air and the bed"
                         + ("\n" + "\n".join(panel.notes) if panel.notes else ""))
        return res
    for ax, (letter, um, place) in zip(axes[0], drawn):
        r = place.run
        title = f"({letter}) µ1 = {um} µm: {case_label(r)}"
        if place.substitute:   # on a line of its own: the panels are narrow
            title += f"\n{place.stand_in()}"
        ax.set_title(title, loc="left", fontsize=9)
        d = np.asarray(r.ds["d_bin"].values, float) * 1e6
        bed = np.asarray(r.ds["psd_bed"].values, float)
        air = np.asarray(r.ds["psd_air"].values, float)
        air_dims = r.ds["psd_air"].dims
        if air_dims[0] == "d_bin":
            air = air.T
        zb = r.ds[r.ds["psd_air"].dims[0] if air_dims[0] != "d_bin" else air_dims[1]].values
        edges = r.ds["z_band_edges"].values if "z_band_edges" in r.ds else None
        cmap = colormaps["plasma"]
        for i in range(air.shape[0]):
            if edges is not None and len(edges) == air.shape[0] + 1:
                lab = f"air, z = {edges[i] * 100:.0f}–{edges[i + 1] * 100:.0f} cm"
            else:
                lab = f"air, z ≈ {zb[i] * 100:.0f} cm"
            ax.plot(d, air[i], color=cmap(i / max(1, air.shape[0])), lw=1.4, marker=".", label=lab)
        ax.plot(d, bed, color="k", lw=2.5, label=f"bed (soil), µ1 = {fmt_um(r.mu1)}")
        res.data[f"psd_air_{place.key}"] = air
        res.data[f"psd_bed_{place.key}"] = bed
        ax.set_xscale("log")
        # a size range of a decade or less (µ1/2.5 to 2.5 µ1 or narrower): powers of ten alone
        # label it in scientific notation, and 1-2-5 steps may leave a single label
        plain_log(ax, "x", subs=(1.0, 1.5, 2.0, 3.0, 5.0, 7.0))
        ax.set_xlabel("grain diameter d [µm]")
        ax.set_ylabel("mass fraction per size bin [-]")
        ax.grid(alpha=0.3, which="both")
        add_legend(ax, fontsize=7)
    return res


# ------------------------------------------------------------------------------------------------
# profile figures: 6, 7, 11, 12
# ------------------------------------------------------------------------------------------------
#: the profile variables as the figures write them
_SYMBOL = {"tau_p": "τp", "G": "⟨G⟩", "R_cu": "R_cu", "St": "St"}


def _log_gaps(x: np.ndarray) -> np.ndarray:
    """Indices of the levels whose value is finite and ≤ 0 with a positive value below and
    above them: a log axis cannot draw them, so the line breaks there and a positive level
    above may stand alone as a single dot (τp of a coarse grid changes sign above z_m)."""
    pos = np.isfinite(x) & (x > 0)
    if pos.sum() < 2:
        return np.array([], dtype=int)
    first, last = np.flatnonzero(pos)[[0, -1]]
    bad = np.isfinite(x) & (x <= 0)
    idx = np.flatnonzero(bad)
    return idx[(idx > first) & (idx < last)]


def _profiles(ctx: ReportContext, var: str, title: str, xlabel: str,
              norm: Callable[[RunData, np.ndarray], np.ndarray], xlog: bool,
              decorate: Callable | None = None, ylim=(0.0, 1.5), xlog_span: float = 1e-4,
              needs: Callable[[RunData], str | None] | None = None) -> FigureResult:
    """Panel (a): the paper's cases 1–6 (various u*s), panel (b): cases 2, 7–10 (various µ1),
    each place filled by the study's run of the case or its nearest run (``panels.py``); a
    panel the study cannot fill at all is left out. ``needs(run)``: the reason a run's profile
    cannot be normalised (None if it can)."""
    def usable(r: RunData) -> str | None:
        if profile(r, var) is None:
            return f"no {var}"
        zm = r.scalar("z_m")
        if not (math.isfinite(zm) and zm > 0):
            return "z_m undefined (no saltation?)"
        return needs(r) if needs is not None else None

    groups = []
    for cases, by, soil, ptitle in ((CASES_WIND, BY_U_STAR_S, False, "(a) cases 1–6: various u*s"),
                                    (CASES_SOIL, BY_MU1, True, "(b) cases 2, 7–10: various µ1")):
        groups.append((panel_runs(ctx, cases, by, usable), soil, ptitle))
    drawn = [g for g in groups if g[0].runs]
    fig, axes = new_figure(max(1, len(drawn)), 1, size=(5.5 * max(1, len(drawn)), 5.0), sharey=True)
    res = FigureResult(fig)
    fig.suptitle(title)
    for panel, _, _ in groups:
        res.notes.extend(panel.notes)
    if not drawn:
        axes[0, 0].remove()
        nothing_to_draw(fig, f"no run of this study has {var} against z/z_m")
        return res
    for ax, (panel, soil, ptitle) in zip(axes[0], drawn):
        prefix = ptitle[:3]
        gap_notes: list[str] = []
        for place in panel.runs:
            r = place.run
            z, v = profile(r, var)
            zm = r.scalar("z_m")
            x = np.asarray(norm(r, v), float)
            vis = z / zm <= ylim[1] * 1.05
            z, x = z[vis], x[vis]
            if xlog:
                gaps = _log_gaps(x)
                if gaps.size:
                    name = f"case {r.case}" if r.case is not None and r.plain_case else r.label
                    at = ", ".join(f"{h:.2f}" for h in z[gaps] / zm)
                    gap_notes.append(f"{name}: {_SYMBOL.get(var, var)} ≤ 0 at z/z_m = {at}, "
                                     "a gap in its line on the log axis")
                x = np.where(x > 0, x, np.nan)
            ax.plot(x, z / zm, color=case_color(place.paper_case, soil), lw=1.6, marker=".", ms=3,
                    label=case_label(r, soil, place))
            res.data[f"{prefix}{place.key}"] = np.asarray(x, float)
        res.notes.extend(gap_notes)
        if decorate is not None:
            decorate(ax, soil, res)
        if xlog:
            vals = np.concatenate([v for k, v in res.data.items() if k.startswith(prefix)] or [np.array([])])
            vals = vals[np.isfinite(vals) & (vals > 0)]
            if vals.size:  # a log axis without positive data cannot be drawn
                ax.set_xscale("log")
                hi = float(vals.max())
                lo = max(float(vals.min()), hi * xlog_span)
                ax.set_xlim(lo / 1.5, hi * 1.5)
        ax.set_ylim(*ylim)
        ax.set_xlabel(xlabel)
        ax.set_title(ptitle, loc="left")
        ax.grid(alpha=0.3, which="both")
        add_legend(ax, fontsize=7.5, loc="best")  # profiles differ per run: least overlap
        add_notes(ax, panel.notes + gap_notes, "lower left")
    axes[0, 0].set_ylabel(r"$z / z_m$ [-]")
    return res


def fig06(ctx: ReportContext) -> FigureResult:
    """τp over ρ u*s² with u*s read the paper's way, from the total stress at z_ref (the u*s of
    the labels and of Figs. 3, 4, 8, 13's abscissa), the free log fit only for a run whose
    archive lacks the stress reading (its label and a note say so). z_m, from the analysis, is
    where τp falls below 0.1 % of ρ u*s² with the same stress u*s: each profile crosses the
    dotted 0.1 % line at z/z_m = 1."""
    free_fit: list[str] = []

    def norm(r, v):
        if not has_stress_u_star(r):
            free_fit.append(r.label)
        return v / (r.rho * u_star_stress(r) ** 2)

    def needs(r):
        us = u_star_stress(r)
        return None if math.isfinite(us) and us > 0 else "no u*s"

    def deco(ax, soil, res):
        ax.axvline(1e-3, color="0.6", ls=":", lw=1,
                   label="0.1 % (z_m: τp = 0.1 % of ρu*s²)")
        val = paper_results().get("fig6_taup_surface_fraction_case6")
        if val and not soil:
            r6 = ctx.by_case(6)
            y = 0.0
            if r6 is not None and r6.ok and r6.has("z") and math.isfinite(r6.scalar("z_m")):
                y = float(r6.ds["z"].values[0]) / r6.scalar("z_m")
            ax.plot([val], [y], marker="*", ms=15, color=PAPER_COLOR, ls="none", clip_on=False,
                    label=f"{PAPER_LABEL}: case 6 surface ≈ {val:g}")

    res = _profiles(ctx, "tau_p", "Fig. 6 — particle momentum flux τp / (ρ u*s²)",
                    r"$\tau_p / (\rho u_{*s}^2)$ [-], $u_{*s}$ from the total stress at $z_{ref}$",
                    norm, True, deco, needs=needs)
    res.notes.extend(f"{label}: no stress u*s in the archive, τp over ρu*s² of the free log fit"
                     for label in dict.fromkeys(free_fit))
    return res


def fig07(ctx: ReportContext) -> FigureResult:
    def norm(r, v):
        return v / r.scalar("G_tot")

    return _profiles(ctx, "G", "Fig. 7 — mean saltation flux ⟨G⟩ / ⟨G_tot⟩",
                     r"$\langle G\rangle / \langle G_{tot}\rangle$ [m⁻¹]", norm, True)


def fig11(ctx: ReportContext) -> FigureResult:
    res_ = paper_results()

    def deco(ax, soil, res):
        ax.axvline(0.0, color="0.5", lw=0.8)
        val = res_.get("fig11_Rcu_upper_layer")
        if val is not None and not soil:
            ax.plot([val, val], [0.6, 1.0], color=PAPER_COLOR, lw=6, alpha=0.6, solid_capstyle="butt",
                    label=f"{PAPER_LABEL}: R_cu ≈ {val:g} for z ≥ 0.6 z_m (µ1 = 200 µm)")
        pk = res_.get("fig11_Rcu_peak_height_over_zm")
        if pk and not soil:
            ax.axhspan(pk[0], pk[1], color=PAPER_COLOR, alpha=0.2, zorder=0,
                       label=f"{PAPER_LABEL}: peak at {pk[0]:g}–{pk[1]:g} z_m (cases 1–4)")

    return _profiles(ctx, "R_cu", "Fig. 11 — zero-lag correlation R_cu between C_p and u(z)",
                     r"$R_{cu}$ [-]", lambda r, v: v, False, deco)


def fig12(ctx: ReportContext) -> FigureResult:
    h = paper_results().get("fig12_St_below_1_above_z_over_zm")

    def deco(ax, soil, res):
        ax.axvline(1.0, color="0.4", ls="--", lw=1, label="St = 1")
        if h is not None:
            ax.axhline(h, color=PAPER_COLOR, lw=4, alpha=0.5,
                       label=f"{PAPER_LABEL}: St < 1 above ≈{h:g} z_m (µ1 ≥ 200 µm)")

    return _profiles(ctx, "St", "Fig. 12 — Stokes number St = T_p / T_ε in the saltation layer",
                     r"$St$ [-]", lambda r, v: v, True, deco, ylim=(0.0, 1.2))


# ------------------------------------------------------------------------------------------------
# Fig 9
# ------------------------------------------------------------------------------------------------
def fig09(ctx: ReportContext) -> FigureResult:
    """A row per paper case 1, 4, 6 (top to bottom): the study's run of the case, or its nearest
    run by u*s at µ1 = 200 µm (``panels.py``), titled with the case it stands in for; a row the
    study cannot fill is left out."""
    panel = panel_runs(ctx, FIG9_CASES, BY_U_STAR_S, lacks("C_p_snapshot", "u_snapshot"))
    rows = panel.runs
    ref = rows[0].run if rows else None     # the aspect of the first drawn run
    lx = ref.attr("Lx", 20.0) if ref else 20.0
    ly = ref.attr("Ly", 15.0) if ref else 15.0
    w = 11.0
    h = len(rows) * (w / 2) * (ly / lx) * 0.95 + 1.0
    fig, axes = new_figure(2, max(1, len(rows)), size=(w, min(max(h, 3.5), 14.0)))
    res = FigureResult(fig)
    res.notes.extend(panel.notes)
    fig.suptitle("Fig. 9 — snapshots: (a) C_p / C_pmax and (b) u / u_max at z = 0.1 m")
    if not rows:
        for ax in axes.ravel():
            ax.remove()
        nothing_to_draw(fig, "no run of this study at µ1 = 200 µm has C_p and u snapshots")
        return res
    for row, place in enumerate(rows):
        r = place.run
        for col, (var, lab, cmap) in enumerate((("C_p_snapshot", r"$C_p / C_{p,max}$", "YlOrBr"),
                                                ("u_snapshot", r"$u / u_{max}$", "viridis"))):
            ax = axes[row, col]
            v = r.var(var)
            arr = np.asarray(v.values, float)
            if v.dims == ("y", "x"):
                arr = arr.T
            vmax = np.nanmax(np.abs(arr))
            arr = arr / vmax if vmax > 0 else arr
            x = np.asarray(r.ds["x"].values, float) if "x" in r.ds else np.arange(arr.shape[0])
            y = np.asarray(r.ds["y"].values, float) if "y" in r.ds else np.arange(arr.shape[1])
            dx = x[1] - x[0] if x.size > 1 else 1.0
            dy = y[1] - y[0] if y.size > 1 else 1.0
            im = ax.imshow(arr.T, origin="lower", cmap=cmap, aspect="equal",
                           extent=(x[0] - dx / 2, x[-1] + dx / 2, y[0] - dy / 2, y[-1] + dy / 2),
                           vmin=0.0 if col == 0 else None, vmax=1.0)
            fig.colorbar(im, ax=ax, shrink=0.85, label=lab)
            res.data[f"{var}_{place.key}"] = arr
            title = f"({'ab'[col]}) {case_label(r)}"
            if place.substitute:   # on a line of its own: the panels are narrow
                title += f"\n{place.stand_in()}"
            ax.set_title(title, loc="left", fontsize=9)
            ax.set_ylabel("y [m]")
            if row == len(rows) - 1:
                ax.set_xlabel("x [m] (wind →)")
    return res


#: the paper's Fig. 9 rows, top to bottom
FIG9_CASES = (1, 4, 6)


# ------------------------------------------------------------------------------------------------
# Fig 10
# ------------------------------------------------------------------------------------------------
def fig10(ctx: ReportContext) -> FigureResult:
    """The premultiplied spanwise spectra ky S(ky) against wavelength on a log axis, the form
    Table 2's delta_y is read from (docs/STREAMERS.md), over the variance: the area under each
    curve against ln(wavelength) is 1. Top row: the paper's cases 1–6 (various u*s), bottom row:
    cases 2, 7–10 (various µ1), each filled by the study's run of the case or its nearest run
    (``panels.py``); a row the study cannot fill at all is left out."""
    table = paper_table2()
    groups = [(panel_runs(ctx, cases, by, lacks("S_c", "S_u")), cases, soil, rtitle)
              for cases, by, soil, rtitle in ((CASES_WIND, BY_U_STAR_S, False, "cases 1–6"),
                                              (CASES_SOIL, BY_MU1, True, "cases 2, 7–10"))]
    drawn = [g for g in groups if g[0].runs]
    fig, axes = new_figure(2, max(1, len(drawn)), size=(11, 0.5 + 4.0 * max(1, len(drawn))))
    res = FigureResult(fig)
    fig.suptitle("Fig. 10 — premultiplied spanwise spectra of (a) C_p and (b) u at z = 0.1 m, "
                 "averaged in x and t")
    for panel, _, _, _ in groups:
        res.notes.extend(panel.notes)
    if not drawn:
        for ax in axes.ravel():
            ax.remove()
        nothing_to_draw(fig, "no run of this study has spanwise spectra of C_p and u")
        return res
    for row, (panel, cases, soil, rtitle) in enumerate(drawn):
        for col, (var, dvar, vlab) in enumerate((("S_c", "delta_y", "C_p"), ("S_u", "delta_y_u", "u"))):
            ax = axes[row, col]
            for place in panel.runs:
                r = place.run
                v = r.var(var)
                wavelength, pn = premultiplied_over_variance(
                    r.ds[v.dims[0]].values, v.values, r.attr("Ly"), r.attr("dy"))
                c = case_color(place.paper_case, soil)
                ax.plot(wavelength, pn, color=c, lw=1.5, label=case_label(r, soil, place))
                res.data[f"{var}_{place.key}"] = pn
                dyv = r.scalar(dvar)
                if math.isfinite(dyv):
                    ax.axvline(dyv, color=c, lw=0.8, ls=":")
            if col == 0:  # the paper's delta_y (from C_p spectra, Table 2) as grey triangles
                pv = [(n, table.get(n, {}).get("delta_y_m", math.nan)) for n in cases]
                pv = [(n, v) for n, v in pv if math.isfinite(v)]
                if pv:
                    ax.plot([v for _, v in pv], [0.0] * len(pv), marker="^", ms=9, ls="none",
                            color=PAPER_COLOR, transform=ax.get_xaxis_transform(), clip_on=False,
                            label=f"{PAPER_LABEL}: δy (Table 2)")
            ax.set_xscale("log")
            plain_log(ax, "x")
            ax.set_xlabel(r"spanwise wavelength $1/k_y$ [m]")
            ax.set_ylabel(f"$k_y S_{{{vlab}}}(k_y) / \\sigma_{{{vlab}}}^2$ [-]")
            ax.set_title(f"({'ab'[col]}) {vlab}, {rtitle}  (dotted: computed δy)", loc="left",
                         fontsize=9)
            ax.grid(alpha=0.3, which="both")
            add_legend(ax, fontsize=7, loc="upper right")
            add_notes(ax, panel.notes, "upper left")
    return res


FIGURES: dict[str, Callable[[ReportContext], FigureResult]] = {
    "fig01": fig01, "fig02": fig02, "fig03": fig03, "fig04": fig04, "fig05": fig05,
    "fig06": fig06, "fig07": fig07, "fig08": fig08, "fig09": fig09, "fig10": fig10,
    "fig11": fig11, "fig12": fig12, "fig13": fig13,
}

CAPTIONS = {
    "fig01": "Airborne parcels per m² of bed vs time since activation, every case converted to "
             "parcels of its own Q, beside the paper's ≈ 2,000 per m² (its Q makes all cases "
             "hold a similar number).",
    "fig02": "(a) ⟨u⟩/u_ref and (b) ⟨u′w′⟩ vs height, case 2, with and without saltation; grey: "
             "saltation layer (z < z_m). Where the study lacks case 2, its nearest run by u*s at "
             "µ1 = 200 µm, titled with the case it stands in for.",
    "fig03": "Saltation roughness length z0s vs u*s/u*t (dots; u*s read from the total stress "
             "at z_ref, as the paper) with semi-empirical laws (lines).",
    "fig04": "Saltation height z_m vs u*s/u*t.",
    "fig05": "Grain-size distribution in the saltation layer vs the bed for µ1 = 90, 200, 400 µm "
             "(cases 7, 2, 10); where the study lacks one, its run of that grain size (±10 %) "
             "nearest in u*s, titled with the case it stands in for; a grain size the study has "
             "no run of is left out.",
    "fig06": "τp/(ρu*s²) vs z/z_m (u*s read from the total stress at z_ref, as the paper): "
             "(a) cases 1–6, (b) cases 2, 7–10.",
    "fig07": "⟨G⟩/⟨G_tot⟩ vs z/z_m: (a) cases 1–6, (b) cases 2, 7–10.",
    "fig08": "Total saltation flux G_tot vs u*s/u*t (dots; u*s read from the total stress at "
             "z_ref, as the paper) with semi-empirical laws for 200 µm (lines).",
    "fig09": "Snapshots of C_p/C_pmax and u/u_max at z = 0.1 m for cases 1, 4, 6 (top to "
             "bottom); where the study lacks one, its nearest run by u*s at µ1 = 200 µm, "
             "titled with the case it stands in for.",
    "fig10": "Premultiplied spanwise spectra k_y S(k_y) of C_p and u(0.1 m) over their variance "
             "against wavelength (Table 2's δy is read at their peak): top cases 1–6, bottom "
             "cases 2, 7–10.",
    "fig11": "Zero-lag correlation R_cu between C_p and u(z) vs z/z_m.",
    "fig12": "Stokes number St vs z/z_m.",
    "fig13": "σ_G/⟨G_tot⟩ vs u*s/u*t.",
}


def error_figure(name: str, exc: BaseException) -> Figure:
    fig, axes = new_figure()
    empty_axes(axes[0, 0], f"{name}: could not be drawn\n{type(exc).__name__}: {exc}")
    return fig


def make_figures(ctx: ReportContext, names=None) -> dict[str, FigureResult]:
    """Draw the figures (all, or ``names``). A figure function that raises is replaced by a figure
    stating the error, so one bad archive never loses the whole report."""
    out: dict[str, FigureResult] = {}
    for name in names or FIGURES:
        try:
            out[name] = FIGURES[name](ctx)
        except Exception as exc:  # report the failure on the figure itself
            out[name] = FigureResult(error_figure(name, exc), notes=[f"error: {type(exc).__name__}: {exc}"])
    return out


def figure_data_digest(fig: Figure) -> str:
    """SHA-256 of every data array drawn on ``fig`` (lines, collections, images), so a test can
    tell whether the plotted data changed without comparing image bytes."""
    h = hashlib.sha256()
    for ax in fig.axes:
        for ln in ax.get_lines():
            h.update(np.ascontiguousarray(ln.get_xydata(), dtype=float).tobytes())
        for c in ax.collections:
            off = c.get_offsets()
            h.update(np.ascontiguousarray(np.asarray(off, dtype=float)).tobytes())
        for im in ax.get_images():
            h.update(np.ascontiguousarray(np.asarray(im.get_array(), dtype=float)).tobytes())
    return h.hexdigest()
