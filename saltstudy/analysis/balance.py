"""The saltation layer's momentum balance at the bed, two ways.

A steady layer gives the bed, per unit area and time, the streamwise momentum the grains took from
the air, tau_g(0), and takes from it the vertical momentum that carries their weight, M g (less
the small part the air's drag carries). Their ratio is the bed friction coefficient
mu_b = tau_g(0) / (M g) (Bagnold 1956; Pähtz & Durán 2018, Phys. Rev. Fluids 3, 104302).

* From the impact record (samples.nc's cumulative ``bed_px``, streamwise momentum the grains gave
  the bed, impacts minus launches, and ``bed_pz``, vertical momentum the bed gave them): over the
  sampling window tau_g(0) = d(bed_px) / (A dt), mu_b = d(bed_px) / d(bed_pz); its error from
  contiguous blocks of the window.
* From the air's budget: tau_g(0) = rho (u*^2 - tau_air(0) - dP/dt), the total stress at the
  reference height less the bulk law's on the bed and less the air's gain of momentum below
  it, P = int_0^z_ref <u> dz (zero in a steady layer, not over a 30 s window of a small box:
  ``column_momentum_rate``); mu_b = tau_g(0) / (M g), M the airborne mass of the 3-D samples;
  its error from the per-sample values.

In a steady layer that leaks no momentum the two tau_g(0) agree, and so do the two mu_b within
the air's share of the weight; the count of grains then follows the fluid stress left on the bed:
M = (rho u*^2 - tau_air(0)) / (mu_b g).
"""
from __future__ import annotations

import math

import numpy as np

from .reading import Frame
from .schema import Variables

__all__ = ["N_BLOCKS", "bed_exchange", "budget_friction", "column_momentum_rate", "layer_weights",
           "air_budget_statistics", "impact_balance_statistics"]

#: contiguous blocks of the sampling window for the impact record's error
N_BLOCKS = 6


def _at(t: np.ndarray, y: np.ndarray, tq: float) -> float:
    return float(np.interp(tq, t, y))


def bed_exchange(t: np.ndarray, bed_px: np.ndarray | None, bed_pz: np.ndarray | None,
                 t0: float, t1: float, area: float, n_blocks: int = N_BLOCKS) -> dict[str, float]:
    """From the cumulative series over [t0, t1]: ``tau_g_bed_impacts`` [Pa] (streamwise momentum
    to the bed per unit area and time), ``bed_vertical_impulse`` [Pa] (vertical momentum from the
    bed per unit area and time), ``mu_b`` (their ratio) and ``mu_b_se`` (block scatter / sqrt n).
    NaN where the record is missing or the window empty."""
    out = {"tau_g_bed_impacts": math.nan, "bed_vertical_impulse": math.nan, "mu_b": math.nan,
           "mu_b_se": math.nan}
    if bed_px is None or bed_pz is None:
        return out
    t, px, pz = (np.asarray(v, dtype=np.float64) for v in (t, bed_px, bed_pz))
    ok = np.isfinite(t) & np.isfinite(px) & np.isfinite(pz)
    t, px, pz = t[ok], px[ok], pz[ok]
    if t.size < 2 or not (t1 > t0) or area <= 0:
        return out
    t0, t1 = max(t0, float(t[0])), min(t1, float(t[-1]))
    if not t1 > t0:
        return out
    dpx = _at(t, px, t1) - _at(t, px, t0)
    dpz = _at(t, pz, t1) - _at(t, pz, t0)
    span = (t1 - t0) * area
    out["tau_g_bed_impacts"] = dpx / span
    out["bed_vertical_impulse"] = dpz / span
    if dpz > 0:
        out["mu_b"] = dpx / dpz
    edges = np.linspace(t0, t1, n_blocks + 1)
    mus = [(_at(t, px, b) - _at(t, px, a)) / dz for a, b in zip(edges[:-1], edges[1:])
           if (dz := _at(t, pz, b) - _at(t, pz, a)) > 0]
    if len(mus) >= 2:
        out["mu_b_se"] = float(np.std(mus, ddof=1) / math.sqrt(len(mus)))
    return out


def layer_weights(z_w: np.ndarray, z_lo: float, z_hi: float) -> np.ndarray:
    """The length [m] of each cell between the faces ``z_w`` (nz+1,) that lies in [z_lo, z_hi]:
    ``u_mean @ layer_weights(...)`` integrates a profile over the layer, a cut cell in part."""
    zw = np.asarray(z_w, dtype=np.float64)
    return np.clip(np.minimum(zw[1:], z_hi) - np.maximum(zw[:-1], z_lo), 0.0, None)


def column_momentum_rate(t: np.ndarray, u_mean: np.ndarray | None, z_w: np.ndarray,
                         z_top: float) -> float:
    """dP/dt [m^2 s^-2] of P = int_0^z_top <u> dz, the least-squares slope over the samples'
    times ``t`` of the column integral of their horizontal-mean profiles ``u_mean`` (samples, nz)
    on the cells between the faces ``z_w`` (the cell holding z_top counted in part). NaN with
    fewer than three samples."""
    if u_mean is None:
        return math.nan
    u, t, zw = (np.asarray(v, dtype=np.float64) for v in (u_mean, t, z_w))
    if u.ndim != 2 or u.shape[0] != t.size or u.shape[1] != zw.size - 1 or t.size < 3:
        return math.nan
    P = u @ layer_weights(zw, zw[0], z_top)
    ok = np.isfinite(P) & np.isfinite(t)
    if ok.sum() < 3 or np.ptp(t[ok]) <= 0:
        return math.nan
    return float(np.polyfit(t[ok], P[ok], 1)[0])


def budget_friction(rho: float, g: float, tau_total_kin: float, uw_bed: np.ndarray | None,
                    mass_per_m2: np.ndarray | None, column_rate: float = 0.0) -> dict[str, float]:
    """From the air's budget (module doc): ``tau_g_bed_budget`` [Pa] = rho (tau_total + uw_bed -
    column_rate) (kinematic [m^2 s^-2]: u*^2 at the reference height, the bed's u'w' per sample,
    dP/dt with NaN taken as 0), ``bed_fluid_stress_fraction`` = -uw_bed / tau_total,
    ``mu_b_budget`` = tau_g / (M g) (M [kg m^-2]) and its error from the per-sample ratios."""
    out = {"tau_g_bed_budget": math.nan, "bed_fluid_stress_fraction": math.nan,
           "mu_b_budget": math.nan, "mu_b_budget_se": math.nan}
    if uw_bed is None or mass_per_m2 is None or not (tau_total_kin > 0):
        return out
    uw, m = (np.asarray(v, dtype=np.float64).ravel() for v in (uw_bed, mass_per_m2))
    if uw.size != m.size or uw.size == 0:
        return out
    ok = np.isfinite(uw) & np.isfinite(m)
    uw, m = uw[ok], m[ok]
    if uw.size == 0:
        return out
    drift = column_rate if math.isfinite(column_rate) else 0.0
    tau_g = rho * (tau_total_kin + uw - drift)
    out["tau_g_bed_budget"] = float(tau_g.mean())
    out["bed_fluid_stress_fraction"] = float(-uw.mean() / tau_total_kin)
    if m.mean() > 0:
        out["mu_b_budget"] = float(tau_g.mean() / (m.mean() * g))
    pos = m > 0
    if pos.sum() >= 2:
        r = tau_g[pos] / (m[pos] * g)
        out["mu_b_budget_se"] = float(np.std(r, ddof=1) / math.sqrt(r.size))
    return out


def air_budget_statistics(fr: Frame, s: dict, uw_w: np.ndarray | None, u0_stress: float
                          ) -> Variables:
    """The balance at the bed from the air's budget: ``uw_w`` the total momentum flux of each
    3-D sample on the faces, ``u0_stress`` the stress u* at the bed."""
    n_t = fr.n_t
    pm = s.get("pm")
    uw_bed_i = (np.asarray(uw_w, dtype=np.float64)[:, 0]
                if uw_w is not None and uw_w.ndim == 2 and uw_w.shape[0] == n_t else None)
    mass_i = (np.nansum(np.asarray(pm, dtype=np.float64), axis=1) / fr.bed_area
              if pm is not None and pm.ndim == 2 and pm.shape[0] == n_t else None)
    col_rate = column_momentum_rate(fr.t_sample, s.get("u_mean"), fr.z_w, fr.z_ref_eff)
    # the bed's total stress: u*_0^2, with the pressure-gradient drive's body force on the column
    # below z_ref included (u*_0^2 = u*(z_ref)^2 + G z_ref)
    bud = budget_friction(fr.rho, fr.g, u0_stress ** 2 if math.isfinite(u0_stress) else math.nan,
                          uw_bed_i, mass_i, col_rate)
    V = Variables()
    V.put("column_momentum_rate", (), col_rate)
    for name, val in bud.items():
        V.put(name, (), val)
    return V


def impact_balance_statistics(fr: Frame, s: dict, budget: Variables) -> Variables:
    """The balance at the bed from the impact record over the sampling window, and its ratios to
    the air's budget (``budget``: :func:`air_budget_statistics`): 1 in a steady layer that leaks
    no momentum."""
    imp_bal = bed_exchange(fr.t_series, s.get("bed_px"), s.get("bed_pz"), fr.t0, fr.t1,
                           fr.bed_area)
    V = Variables()
    for name, val in imp_bal.items():
        V.put(name, (), val)
    mu_b_budget = budget["mu_b_budget"][1]
    tau_g_b = budget["tau_g_bed_budget"][1]
    V.put("mu_b_ratio_budget_to_impacts", (), float(mu_b_budget / imp_bal["mu_b"])
          if imp_bal["mu_b"] and math.isfinite(imp_bal["mu_b"]) else math.nan)
    V.put("tau_g_bed_ratio_budget_to_impacts", (), float(tau_g_b / imp_bal["tau_g_bed_impacts"])
          if imp_bal["tau_g_bed_impacts"] and math.isfinite(imp_bal["tau_g_bed_impacts"])
          else math.nan)
    return V
