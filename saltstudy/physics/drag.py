"""Grain drag: Clift et al. (1978) correction and the Stokes response time (paper eqs. 3-4).

The scalar laws are numba-jitted so solver kernels call the same code as the tests.
"""
from __future__ import annotations

import math

from .._jit import jit

__all__ = ["drag_correction", "particle_response_time", "particle_reynolds"]


@jit
def drag_correction(re_p: float) -> float:
    """f(Re_p) = 1 + 0.15 Re_p^0.687 (Schiller & Naumann, in Clift et al. 1978), valid Re_p < ~800."""
    return 1.0 + 0.15 * re_p ** 0.687


@jit
def particle_response_time(d: float, rho_p: float, rho: float, nu: float) -> float:
    """Stokes response time T_p = rho_p d^2 / (18 rho nu) [s] (paper section 4.2)."""
    return rho_p * d * d / (18.0 * rho * nu)


@jit
def particle_reynolds(rel_speed: float, d: float, nu: float) -> float:
    """Re_p = |u - u_p| d / nu [-]."""
    return math.fabs(rel_speed) * d / nu
