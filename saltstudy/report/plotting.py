"""What the figures share: a paper case keeps its colour in every figure, a run is labelled by
its case and its u*s read the paper's way (the total stress at z_ref) or its grain size, log axes
carry plain numbers, a figure says on itself why it cannot draw a run; figures are made without
pyplot (:func:`new_figure`), so worker threads can draw them without a display.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
from matplotlib.figure import Figure

from .data import RunData
from .panels import PanelRun
from .reference import CASES_WIND, paper_table2

__all__ = ["FigureResult", "WIND_COLORS", "SOIL_COLORS", "MARKERS", "OWN_COLORS", "case_color",
           "fmt_um", "case_label", "has_stress_u_star", "u_star_stress", "new_figure", "plain_log",
           "add_legend", "add_notes", "nothing_to_draw", "lacks", "empty_axes", "u_star_ratio",
           "is_200um", "paper_u_star_ratio", "save_figure"]


@dataclass
class FigureResult:
    fig: Figure
    data: dict[str, np.ndarray] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


WIND_COLORS = {n: c for n, c in zip(CASES_WIND, ("#1b9e77", "#66a61e", "#e6ab02", "#d95f02",
                                                    "#e7298a", "#7570b3"))}
SOIL_COLORS = {2: "#66a61e", 7: "#a6761d", 8: "#e41a1c", 9: "#377eb8", 10: "#222222"}
MARKERS = {"200": "o", "other": "s", "scene": "^"}
#: colours of runs that are no paper case (Fig. 1), apart from the cases' own
OWN_COLORS = ("#17becf", "#bcbd22", "#8c564b", "#9467bd", "#ff7f0e", "#1f77b4")


def case_color(n: int | None, soil: bool = False) -> str:
    if soil and n in SOIL_COLORS:
        return SOIL_COLORS[n]
    return WIND_COLORS.get(n, SOIL_COLORS.get(n, "0.3"))


def fmt_um(d: float) -> str:
    return f"{d * 1e6:.0f} µm" if math.isfinite(d) else "µ1 ?"


def case_label(r: RunData, soil: bool = False, place: PanelRun | None = None) -> str:
    """The run's name (``case N`` for a plain case, else its label), what it stands in for when
    it fills the place of another paper case (``place``), and its u*s or (``soil``) µ1."""
    name = f"case {r.case}" if r.case is not None and r.plain_case else r.label
    if place is not None and place.substitute:
        name = f"{name} {place.stand_in()}"
    if soil:
        return f"{name}, µ1 = {fmt_um(r.mu1)}"
    us = u_star_stress(r)
    if not math.isfinite(us):
        return name
    return f"{name}, u*s = {us:.2f} m s⁻¹" + ("" if has_stress_u_star(r) else " (free log fit)")


def has_stress_u_star(r: RunData) -> bool:
    us = r.scalar("u_star_s_stress")
    return math.isfinite(us) and us > 0


def u_star_stress(r: RunData) -> float:
    """u*s the paper's way (the total stress at z_ref, Table 2's leading column): the u*s that
    places a run in the figures and normalises its profiles; the free log fit only where an
    archive lacks it (labels then say "free log fit") [m s-1]."""
    return r.scalar("u_star_s_stress") if has_stress_u_star(r) else r.scalar("u_star_s")


def new_figure(ncols: int = 1, nrows: int = 1, size=(6.4, 4.6), **kw) -> tuple[Figure, np.ndarray]:
    fig = Figure(figsize=size, layout="constrained")
    return fig, fig.subplots(nrows, ncols, squeeze=False, **kw)


def save_figure(fig: Figure, folder: Path, stem: str, dpi: float,
                formats=("png", "pdf")) -> list[Path]:
    """Write ``fig`` as ``folder/stem.<format>`` in each format; returns the files."""
    files = [Path(folder) / f"{stem}.{ext}" for ext in formats]
    for f in files:
        fig.savefig(f, dpi=dpi)
    return files


def plain_log(ax, axis: str = "x", subs: tuple[float, ...] | None = None) -> None:
    """Log axis with plain-number labels (0.5, 1, 2) and no minor labels. ``subs``: the
    mantissas of the labelled ticks in each decade (``(1, 2, 5)`` labels 50, 100, 200, 500),
    for an axis spanning a decade or less, where powers of ten alone leave one label or none."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    a = ax.xaxis if axis == "x" else ax.yaxis
    if subs is not None:
        a.set_major_locator(LogLocator(base=10.0, subs=subs))
        a.set_minor_locator(LogLocator(base=10.0, subs=tuple(range(1, 10))))
    a.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    a.set_minor_formatter(NullFormatter())


def add_legend(ax, below: bool = False, **kw) -> None:
    """below: under the axes, for scatter plots whose points may fall anywhere (a legend inside
    hid case 10's point in Fig. 4)."""
    if below:
        kw.update(loc="upper center", bbox_to_anchor=(0.5, -0.14))
    if ax.get_legend_handles_labels()[0]:
        ax.legend(**kw)


def add_notes(ax, notes: list[str], loc: str = "lower right") -> None:
    if not notes:
        return
    x, ha = (0.98, "right") if "right" in loc else (0.02, "left")
    y, va = (0.02, "bottom") if "lower" in loc else (0.98, "top")
    ax.text(x, y, "\n".join(notes), transform=ax.transAxes, ha=ha, va=va, fontsize=7.5,
            color="firebrick", bbox=dict(boxstyle="round", fc="white", ec="firebrick", alpha=0.85))


def nothing_to_draw(res: FigureResult, message: str) -> FigureResult:
    """A figure none of whose places the study can fill says why in words (and its notes),
    without a frame."""
    for ax in list(res.fig.axes):
        ax.remove()
    res.fig.text(0.5, 0.5, "\n".join([message] + res.notes), ha="center", va="center",
                 fontsize=11, color="firebrick", wrap=True)
    return res


def lacks(*names: str) -> Callable[[RunData], str | None]:
    """``usable`` for :func:`panels.panel_runs`: the first of ``names`` the run's archive lacks."""
    def usable(r: RunData) -> str | None:
        return next((f"no {n}" for n in names if not r.has(n)), None)
    return usable


def empty_axes(ax, message: str) -> None:
    ax.text(0.5, 0.5, message, transform=ax.transAxes, ha="center", va="center", fontsize=11,
            color="firebrick")
    ax.set(xticks=[], yticks=[])


def u_star_ratio(r: RunData) -> float:
    """u*s/u*t with the paper's u*s reading: √|total stress| at the reference height (its [33],
    Table 2's "u*s, stress at z_ref"), not the free log-law fit."""
    us, ut = r.scalar("u_star_s_stress"), r.scalar("u_star_t")
    return us / ut if math.isfinite(us) and math.isfinite(ut) and ut > 0 else math.nan


def is_200um(r: RunData) -> bool:
    return math.isfinite(r.mu1) and abs(r.mu1 - 200e-6) < 1e-6


def paper_u_star_ratio(n: int) -> float:
    row = paper_table2().get(n, {})
    return row.get("u_star_s", math.nan) / row.get("u_star_t", math.nan)
