"""Threshold friction velocity for saltation, Shao & Lu (2000), J. Geophys. Res., 105(D17),
22437-22443, eq. (24), as used for Table 2 of the paper:

    u*t^2 = A_N ( (rho_p - rho) g d / rho  +  gamma / (rho d) )

with A_N = 0.0123 and gamma = 3e-4 kg s^-2 (Dupont et al. 2013, section 3.1). With the paper's
mean diameter <d_p> it gives Table 2 within 0.011 m/s (0.300, 0.338 against 0.29, 0.33 at 300 and
400 um); a count-mean diameter would match every rounded value, but the paper's text says <d_p>.
"""
from __future__ import annotations

import numpy as np

#: Shao & Lu (2000) dimensionless coefficient A_N [-]
SHAO_LU_A_N = 0.0123
#: Shao & Lu (2000) cohesion parameter gamma [kg s^-2]
SHAO_LU_GAMMA = 3.0e-4


def threshold_friction_velocity(d, rho_p, rho, g, A_N=SHAO_LU_A_N, gamma=SHAO_LU_GAMMA):
    """Shao & Lu (2000) threshold friction velocity u*t [m s^-1] at diameter(s) ``d`` [m];
    densities [kg m^-3], g [m s^-2], A_N [-], gamma [kg s^-2]."""
    d_arr = np.asarray(d, dtype=float)
    if np.any(d_arr <= 0):
        raise ValueError("grain diameter must be positive")
    ut = np.sqrt(A_N * ((rho_p - rho) * g * d_arr / rho + gamma / (rho * d_arr)))
    return float(ut) if ut.ndim == 0 else ut


def threshold_for_soil(soil, air, threshold, d=None) -> float:
    """u*t [m s^-1] of a configured case: Shao & Lu at <d_p> (paper eq. 8), or at ``d`` [m]."""
    diameter = soil.mean_diameter if d is None else d
    return threshold_friction_velocity(diameter, soil.rho_p, air.rho, air.g, threshold.A_N,
                                       threshold.gamma)
