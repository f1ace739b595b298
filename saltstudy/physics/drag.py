"""Grain drag: Clift et al. (1978) correction and the Stokes response time (paper eqs. 3-4).

The scalar laws are numba-jitted so solver kernels call the same code as the tests.

With eq. (4), the drag per unit mass of eq. (3) is f(Re_p) (u - u_p) / T_p with the Stokes response
time T_p = rho_p d^2 / (18 rho nu). A grain falling in still air (the paper's eq. 3 has no buoyancy
term, rho_p >> rho) therefore reaches the terminal velocity w_t that solves

    f(Re_t) w_t = g T_p,   Re_t = w_t d / nu,

which reduces to the Stokes value w_s = g T_p when Re_t -> 0.
"""
from __future__ import annotations

import math

import numpy as np

from .._jit import jit

__all__ = ["drag_correction", "particle_response_time", "particle_reynolds",
           "terminal_velocity", "stokes_terminal_velocity", "terminal_velocity_residual"]


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


def stokes_terminal_velocity(d, rho_p, rho, nu, g):
    """Stokes fall speed w_s = g T_p = g rho_p d^2 / (18 rho nu) [m s^-1] (no buoyancy, f = 1).

    ``d`` [m] may be an array; densities [kg m^-3], ``nu`` [m^2 s^-1], ``g`` [m s^-2].
    """
    w = g * rho_p * np.asarray(d, dtype=float) ** 2 / (18.0 * rho * nu)
    return float(w) if w.ndim == 0 else w


def terminal_velocity_residual(w, d, rho_p, rho, nu, g):
    """F(w) = f(w d / nu) w - g T_p [m s^-1]; zero at the terminal velocity (numpy, vectorised)."""
    w = np.asarray(w, dtype=float)
    d = np.asarray(d, dtype=float)
    re = w * d / nu
    return (1.0 + 0.15 * re ** 0.687) * w - g * rho_p * d * d / (18.0 * rho * nu)


def terminal_velocity(d, rho_p, rho, nu, g, rtol: float = 1e-13, max_iter: int = 100):
    """Terminal fall speed w_t [m s^-1] with the Clift et al. (1978) drag of eq. (4).

    Solves F(w) = w (1 + 0.15 (w d/nu)^0.687) - g T_p = 0 by Newton's method started at the Stokes
    speed w_s = g T_p. F is increasing and convex in w and F(w_s) >= 0, so the iterates decrease
    monotonically to the root (no bracketing needed); the result is accurate to ``rtol`` relative.
    ``d`` [m] may be an array (vectorised). Note f(Re) is fitted for Re < ~800 (d up to ~1.5 mm in
    air); beyond that the result is an extrapolation of the law, not of physics.
    """
    d_arr = np.asarray(d, dtype=float)
    if np.any(d_arr <= 0):
        raise ValueError("grain diameter must be positive")
    target = g * rho_p * d_arr * d_arr / (18.0 * rho * nu)       # g T_p = Stokes speed
    w = target.copy()
    for _ in range(max_iter):
        re = w * d_arr / nu
        f = 1.0 + 0.15 * re ** 0.687
        F = f * w - target
        dF = f + 0.15 * 0.687 * re ** 0.687                        # d(f w)/dw
        step = F / dF
        w = w - step
        if np.all(np.abs(step) <= rtol * np.abs(w)):
            break
    else:  # pragma: no cover - Newton on a convex increasing function always converges
        raise RuntimeError("terminal_velocity: Newton iteration did not converge")
    return float(w) if w.ndim == 0 else w
