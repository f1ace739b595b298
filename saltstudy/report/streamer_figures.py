"""Figs. 9 and 10 of Dupont et al. (2013): the streamers and the wind's streaks (section 4.1):
snapshots of C_p and u at 0.1 m, and their premultiplied spanwise spectra, the form Table 2's
delta_y is read from (docs/STREAMERS.md).
"""
from __future__ import annotations

import math

import numpy as np

from .data import ReportContext
from .panels import BY_U_STAR_S, panel_runs, wind_and_soil
from .plotting import (FigureResult, add_legend, add_notes, case_color, case_label, lacks,
                       new_figure, nothing_to_draw, plain_log)
from .reference import PAPER_COLOR, PAPER_LABEL, paper_table2

__all__ = ["fig09", "fig10", "FIG9_CASES", "premultiplied_over_variance"]


def fig09(ctx: ReportContext) -> FigureResult:
    """A row per paper case 1, 4, 6: the study's run of the case or its nearest by u*s at
    µ1 = 200 µm (``panels.py``); a row the study cannot fill is left out."""
    panel = panel_runs(ctx, FIG9_CASES, BY_U_STAR_S, lacks("C_p_snapshot", "u_snapshot"))
    rows = panel.runs
    # the aspect of the first drawn run
    lx, ly = (rows[0].run.attr("Lx", 20.0), rows[0].run.attr("Ly", 15.0)) if rows else (20.0, 15.0)
    w = 11.0
    h = len(rows) * (w / 2) * (ly / lx) * 0.95 + 1.0
    fig, axes = new_figure(2, max(1, len(rows)), size=(w, min(max(h, 3.5), 14.0)))
    res = FigureResult(fig, notes=list(panel.notes))
    fig.suptitle("Fig. 9 — snapshots: (a) C_p / C_pmax and (b) u / u_max at z = 0.1 m")
    if not rows:
        return nothing_to_draw(res, "no run of this study at µ1 = 200 µm has C_p and u snapshots")
    for row, place in enumerate(rows):
        r = place.run
        for col, (var, lab, cmap) in enumerate((("C_p_snapshot", r"$C_p / C_{p,max}$", "YlOrBr"),
                                                ("u_snapshot", r"$u / u_{max}$", "viridis"))):
            ax = axes[row, col]
            arr = np.asarray(r.ds[var].transpose("x", "y").values, float)
            vmax = np.nanmax(np.abs(arr))
            arr = arr / vmax if vmax > 0 else arr
            x, y = (np.asarray(r.ds[c].values, float) for c in ("x", "y"))
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


def premultiplied_over_variance(ky: np.ndarray, S: np.ndarray, Ly: float, dy: float
                                ) -> tuple[np.ndarray, np.ndarray]:
    """(wavelength [m], ky S(ky) / variance) of a one-sided spanwise density ``S`` [variance m]
    on modes ``ky`` [cycles m-1], the mean mode left out: the area under the curve against
    ln(wavelength) is 1. The Nyquist entry of an even grid holds the density of half a bin (so
    that ``sum S dky`` is the variance) and is doubled to the point density; without the grid's
    size (``Ly``, ``dy``) it is left out."""
    ky = np.asarray(ky, dtype=np.float64)
    s = np.array(S, dtype=np.float64)
    if ky.size < 2:
        return np.zeros(0), np.zeros(0)
    variance = float(np.nansum(s)) * (ky[1] - ky[0])
    if not (math.isfinite(Ly) and math.isfinite(dy) and dy > 0):
        ky, s = ky[:-1], s[:-1]
    elif round(Ly / dy) == 2 * (ky.size - 1):
        s[-1] *= 2.0
    ok = (ky > 0) & np.isfinite(s)
    ky, s = ky[ok], s[ok]
    pre = ky * s
    if math.isfinite(variance) and variance > 0:
        pre = pre / variance
    return 1.0 / ky, pre


def fig10(ctx: ReportContext) -> FigureResult:
    """ky S(ky) over the variance against log wavelength (area 1 against ln wavelength): top
    row cases 1–6, bottom row cases 2, 7–10, filled by ``panels.py``."""
    table = paper_table2()
    groups = wind_and_soil(ctx, lacks("S_c", "S_u"))
    drawn = [g for g in groups if g[0].runs]
    fig, axes = new_figure(2, max(1, len(drawn)), size=(11, 0.5 + 4.0 * max(1, len(drawn))))
    res = FigureResult(fig, notes=[n for g in groups for n in g[0].notes])
    fig.suptitle("Fig. 10 — premultiplied spanwise spectra of (a) C_p and (b) u at z = 0.1 m, "
                 "averaged in x and t")
    if not drawn:
        return nothing_to_draw(res, "no run of this study has spanwise spectra of C_p and u")
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
                pv = [v for n in cases
                      if math.isfinite(v := table.get(n, {}).get("delta_y_m", math.nan))]
                if pv:
                    ax.plot(pv, [0.0] * len(pv), marker="^", ms=9, ls="none",
                            color=PAPER_COLOR, transform=ax.get_xaxis_transform(), clip_on=False,
                            label=f"{PAPER_LABEL}: δy (Table 2)")
            ax.set_xscale("log")
            plain_log(ax, "x")
            ax.set(xlabel=r"spanwise wavelength $1/k_y$ [m]",
                   ylabel=f"$k_y S_{{{vlab}}}(k_y) / \\sigma_{{{vlab}}}^2$ [-]")
            ax.set_title(f"({'ab'[col]}) {vlab}, {rtitle}  (dotted: computed δy)", loc="left",
                         fontsize=9)
            ax.grid(alpha=0.3, which="both")
            add_legend(ax, fontsize=7, loc="upper right")
            add_notes(ax, panel.notes, "upper left")
    return res
