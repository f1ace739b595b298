"""The streamers of model variants side by side: the curves Table 2's λx, λy and δy are read from.

A variants study (labels ``c<case>_<variant>_s<seed>``) compares, e.g., two boxes or two advection
schemes; its table holds the readings, this figure the curves behind them, so that a change of a
reading can be told from a change of the field: per case (row), the autocorrelation of C_p along
the wind and across it (λ = 2 × the lag where it drops below 0.4, analysis/streamers.py), and the
premultiplied spanwise spectra of C_p and of u at 0.1 m over their variance (δy is read at their
peak, docs/STREAMERS.md), with the paper's λx/2, λy/2 and δy (Table 2) marked.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["premultiplied_over_variance", "streak_curves", "streaks_figure", "VariantGrid",
           "LAMBDA_LEVEL"]

#: the level of C_p's autocorrelation whose lag is λ/2 (analysis/streamers.py, ``CORE_LEVEL``)
LAMBDA_LEVEL = 0.4


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


def streak_curves(archive: str | Path) -> dict[str, Any] | None:
    """The streamer curves of one analysis archive, or None without them."""
    import xarray as xr

    from ..ncio import NC_LOCK

    try:
        with NC_LOCK, xr.open_dataset(archive) as ds:
            if any(n not in ds for n in ("C_p_autocorr", "S_c", "S_u")):
                return None
            ac = np.asarray(ds["C_p_autocorr"].values, dtype=np.float64)
            lag_x = np.asarray(ds["lag_x"].values, dtype=np.float64)
            lag_y = np.asarray(ds["lag_y"].values, dtype=np.float64)
            ky = np.asarray(ds["ky"].values, dtype=np.float64)
            Ly = float(ds.attrs.get("Ly", math.nan))
            dy = float(ds.attrs.get("dy", math.nan))
            S_c = np.asarray(ds["S_c"].values, dtype=np.float64)
            S_u = np.asarray(ds["S_u"].values, dtype=np.float64)
    except (OSError, KeyError, ValueError):
        return None
    nx, ny = ac.shape
    # the zero lag sits at index n // 2 (the analysis' centred autocorrelation)
    return {"x": (lag_x[nx // 2:], ac[nx // 2:, ny // 2]),
            "y": (lag_y[ny // 2:], ac[nx // 2, ny // 2:]),
            "S_c": premultiplied_over_variance(ky, S_c, Ly, dy),
            "S_u": premultiplied_over_variance(ky, S_u, Ly, dy)}


class VariantGrid:
    """A figure of one row of four panels per case for runs by variant (a colour each, in the
    order first met) and seed (a line style each); ``runs``: case -> [(variant, seed, curves)]."""

    def __init__(self, runs: dict[int, list]):
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        self.runs = runs
        self.variants = list(dict.fromkeys(v for rows in runs.values() for v, _, _ in rows))
        self.colours = {v: f"C{i}" for i, v in enumerate(self.variants)}
        self.seeds = sorted({s for rows in runs.values() for _, s, _ in rows})
        self.cases = sorted(runs)
        self.fig, self.axes = plt.subplots(len(self.cases), 4, figsize=(16, 3.4 * len(self.cases)),
                                           squeeze=False, constrained_layout=True)

    def rows(self, case: int) -> list:
        """The case's runs, by variant then seed."""
        return sorted(self.runs[case], key=lambda r: (self.variants.index(r[0]), r[1]))

    def line_style(self, seed) -> str:
        return ("-", "--", ":", "-.")[self.seeds.index(seed) % 4]

    def save(self, path: Path) -> Path:
        import matplotlib.pyplot as plt

        self.fig.savefig(path, dpi=100)
        plt.close(self.fig)
        return path


def streaks_figure(runs: dict[int, list], path: Path) -> Path | None:
    """One row per case, four panels: C_p's autocorrelation along x and along y, the
    premultiplied spectra of C_p and of u at 0.1 m; a colour per variant, a line style per seed.
    ``runs``: case -> [(variant, seed, :func:`streak_curves` of its archive)]
    (``variants.variant_runs``). None when there is no run."""
    from matplotlib.ticker import LogLocator

    from .plotting import plain_log
    from .reference import PAPER_COLOR, PAPER_LABEL, paper_table2

    if not runs:
        return None
    grid = VariantGrid(runs)
    table = paper_table2()
    for row, case in enumerate(grid.cases):
        ax = grid.axes[row]
        paper = table.get(case, {})
        for v, seed, c in grid.rows(case):
            ls = grid.line_style(seed)
            for k, key in enumerate(("x", "y", "S_c", "S_u")):
                xs, ys = c[key]
                ax[k].plot(xs, ys, ls, color=grid.colours[v], lw=1.2, label=f"{v} s{seed}")
        for k, key in enumerate(("lambda_x_m", "lambda_y_m")):
            ax[k].axhline(LAMBDA_LEVEL, color="0.5", lw=0.8)
            half = paper.get(key, math.nan) / 2.0
            if math.isfinite(half):
                ax[k].axvline(half, color=PAPER_COLOR, lw=2, ls="--",
                              label=f"{PAPER_LABEL}: λ/2 = {half:g} m")
        dy_paper = paper.get("delta_y_m", math.nan)
        for k in (2, 3):
            ax[k].set_xscale("log")
            plain_log(ax[k], "x")
            ax[k].xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
            if math.isfinite(dy_paper):   # [49]: the u streaks' spacing is C_p's where it peaks
                ax[k].axvline(dy_paper, color=PAPER_COLOR, lw=2, ls="--",
                              label=f"{PAPER_LABEL}: δy of C_p = {dy_paper:g} m")
        ax[0].set(xlabel="streamwise lag [m]", ylabel=f"case {case}: autocorrelation of C_p",
                  title="(a) along the wind" if row == 0 else None)
        ax[1].set(xlabel="spanwise lag [m]", title="(b) across the wind" if row == 0 else None)
        ax[2].set(xlabel="spanwise wavelength [m]", ylabel="k_y S(k_y) / variance",
                  title="(c) C_p, premultiplied" if row == 0 else None)
        ax[3].set(xlabel="spanwise wavelength [m]",
                  title="(d) u at 0.1 m, premultiplied" if row == 0 else None)
        for a in ax:
            a.grid(alpha=0.3, which="both")
        ax[0].legend(fontsize=7)
        ax[2].legend(fontsize=7)
    grid.fig.suptitle("The streamers by case (row), variant (colour) and seed (line style); "
                 f"λ = 2 × the lag where the autocorrelation falls below {LAMBDA_LEVEL:g}",
                 fontsize=10)
    return grid.save(path)
