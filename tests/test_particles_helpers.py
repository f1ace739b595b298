"""Shared set-up for the grain-component tests: scenes, frozen flows, exact solutions."""
from __future__ import annotations

import math

import numpy as np

from saltstudy.config import load_case, load_fidelity, resolve_scene
from saltstudy.solver.grid import Grid
from saltstudy.solver.grains.particles import Saltation
from saltstudy.solver.state import FlowState

#: index of g in Saltation.prm (the kernels' parameter vector); tests switch gravity off with it
G_INDEX = 2


def scene(case: int = 2, fidelity: str = "smoke", **overrides):
    return resolve_scene(load_case(case, overrides=overrides or None), load_fidelity(fidelity))


def component(sc, grid: Grid | None = None, gravity: bool = True) -> tuple[Saltation, FlowState]:
    grid = grid or Grid.from_spec(sc.fidelity.grid)
    st = FlowState.zeros(grid)
    s = Saltation(grid, sc)
    if not gravity:
        s.prm[G_INDEX] = 0.0
    return s, st


def terminal_velocity(d: float, rho_p: float, rho: float, nu: float, g: float) -> float:
    """w_t solving f(Re(w)) w = g T_p by bisection to machine precision (eqs. 3-4)."""
    tp = rho_p * d * d / (18 * rho * nu)
    lo, hi = 0.0, g * tp
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        f = 1.0 + 0.15 * (mid * d / nu) ** 0.687
        if f * mid > g * tp:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def exact_slip(t: float, r0: float, d: float, tp: float, nu: float) -> float:
    """Slip r(t) of dr/dt = -(1 + c r^b) r / T_p (b = 0.687, c = 0.15 (d/nu)^b), closed form:
    with q = r^b, q/(1 + c q) = q0/(1 + c q0) exp(-b t / T_p)."""
    b = 0.687
    c = 0.15 * (d / nu) ** b
    q0 = r0 ** b
    A = q0 / (1 + c * q0) * math.exp(-b * t / tp)
    q = A / (1 - c * A)
    return q ** (1 / b)


def synthetic_flow(st: FlowState, u_star: float, z0: float, seed: int = 1, amp: float = 0.3) -> None:
    """A frozen 'turbulent-ish' log-law flow: u = u*/kappa ln(z/z0) plus smooth periodic
    perturbations (amp * u*), v and w perturbed too (w = 0 at the bed)."""
    g = st.grid
    rng = np.random.default_rng(seed)
    X = g.x_f[:, None, None]
    Xc = g.x_c[:, None, None]
    Y = g.y_c[None, :, None]
    Yf = g.y_f[None, :, None]
    zc = g.z_c[None, None, :]
    zf = g.z_f[None, None, :]
    kx = 2 * math.pi / g.Lx
    ky = 2 * math.pi / g.Ly
    ph = rng.uniform(0, 2 * math.pi, 6)
    st.u[...] = u_star / 0.4 * np.log(zc / z0) + amp * u_star * (
        np.sin(kx * X + ph[0]) * np.cos(2 * ky * Y + ph[1]))
    st.v[...] = amp * u_star * np.sin(2 * kx * Xc + ph[2]) * np.sin(ky * Yf + ph[3]) + 0 * zc
    st.w[...] = amp * u_star * np.cos(kx * Xc + ph[4]) * np.sin(ky * Y + ph[5]) * np.tanh(zf / 0.05)
    st.w[..., 0] = 0.0
    st.w[..., -1] = 0.0
    st.e[...] = 0.5 * u_star ** 2
