"""Correlation between the grain concentration C_p and the streamwise wind u (paper eq. 12).

R_cu(z) (section 4.2 [50], Fig. 11)
    ``R_cu(z) = <C_p' u'(z)> / (sqrt<C_p'^2> sqrt<u'(z)^2>)``, ``<>`` the average over x, y and
    the 3-D sample times (section 2.4 [29]), C_p the samples' ``C_p_s``, u the cell-centred ``u``;
    accumulated sample by sample so the 3-D field is never copied; NaN where a variance vanishes.
    ``noise``: the white parcel-count noise of the run beyond the paper's
    (:mod:`saltstudy.analysis.streamers`), taken out of ``<C_p'^2>``: uncorrelated with u, it
    lowers |R_cu| by sqrt(1 - noise/<C_p'^2>) and nothing else.
``R_cu_upper``: the mean over ``0.6 z_m <= z <= z_m``, where the paper finds a constant value.
R_cu_lag(lag_t, z_plane) (beyond eq. 12; the paper's remark in [51])
    Correlation of C_p(t) with the past wind ``u(t - tau)`` at the plane heights, from the 2-D
    planes; means and variances over all planes, the covariance over all pairs (t, t - tau)
    inside the record. Lag 0 is eq. 12 at the plane heights.
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np

from .reading import Frame
from .schema import Variables

__all__ = ["correlation_profile", "upper_mean", "lagged_correlation", "UPPER_FRACTION",
           "r_cu_statistics"]

UPPER_FRACTION = 0.6


def correlation_profile(C: np.ndarray, u: np.ndarray, noise: float = 0.0) -> np.ndarray:
    """R_cu(z) of ``C (nt, nx, ny)`` and ``u (nt, nx, ny, nz)`` (eq. 12), ``noise`` taken out of
    the variance of C (module docstring)."""
    C = np.asarray(C)
    nt = C.shape[0]
    nz = u.shape[-1]
    if nt == 0 or u.shape[0] != nt:
        return np.full(nz, np.nan)
    n = 0
    s_c = s_cc = 0.0
    s_u, s_uu, s_cu = np.zeros(nz), np.zeros(nz), np.zeros(nz)
    for t in range(nt):
        c = np.asarray(C[t], dtype=np.float64).ravel()
        uu = np.asarray(u[t], dtype=np.float64).reshape(-1, nz)
        n += c.size
        s_c += c.sum()
        s_cc += float(c @ c)
        s_u += uu.sum(axis=0)
        s_uu += np.einsum("ik,ik->k", uu, uu)
        s_cu += c @ uu
    # shift-free formulas in float64; u is O(10) m s-1 and its variance O(0.1-1): fine
    mc, mu = s_c / n, s_u / n
    var_c = s_cc / n - mc * mc - noise
    var_u = s_uu / n - mu * mu
    cov = s_cu / n - mc * mu
    with np.errstate(invalid="ignore", divide="ignore"):
        r = cov / np.sqrt(var_c * var_u)
    tiny_c = var_c <= 1e-12 * max(s_cc / n, 1e-300)
    tiny_u = var_u <= 1e-12 * np.maximum(s_uu / n, 1e-300)
    r = np.where(tiny_u | tiny_c, np.nan, r)
    return np.clip(r, -1.0, 1.0)


def upper_mean(z: np.ndarray, R: np.ndarray, z_m: float, frac: float = UPPER_FRACTION) -> float:
    """Mean of R over ``frac z_m <= z <= z_m``; NaN if no finite level there."""
    if not (math.isfinite(z_m) and z_m > 0):
        return math.nan
    z, R = (np.asarray(v, dtype=np.float64) for v in (z, R))
    sel = (z >= frac * z_m) & (z <= z_m) & np.isfinite(R)
    return float(R[sel].mean()) if sel.any() else math.nan


def lagged_correlation(C: np.ndarray, u: np.ndarray, max_lag: int, noise: float = 0.0) -> np.ndarray:
    """R(k, j) = corr(C(t), u(t - k, plane j)) for k = 0..max_lag; ``u (nt, nx, ny, nzp)``;
    ``noise`` taken out of the variance of C as in :func:`correlation_profile`."""
    C, u = (np.asarray(v, dtype=np.float64) for v in (C, u))
    nt = C.shape[0]
    nzp = u.shape[-1]
    out = np.full((max_lag + 1, nzp), np.nan)
    if nt == 0:
        return out
    c = C - C.mean()
    var_c = float((c ** 2).mean()) - noise
    sc = math.sqrt(var_c) if var_c > 0 else 0.0
    if not sc > 0:
        return out
    for j in range(nzp):
        a = u[..., j] - u[..., j].mean()
        sa = math.sqrt(float((a ** 2).mean()))
        if not sa > 0:
            continue
        for k in range(min(max_lag, nt - 1) + 1):
            cov = float((c[k:] * a[: nt - k]).mean())
            out[k, j] = cov / (sc * sa)
    return out


def r_cu_statistics(fr: Frame, s: dict, z_m: float,
                    noise_to_paper: Callable[[np.ndarray], np.ndarray]) -> Variables:
    """R_cu(z) (eq. 12) from the 3-D samples' C_p and u, with the mean of ``noise_to_paper``
    (per-plane variance, :meth:`saltstudy.analysis.streamer_statistics.ParcelNoise.to_paper`)
    taken out of C_p's variance so that it carries the paper's parcel-count noise, and its mean
    over the upper layer (0.6 z_m to z_m)."""
    u3 = s.get("u")
    Cs = s.get("C_p_s")
    if u3 is not None and Cs is not None and u3.ndim == 4 and Cs.ndim == 3 and u3.shape[0] == Cs.shape[0]:
        R_cu = correlation_profile(Cs, u3, noise=float(np.mean(noise_to_paper(Cs))))
    else:
        R_cu = np.full(fr.nz, np.nan)
    V = Variables()
    V.put("R_cu", ("z",), R_cu)
    V.put("R_cu_upper", (), upper_mean(fr.z, R_cu, z_m))
    return V
