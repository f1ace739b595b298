"""Mean wind profiles, the log-law fit (u*s, z0s) and the stress friction velocity.

Paper section 3.1 [33]-[34]: without grains the flow is a constant-stress layer with a log
profile; with grains a log profile and constant stress hold above the saltation layer, with the
saltation friction velocity ``u*s`` and roughness length ``z0s``. The paper reads u* from the
stress, ``u*^2 = |<u'w'>|`` at z = 2 m, and z0 from a regression of ``<u> = (u*/kappa) ln(z/z0)``.

This module provides

* :func:`faces_to_centres` - the momentum flux ``uw_res + uw_sgs`` is stored on the faces
  ``z_w``; the centre value is the mean of the two faces of the cell;
* :func:`log_law_fit` - least squares of ``<u>`` on ``ln z`` over a height range:
  slope ``a = u*/kappa``, intercept ``b = -(u*/kappa) ln z0``, so ``u* = kappa a`` and
  ``z0 = exp(-b/a)``;
* :func:`fit_range` - the documented range of that fit (see its docstring);
* :func:`stress_u_star` - ``sqrt|uw|`` interpolated to a reference height.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..physics.laws import invert_log_law_shape, regress_log_law

__all__ = ["LogFit", "faces_to_centres", "log_law_fit", "fit_range", "stress_u_star",
           "interp_at", "FIT_Z_FLOOR", "MIN_FIT_POINTS"]

#: lowest height of the log-law fit [m]: the paper finds the log law "above about z = 0.30 m"
#: with grains (section 3.1 [34]); the fit never starts below the saltation height z_m either.
FIT_Z_FLOOR = 0.3
#: fewer levels than this in the fit range give NaN (a two-parameter fit needs redundancy)
MIN_FIT_POINTS = 3


@dataclass(frozen=True)
class LogFit:
    """Result of a log-law regression. All NaN when undefined."""
    u_star: float
    z0: float
    n_points: int
    r2: float
    z_min: float
    z_max: float


def faces_to_centres(a_w: np.ndarray) -> np.ndarray:
    """Values on the nz+1 faces (last axis) -> the nz cell centres (mean of the two faces)."""
    a_w = np.asarray(a_w, dtype=np.float64)
    return 0.5 * (a_w[..., :-1] + a_w[..., 1:])


def fit_range(z_m: float, Lz: float, damping_depth: float,
              z_floor: float = FIT_Z_FLOOR, drive: str = "top") -> tuple[float, float]:
    """Height range [z_min, z_max] of the log-law fit.

    ``z_min = max(z_floor, z_m)``: above the saltation layer, where grains no longer extract
    momentum (z_m NaN, e.g. the particle-free spin-up: ``z_floor``, 0.3 m by default).
    ``z_max``: top drive, ``(Lz - damping_depth) / 2``, the lower half of the undamped column
    (above it the top lid and the Rayleigh layer bend the profile; also where the forcing holds
    u*); pressure-gradient drive (no damping layer), ``Lz / 3``: the lower third, where the
    local-equilibrium profile of the linear stress holds (outer-layer effects grow above).
    """
    z_lo = float(z_floor)
    if z_m is not None and math.isfinite(z_m):
        z_lo = max(z_lo, float(z_m))
    if drive == "pressure_gradient":
        z_hi = float(Lz) / 3.0
    else:
        z_hi = 0.5 * (float(Lz) - float(damping_depth))
    return z_lo, z_hi


def log_law_fit(z: np.ndarray, u: np.ndarray, z_min: float, z_max: float, kappa: float,
                min_points: int = MIN_FIT_POINTS, H: float | None = None) -> LogFit:
    """Regress ``u = (u*/kappa) ln(z/z0)`` on the levels with ``z_min <= z <= z_max``.

    Returns ``u*`` = kappa * slope and ``z0 = exp(-intercept/slope)``; NaN when fewer than
    ``min_points`` finite levels lie in the range or the slope is not positive. With ``H`` (the
    domain height of a pressure-gradient drive) ln z is replaced by the shape F(z) of the
    linear-stress profile (``physics.laws.log_law_shape``) and ``u*`` is the surface value u*_0.
    """
    a, b, lz, uu = regress_log_law(z, u, z_min, z_max, H)
    n = int(uu.size)
    nan = LogFit(math.nan, math.nan, n, math.nan, float(z_min), float(z_max))
    if n < min_points or not (a > 0 and math.isfinite(a) and math.isfinite(b)):
        return nan
    resid = uu - (a * lz + b)
    ss_tot = float(np.sum((uu - uu.mean()) ** 2))
    r2 = 1.0 - float(np.sum(resid ** 2)) / ss_tot if ss_tot > 0 else math.nan
    return LogFit(float(kappa * a), float(invert_log_law_shape(-b / a, H)), n, r2, float(z_min),
                  float(z_max))


def interp_at(z: np.ndarray, f: np.ndarray, z0: float) -> float:
    """Linear interpolation of ``f(z)`` at ``z0``; NaN outside the range or for NaN input."""
    z = np.asarray(z, dtype=np.float64)
    f = np.asarray(f, dtype=np.float64)
    ok = np.isfinite(f)
    if ok.sum() < 1 or not math.isfinite(z0) or z0 < z[ok].min() or z0 > z[ok].max():
        return math.nan
    return float(np.interp(z0, z[ok], f[ok]))


def stress_u_star(z: np.ndarray, uw: np.ndarray, z_ref: float) -> float:
    """``u* = sqrt|<u'w'>(z_ref)|`` (paper section 3.1 [33]); ``uw`` kinematic [m2 s-2]."""
    v = interp_at(z, uw, z_ref)
    return math.sqrt(abs(v)) if math.isfinite(v) else math.nan
