"""Figs. 2, 5, 6, 7, 11 and 12 of Dupont et al. (2013): the saltation layer along the height
(section 3.1, section 3.2 [39], eqs. 10-13).
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np
from matplotlib import colormaps

from .data import ReportContext, RunData, profile
from .panels import BY_U_STAR_S, panel_runs, wind_and_soil
from .plotting import (FigureResult, add_legend, add_notes, case_color, case_label, fmt_um,
                       has_stress_u_star, lacks, new_figure, nothing_to_draw, plain_log,
                       u_star_stress)
from .reference import PAPER_COLOR, PAPER_LABEL, paper_results

__all__ = ["fig02", "fig05", "fig06", "fig07", "fig11", "fig12", "FIG2_PROFILES", "FIG5_PANELS"]


#: the wind and stress profiles of Fig. 2, with saltation and without (the spin-up)
FIG2_PROFILES = ("u_mean", "uw_flux", "u_mean_spinup", "uw_flux_spinup")


def fig02(ctx: ReportContext) -> FigureResult:
    """(a) ⟨u⟩/u_ref and (b) ⟨u'w'⟩ against height, with and without saltation, of case 2 or
    the study's nearest run by u*s at µ1 = 200 µm (``panels.py``): another grain size would
    change the saltation layer the figure shows."""
    def usable(r: RunData) -> str | None:
        return None if any(profile(r, n) is not None for n in FIG2_PROFILES) else \
            "no wind or stress profile"

    panel = panel_runs(ctx, (2,), BY_U_STAR_S, usable)
    fig, axes = new_figure(2, 1, size=(10, 4.8), sharey=True)
    res = FigureResult(fig, notes=list(panel.notes))
    if not panel.runs:
        return nothing_to_draw(res, "Fig. 2: no run of this study at µ1 = 200 µm has wind or "
                                    "stress profiles")
    place = panel.runs[0]
    r = place.run
    ax_u, ax_f = axes[0]
    fig.suptitle("Fig. 2 — mean wind and momentum flux with and without saltation\n"
                 + case_label(r, place=place))
    zref, why = r.z_ref()
    zm = r.scalar("z_m")
    styles = (("u_mean", "uw_flux", "with saltation", "k", "-"),
              ("u_mean_spinup", "uw_flux_spinup", "without saltation (spin-up)", "tab:blue", "--"))
    for uname, fname, lab, col, ls in styles:
        pu = profile(r, uname)
        if pu is not None:
            z, u = pu
            ok = np.isfinite(u) & (z > 0)
            uref = (float(np.interp(np.log(zref), np.log(z[ok]), u[ok])) if ok.sum() >= 2
                    else math.nan)
            if math.isfinite(uref) and uref != 0:
                ax_u.plot(u / uref, z, color=col, ls=ls, lw=1.5, label=lab)
                res.data[f"{uname}_norm"] = u / uref
                res.data["z"] = z
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
    if "z" in res.data:
        zs = res.data["z"]
        ax_u.set_ylim(max(1e-3, 0.5 * float(np.nanmin(zs))), 1.2 * np.nanmax(zs))
    ax_u.set(xlabel=r"$\langle u\rangle / u_{ref}$ [-]", ylabel="z [m]")
    ax_u.set_title("(a)", loc="left")
    ax_f.set_xlabel(r"$\langle u'w'\rangle$ (resolved + SGS) [m² s⁻²]")
    ax_f.set_title("(b)", loc="left")
    for ax in (ax_u, ax_f):
        add_legend(ax, fontsize=7.5, loc="best", framealpha=0.9)
    add_notes(ax_f, res.notes)
    res.data["u_ref_height"] = np.array([zref])
    return res


#: the paper's Fig. 5 panels: (letter, grain size µ1 [µm], the paper's case drawn)
FIG5_PANELS = (("a", 90, 7), ("b", 200, 2), ("c", 400, 10))


def fig05(ctx: ReportContext) -> FigureResult:
    """Grain-size distribution in the air, by height band, against the bed's: a panel per grain
    size of the paper (µ1 = 90, 200, 400 µm: its cases 7, 2, 10). A panel is a soil: only a run
    within ``panels.HELD_TOLERANCE`` of its µ1 fills it (the paper's case, else the nearest in
    target u*s, which changes how high and how unevenly the sizes are lifted); else left out."""
    panel = panel_runs(ctx, tuple(n for _, _, n in FIG5_PANELS), BY_U_STAR_S,
                       lacks("psd_air", "psd_bed", "d_bin", "z_band_edges"))
    chosen = {place.paper_case: place for place in panel.runs}
    drawn = [(letter, um, chosen[n]) for letter, um, n in FIG5_PANELS if n in chosen]
    fig, axes = new_figure(max(1, len(drawn)), 1, size=(max(6.0, 0.5 + 4.2 * len(drawn)), 4.8))
    res = FigureResult(fig, notes=list(panel.notes))
    fig.suptitle("Fig. 5 — grain-size distribution in the saltation layer (by height band)"
                 + ("\n" if len(drawn) < 3 else " ") + "vs the bed")
    if not drawn:
        return nothing_to_draw(res, "no run of this study at µ1 = 90, 200 or 400 µm (±10 %) has "
                                    "size distributions in the air and the bed")
    for ax, (letter, um, place) in zip(axes[0], drawn):
        r = place.run
        title = f"({letter}) µ1 = {um} µm: {case_label(r)}"
        if place.substitute:   # on a line of its own: the panels are narrow
            title += f"\n{place.stand_in()}"
        ax.set_title(title, loc="left", fontsize=9)
        d = np.asarray(r.ds["d_bin"].values, float) * 1e6
        bed = np.asarray(r.ds["psd_bed"].values, float)
        air = np.asarray(r.ds["psd_air"].transpose("z_band", "d_bin").values, float)
        edges = r.ds["z_band_edges"].values
        for i in range(air.shape[0]):
            ax.plot(d, air[i], color=colormaps["plasma"](i / max(1, air.shape[0])), lw=1.4,
                    marker=".", label=f"air, z = {edges[i] * 100:.0f}–{edges[i + 1] * 100:.0f} cm")
        ax.plot(d, bed, color="k", lw=2.5, label=f"bed (soil), µ1 = {fmt_um(r.mu1)}")
        res.data[f"psd_air_{place.key}"] = air
        res.data[f"psd_bed_{place.key}"] = bed
        ax.set_xscale("log")
        # a size range of a decade or less (µ1/2.5 to 2.5 µ1 or narrower): powers of ten alone
        # label it in scientific notation, and 1-2-5 steps may leave a single label
        plain_log(ax, "x", subs=(1.0, 1.5, 2.0, 3.0, 5.0, 7.0))
        ax.set(xlabel="grain diameter d [µm]", ylabel="mass fraction per size bin [-]")
        ax.grid(alpha=0.3, which="both")
        add_legend(ax, fontsize=7)
    return res


#: the profile variables as the figures write them
_SYMBOL = {"tau_p": "τp", "G": "⟨G⟩", "R_cu": "R_cu", "St": "St"}


def _log_gaps(x: np.ndarray) -> np.ndarray:
    """Indices of the levels whose value is finite and ≤ 0 with a positive value below and
    above them: a log axis cannot draw them, so the line breaks there and a positive level
    above may stand alone as a single dot (τp of a coarse grid changes sign above z_m)."""
    pos, idx = np.flatnonzero(np.isfinite(x) & (x > 0)), np.flatnonzero(np.isfinite(x) & (x <= 0))
    return idx[(idx > pos[0]) & (idx < pos[-1])] if pos.size >= 2 else idx[:0]


def _profiles(ctx: ReportContext, var: str, title: str, xlabel: str,
              norm: Callable[[RunData, np.ndarray], np.ndarray], xlog: bool,
              decorate: Callable | None = None, ylim=(0.0, 1.5), xlog_span: float = 1e-4,
              needs: Callable[[RunData], str | None] | None = None) -> FigureResult:
    """Panel (a): cases 1–6 (various u*s), (b): cases 2, 7–10 (various µ1), filled by
    ``panels.py``; ``needs(run)``: why a run's profile cannot be normalised (None if it can)."""
    def usable(r: RunData) -> str | None:
        if profile(r, var) is None:
            return f"no {var}"
        zm = r.scalar("z_m")
        if not (math.isfinite(zm) and zm > 0):
            return "z_m undefined (no saltation?)"
        return needs(r) if needs is not None else None

    groups = wind_and_soil(ctx, usable)
    drawn = [g for g in groups if g[0].runs]
    fig, axes = new_figure(max(1, len(drawn)), 1, size=(5.5 * max(1, len(drawn)), 5.0), sharey=True)
    res = FigureResult(fig, notes=[n for g in groups for n in g[0].notes])
    fig.suptitle(title)
    if not drawn:
        return nothing_to_draw(res, f"no run of this study has {var} against z/z_m")
    for ax, (panel, _, soil, name) in zip(axes[0], drawn):
        prefix = "(b)" if soil else "(a)"
        ptitle = f"{prefix} {name}: various {'µ1' if soil else 'u*s'}"
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
    """τp over ρ u*s², u*s the total stress at z_ref (the free log fit, noted, where an archive
    lacks it): each profile crosses the dotted 0.1 % line at z/z_m = 1, z_m's definition."""
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
