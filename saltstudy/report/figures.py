"""The register of Figures 1-13 of Dupont et al. (2013) (``FIGURES``, ``CAPTIONS``), drawn from
analysis archives. Each ``figNN(ctx)`` returns a :class:`FigureResult`: the figure (no pyplot:
safe in worker threads), the arrays it plotted (``data``) and its notes. The figures live in
``scatter_figures`` (Figs. 1, 3, 4, 8, 13), ``profile_figures`` (2, 5, 6, 7, 11, 12) and
``streamer_figures`` (9, 10); a case the study lacks gives its place to its nearest run
(report/panels.py).
"""
from __future__ import annotations

from typing import Callable

from matplotlib.figure import Figure

from .data import ReportContext
from .plotting import FigureResult, empty_axes, new_figure
from .profile_figures import fig02, fig05, fig06, fig07, fig11, fig12
from .scatter_figures import fig01, fig03, fig04, fig08, fig13
from .streamer_figures import fig09, fig10

__all__ = ["FigureResult", "FIGURES", "CAPTIONS", "make_figures", "error_figure", "fig01", "fig02",
           "fig03", "fig04", "fig05", "fig06", "fig07", "fig08",
           "fig09", "fig10", "fig11", "fig12", "fig13"]

FIGURES: dict[str, Callable[[ReportContext], FigureResult]] = {f.__name__: f for f in (
    fig01, fig02, fig03, fig04, fig05, fig06, fig07, fig08, fig09, fig10, fig11, fig12, fig13)}

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
