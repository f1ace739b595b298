"""Time series after activation: parcel count, overshoot, equilibrium time, splash energy ratio.

Paper section 3.1 [31], Fig. 1: after release the number of grains rises (splash), overshoots,
and relaxes to a statistical equilibrium.

* ``n_parcels_mean``: the plateau, mean of ``n_parcels`` over the sampling window ``[t0, t1]``;
  ``n_parcels_peak``: the raw series' maximum; ``overshoot_ratio = peak / plateau``.
* ``t_equilibrium``: the first time the series, smoothed by a centred running mean over
  ``RUNNING_WINDOW_S``, comes within ``EQ_TOLERANCE`` of the plateau (after its maximum if that
  exceeds the plateau by more than the tolerance); NaN if never.
* ``E_splash_over_E_impact``: the increments over the window of the cumulative kinetic energy
  of rebounding + ejected grains over that of impacting ones (the whole record for an empty window).
* ``u_star_s_stress_series``: :func:`block_mean_stress_u_star` of the drive's record ``u_star_ref``.
"""
from __future__ import annotations

import math

import numpy as np

from .reading import Frame
from .schema import Variables

__all__ = ["limiting_step", "RUNNING_WINDOW_S", "EQ_TOLERANCE", "running_mean", "overshoot_stats", "increment_ratio",
           "block_mean_stress_u_star", "series_statistics"]

RUNNING_WINDOW_S = 1.0
EQ_TOLERANCE = 0.10


def running_mean(t: np.ndarray, x: np.ndarray, window_s: float) -> np.ndarray:
    """Centred running mean over ``window_s`` seconds (by index, from the median spacing)."""
    t, x = (np.asarray(v, dtype=np.float64) for v in (t, x))
    if x.size < 2:
        return x.copy()
    dt = float(np.median(np.diff(t)))
    half = int(round(0.5 * window_s / dt)) if dt > 0 else 0
    if half < 1:
        return x.copy()
    c = np.concatenate([[0.0], np.cumsum(np.nan_to_num(x))])
    n = np.concatenate([[0], np.cumsum(np.isfinite(x))])
    i = np.arange(x.size)
    lo = np.maximum(i - half, 0)
    hi = np.minimum(i + half + 1, x.size)
    with np.errstate(invalid="ignore", divide="ignore"):
        return (c[hi] - c[lo]) / (n[hi] - n[lo])


def overshoot_stats(t: np.ndarray, n: np.ndarray, t0: float, t1: float,
                    window_s: float = RUNNING_WINDOW_S, tol: float = EQ_TOLERANCE) -> dict[str, float]:
    """n_parcels_peak, n_parcels_mean, overshoot_ratio, t_equilibrium (module docstring)."""
    t, n = (np.asarray(v, dtype=np.float64) for v in (t, n))
    out = dict(n_parcels_peak=math.nan, n_parcels_mean=math.nan, overshoot_ratio=math.nan,
               t_equilibrium=math.nan)
    ok = np.isfinite(n)
    if not ok.any():
        return out
    peak = float(np.max(n[ok]))
    eps = 1e-9 * max(1.0, abs(t1))
    sel = ok & (t >= t0 - eps) & (t <= t1 + eps)
    if not sel.any():
        sel = ok & (t >= t0 - eps)
    plateau = float(n[sel].mean()) if sel.any() else math.nan
    out.update(n_parcels_peak=peak, n_parcels_mean=plateau)
    if math.isfinite(plateau) and plateau > 0:
        out["overshoot_ratio"] = peak / plateau
        rm = running_mean(t, n, window_s)
        close = np.abs(rm - plateau) <= tol * plateau
        start = int(np.nanargmax(rm)) if np.nanmax(rm) > (1.0 + tol) * plateau else 0
        idx = np.flatnonzero(close[start:])
        if idx.size:
            out["t_equilibrium"] = float(t[start + idx[0]])
    return out


def increment_ratio(t: np.ndarray, num: np.ndarray, den: np.ndarray, t0: float, t1: float) -> float:
    """(num(t1) - num(t0)) / (den(t1) - den(t0)) for cumulative series; whole record if t1 <= t0."""
    t, num, den = (np.asarray(v, dtype=np.float64) for v in (t, num, den))
    ok = np.isfinite(num) & np.isfinite(den)
    if ok.sum() < 1:
        return math.nan
    t, num, den = t[ok], num[ok], den[ok]
    if t1 > t0 and t.size >= 2:
        a = num[-1] if t1 >= t[-1] else float(np.interp(t1, t, num))
        b = den[-1] if t1 >= t[-1] else float(np.interp(t1, t, den))
        a0 = float(np.interp(t0, t, num))
        b0 = float(np.interp(t0, t, den))
        dn, dd = a - a0, b - b0
    else:
        dn, dd = num[-1], den[-1]
    return float(dn / dd) if dd > 0 else math.nan


def block_mean_stress_u_star(t: np.ndarray, u_star: np.ndarray, t0: float, t1: float,
                             block_s: float = 10.0) -> tuple[float, float, int]:
    """From a series of the friction velocity at the reference height (the drive's measure, every
    step or so): (u* of the window-mean stress, sqrt <u*^2> over [t0, t1]; its standard error from
    the scatter of the stress means of contiguous blocks of ``block_s`` seconds, sigma / sqrt(n)
    carried to u* (se_u = se_tau / (2 u*)); the number of blocks). The blocks see the swings
    shorter than the window, not the slower ones that make two realizations differ. NaN with
    fewer than two blocks."""
    t, u = (np.asarray(v, dtype=np.float64) for v in (t, u_star))
    ok = np.isfinite(t) & np.isfinite(u) & (t >= t0) & (t <= t1)
    if ok.sum() < 2 or not t1 > t0:
        return math.nan, math.nan, 0
    t, tau = t[ok], u[ok] ** 2
    mean_u = math.sqrt(float(tau.mean()))
    n = int((t1 - t0) // block_s)
    if n < 2:
        return mean_u, math.nan, n
    edges = t0 + block_s * np.arange(n + 1)
    means = [tau[(t >= a) & (t < b)].mean() for a, b in zip(edges[:-1], edges[1:])
             if np.any((t >= a) & (t < b))]
    if len(means) < 2:
        return mean_u, math.nan, len(means)
    se_tau = float(np.std(means, ddof=1) / math.sqrt(len(means)))
    return mean_u, se_tau / (2.0 * mean_u), len(means)


def series_statistics(fr: Frame, s: dict, G_tot_sample: np.ndarray) -> Variables:
    """The parcel count's plateau, overshoot and equilibrium time, the stress u* of the drive's
    record, the splash/impact energy ratio over the sampling window, and the series themselves
    (``G_tot_sample``: G_tot at the 3-D samples; ``C_p_mean``: the domain mean of every plane)."""
    t_series = fr.t_series

    def series_var(name):
        a = s.get(name)
        return (a.astype(np.float64) if a is not None and a.shape == t_series.shape
                else np.full(t_series.size, np.nan))

    V = Variables()
    n_par = series_var("n_parcels")
    for k, v in overshoot_stats(t_series, n_par, fr.t0, fr.t1).items():
        V.put(k, (), v)
    us_ser, us_se, us_nb = block_mean_stress_u_star(t_series, series_var("u_star_ref"), fr.t0, fr.t1)
    V.put("u_star_s_stress_series", (), us_ser)
    V.put("u_star_s_stress_se", (), us_se, blocks=us_nb)
    V.put("E_splash_over_E_impact", (), increment_ratio(
        t_series, series_var("E_splash"), series_var("E_impact"), fr.t0, fr.t1))
    V.put("n_parcels", ("time",), n_par)
    V.put("G_tot_series", ("time",), series_var("G_tot_series"))
    V.put("u_star_ref", ("time",), series_var("u_star_ref"))
    V.put("G_tot_sample", ("time_sample",), G_tot_sample)
    t_plane = fr.t_plane
    C_all = s.get("C_p")
    ok = C_all is not None and C_all.ndim == 3 and C_all.shape[0] == t_plane.size and C_all.size
    V.put("C_p_mean", ("time_plane",), np.asarray(C_all, dtype=np.float64).mean(axis=(1, 2))
          if ok else np.full(t_plane.size, np.nan))
    return V


def limiting_step(dt_courant: float, dt_diffusion: float, dt_grains: float, dt_max: float,
                  dt_fixed: float | None = None) -> str:
    """Name of the constraint that sets the step: "fixed", "courant", "diffusion", "grains", "dt_max"."""
    if dt_fixed is not None:
        return "fixed"
    cands = {"courant": dt_courant, "diffusion": dt_diffusion, "grains": dt_grains, "dt_max": dt_max}
    return min(cands, key=lambda k: cands[k] if math.isfinite(cands[k]) else math.inf)
