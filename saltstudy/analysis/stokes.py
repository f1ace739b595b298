"""Dissipation eps_tot (paper eq. 13), eddy time T_eps, grain response time T_p, Stokes number St.

Section 4.2 [52]: ``St = T_p / T_eps``, ``T_eps = 0.5 <u_i'^2> / eps_tot`` and

    eps_tot = (<u_i'u_i'> - <u_i'u_pi'>) <Q/V_cell sum_p m_p f(Re_p)/(rho T_p)>
              - <tau_ij' du_i'/dx_j>                                          (eq. 13)

Both terms are sinks of the *resolved* velocity variance (the paper's budget "of the mean
resolved-scale wind velocity variance"), so ``<u_i'u_i'> = 2 tke_res`` (resolved, horizontal and
time mean at the level) in the first factor and in T_eps.

Drag term, from the layer sums of ``samples.nc`` summed over the sample times (``P_*``):
``eps_drag = beta (2 tke_res - <u_i'u_pi'>)`` with ``beta(z) = <pdrag>/(rho Lx Ly dz)`` [s-1]
(``pdrag = sum Q m_p f(Re_p)/T_p`` per layer: the horizontal mean of the paper's ``<Q/V_cell sum
m_p f/(rho T_p)>``) and the mass-weighted fluid-grain covariance ``<u_i'u_pi'> = P_(uf.up)/P_m -
(P_uf/P_m)(P_u/P_m)``: only the streamwise mean products are removed, the lateral and vertical
means being ~0 in a horizontally homogeneous flow (the Eulerian mean <u> cancels exactly).

SGS term: ``sgs_transfer`` in samples.nc is ``-<tau_ij S_ij>`` with the *total* velocity; its
mean-flow part ``-uw_sgs d<u>/dz`` is energy the SGS take from the *mean* flow, so
``eps_sgs = -<tau_ij' S_ij'> = sgs_transfer + uw_sgs d<u>/dz`` (centred differences on the
stretched levels). ``eps_tot = eps_drag + eps_sgs``; T_eps and St are NaN where it is not positive.

T_p(z) = rho_p d^2/(18 rho nu) (section 4.2 [52]), d the mass-weighted mean diameter of the grains
at that level over the window from ``size_hist``: ``d = sum n d^4 / sum n d^3`` (bin centres).
"""
from __future__ import annotations

import numpy as np

from .reading import Frame, time_mean, time_sum
from .schema import Variables

__all__ = ["drag_rate", "fluid_grain_covariance", "eps_drag", "eps_sgs_fluct",
           "eddy_time", "mass_mean_diameter", "response_time", "stokes_number",
           "stokes_statistics"]


def _nan_div(a, b):
    a, b = (np.asarray(v, dtype=np.float64) for v in (a, b))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(b > 0, a / np.where(b > 0, b, 1.0), np.nan)


def drag_rate(pdrag_mean: np.ndarray, rho: float, dz: np.ndarray, Lx: float, Ly: float) -> np.ndarray:
    """beta(z) = <pdrag>/(rho Lx Ly dz) [s-1] (time-mean pdrag per layer)."""
    return np.asarray(pdrag_mean, dtype=np.float64) / (rho * Lx * Ly * np.asarray(dz, dtype=np.float64))


def fluid_grain_covariance(P_m: np.ndarray, P_ufup: np.ndarray, P_uf: np.ndarray,
                           P_u: np.ndarray) -> np.ndarray:
    """<u_i'u_pi'> (mass-weighted over grains; NaN without grains) from time-summed layer sums."""
    return _nan_div(P_ufup, P_m) - _nan_div(P_uf, P_m) * _nan_div(P_u, P_m)


def eps_drag(beta: np.ndarray, tke_res: np.ndarray, cov_fp: np.ndarray) -> np.ndarray:
    """Drag dissipation of resolved variance, beta (2 tke_res - <u_i'u_pi'>) [m2 s-3].

    Zero where beta is zero (no grains), whatever the covariance.
    """
    beta = np.asarray(beta, dtype=np.float64)
    cov = np.where(np.isfinite(cov_fp), cov_fp, 0.0)
    return np.where(beta > 0, beta * (2.0 * np.asarray(tke_res, dtype=np.float64) - cov), 0.0)


def eps_sgs_fluct(sgs_transfer: np.ndarray, uw_sgs_c: np.ndarray, u_mean: np.ndarray,
                  z: np.ndarray) -> np.ndarray:
    """-<tau_ij' S_ij'> = sgs_transfer + uw_sgs d<u>/dz [m2 s-3] (module docstring)."""
    z, u = (np.asarray(v, dtype=np.float64) for v in (z, u_mean))
    dudz = np.gradient(u, z) if z.size >= 2 else np.zeros_like(u)
    return np.asarray(sgs_transfer, dtype=np.float64) + np.asarray(uw_sgs_c, dtype=np.float64) * dudz


def eddy_time(tke_res: np.ndarray, eps_tot: np.ndarray) -> np.ndarray:
    """T_eps = 0.5<u_i'^2>/eps_tot = tke_res/eps_tot [s]; NaN where eps_tot <= 0."""
    return _nan_div(tke_res, eps_tot)


def mass_mean_diameter(hist: np.ndarray, d_bin: np.ndarray) -> np.ndarray:
    """Mass-weighted mean diameter per level from counts ``hist (nz, nbin)`` [m]."""
    h = np.nan_to_num(np.asarray(hist, dtype=np.float64))
    d = np.asarray(d_bin, dtype=np.float64)
    return _nan_div(h @ d ** 4, h @ d ** 3)


def response_time(d: np.ndarray, rho_p: float, rho: float, nu: float) -> np.ndarray:
    """T_p = rho_p d^2/(18 rho nu) [s]."""
    d = np.asarray(d, dtype=np.float64)
    return rho_p * d ** 2 / (18.0 * rho * nu)


def stokes_number(T_p: np.ndarray, T_eps: np.ndarray) -> np.ndarray:
    return _nan_div(T_p, T_eps)


def stokes_statistics(fr: Frame, s: dict, hist_z: np.ndarray, u_mean: np.ndarray,
                      tke_res: np.ndarray, uw_sgs_c: np.ndarray) -> Variables:
    """T_p, eps_tot (eq. 13), T_eps and St = T_p / T_eps by level (section 4.2 [52], Fig. 12);
    ``hist_z`` from ``sizes.size_statistics``, the window-mean profiles from
    ``profiles.wind_profiles``."""
    nz, d_bin = fr.nz, fr.d_bin
    d_mass = mass_mean_diameter(hist_z, d_bin) if d_bin.size else np.full(nz, np.nan)
    T_p = response_time(d_mass, fr.rho_p, fr.rho, fr.nu)
    P_m = time_sum(s.get("pm"), nz)
    beta = drag_rate(time_mean(s.get("pdrag"), nz), fr.rho, fr.dz, fr.Lx, fr.Ly) \
        if s.get("pdrag") is not None else np.zeros(nz)
    beta = np.nan_to_num(beta)
    cov_fp = fluid_grain_covariance(P_m, time_sum(s.get("pmuf_up"), nz), time_sum(s.get("pmuf"), nz),
                                    time_sum(s.get("pmu"), nz))
    e_drag = eps_drag(beta, tke_res, cov_fp)
    e_sgs_f = eps_sgs_fluct(time_mean(s.get("sgs_transfer"), nz), uw_sgs_c, u_mean, fr.z)
    eps_tot = e_drag + e_sgs_f
    T_eps = eddy_time(tke_res, eps_tot)
    V = Variables()
    V.put("d_mass_mean", ("z",), d_mass)
    V.put("T_p", ("z",), T_p)
    V.put("eps_drag", ("z",), e_drag)
    V.put("eps_sgs", ("z",), e_sgs_f)
    V.put("eps_tot", ("z",), eps_tot)
    V.put("T_eps", ("z",), T_eps)
    V.put("St", ("z",), stokes_number(T_p, T_eps))
    return V
