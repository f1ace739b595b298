"""Grain drag: Clift et al. (1978) correction, the Stokes response time and the exact relaxation
of a grain's velocity over a step (paper eqs. 3-4).

numba device functions (``_jit.device``) shared by the grain kernels, the steady-layer probe and
the tests; numpy callers use ``.py_func``. The drag per unit mass is f(Re_p) (u - u_p) / T_p with
T_p = rho_p d^2 / (18 rho nu); the terminal velocity solves f(Re_t) w_t = g T_p. Over a step h with
k = f(Re_p) / T_p and the seen velocity u_s frozen, eq. 3 is integrated exactly::

    u(h) = u_t + (u_p - u_t) E,   x(h) = x_p + u_t h + (u_p - u_t)(1 - E)/k,
    u_t = u_s - g / k e_z,        E = exp(-k h)

so a grain with T_p << h lands on its terminal velocity instead of overshooting it.
"""
from __future__ import annotations

import math

import numpy as np

from .._jit import device

#: the exponent of the Clift et al. (1978) correction f(Re_p) = 1 + 0.15 Re_p^0.687
CLIFT_EXPONENT = 0.687


@device
def clift_factor(re687: float) -> float:
    """f(Re_p) = 1 + 0.15 Re_p^0.687 (Schiller & Naumann, in Clift et al. 1978; valid Re_p < ~800)
    from ``re687`` = Re_p^0.687 (the kernels evaluate the power their own way)."""
    return 1.0 + 0.15 * re687


@device
def clift_slope(re687: float) -> float:
    """Re_p df/dRe_p = 0.15 * 0.687 Re_p^0.687 from ``re687`` = Re_p^0.687."""
    return (0.15 * 0.687) * re687


@device
def drag_correction(re_p: float) -> float:
    """f(Re_p) = 1 + 0.15 Re_p^0.687 (:func:`clift_factor`) at the particle Reynolds number."""
    return clift_factor(re_p ** 0.687)


@device
def particle_response_time(d: float, rho_p: float, rho: float, nu: float) -> float:
    """Stokes response time T_p = rho_p d^2 / (18 rho nu) [s] (paper section 4.2)."""
    return rho_p * d * d / (18.0 * rho * nu)


@device
def particle_reynolds(rel_speed: float, d: float, nu: float) -> float:
    """Re_p = |u - u_p| d / nu [-]."""
    return math.fabs(rel_speed) * d / nu


@device
def relaxation(em, ik, us, vs, wt, up, vp, wp):
    """Velocity after a step h of eq. 3 with ik = 1/k [s] and the target velocity (us, vs, wt:
    the seen wind plus the settling -g/k) frozen, em = expm1(-k h): (u, v, w) [m s^-1] and
    (1 - E) / k [s] (:func:`relaxed_position`)."""
    E = 1.0 + em
    ome_k = -em * ik
    un = us + (up - us) * E
    vn = vs + (vp - vs) * E
    wn = wt + (wp - wt) * E
    return un, vn, wn, ome_k


@device
def relaxed_position(x0, target, v0, h, ome_k):
    """A coordinate after a step h of :func:`relaxation` [m] (module doc)."""
    return x0 + target * h + (v0 - target) * ome_k


def terminal_velocity(d, rho_p, rho, nu, g, rtol: float = 1e-13, max_iter: int = 100):
    """Terminal fall speed w_t [m s^-1] with the Clift et al. (1978) drag of eq. (4): Newton on
    F(w) = f(w d/nu) w - g T_p from the Stokes speed (F convex increasing, F(w_s) >= 0: monotone,
    no bracketing). f is fitted for Re < ~800 (d up to ~1.5 mm in air)."""
    d_arr = np.asarray(d, dtype=float)
    if np.any(d_arr <= 0):
        raise ValueError("grain diameter must be positive")
    target = g * particle_response_time.py_func(d_arr, rho_p, rho, nu)  # g T_p = Stokes speed
    w = target.copy()
    for _ in range(max_iter):
        re687 = (w * d_arr / nu) ** CLIFT_EXPONENT
        f = clift_factor.py_func(re687)
        F = f * w - target
        dF = f + clift_slope.py_func(re687)                         # d(f w)/dw
        step = F / dF
        w = w - step
        if np.all(np.abs(step) <= rtol * np.abs(w)):
            break
    else:  # pragma: no cover - Newton on a convex increasing function always converges
        raise RuntimeError("terminal_velocity: Newton iteration did not converge")
    return float(w) if w.ndim == 0 else w
