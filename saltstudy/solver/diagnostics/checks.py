"""Per-step health checks: finiteness of u, v, w, e and the advective Courant number. The kernels'
fastmath flags keep NaN/Inf semantics (_jit.py), so ``math.isfinite`` really tests. A failure
raises ``SolverBlowUp`` naming the step, the time, the field and the first offending (i, j, k).
"""
from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..._jit import pjit
from ..state import SolverBlowUp

#: Courant number beyond which RK3 with centred advection is unstable (sqrt 3, Wicker &
#: Skamarock 2002): the run is stopped before it fills with NaN.
CFL_RUNAWAY = math.sqrt(3.0)


@pjit
def _first_nonfinite_slab(a):
    nx = a.shape[0]
    first = np.full(nx, -1, dtype=np.int64)
    for i in prange(nx):
        flat = a[i].ravel()
        for n in range(flat.size):
            if not math.isfinite(flat[n]):
                first[i] = n
                break
    return first


def first_nonfinite(a: np.ndarray) -> tuple[int, ...] | None:
    """Index of the first non-finite value of a 3-D array (x-slab order), or None."""
    first = _first_nonfinite_slab(a)
    bad = np.nonzero(first >= 0)[0]
    if bad.size == 0:
        return None
    i = int(bad[0])
    return (i,) + tuple(int(q) for q in np.unravel_index(int(first[i]), a.shape[1:]))


@pjit
def _health(u, v, w, e, rdx, rdy, dzc, cml, cml_v, nu_mol, rdx2, rdy2, rdz2):
    """(max Courant rate, max diffusion rate [s^-1], count of non-finite u, v, w, e)."""
    nx, ny, nz = u.shape
    part = np.zeros(nx)
    dpart = np.zeros(nx)
    bad = np.zeros(nx, dtype=np.int64)
    for i in prange(nx):
        ip = (i + 1) % nx
        m = 0.0
        dm = 0.0
        nb = 0
        for j in range(ny):
            jp = (j + 1) % ny
            for k in range(nz):
                uu = u[i, j, k]
                vv = v[i, j, k]
                ww = w[i, j, k]
                ek = e[i, j, k]
                if not (math.isfinite(uu) and math.isfinite(vv) and math.isfinite(ww)
                        and math.isfinite(ek)):
                    nb += 1
                    continue
                c = (0.5 * abs(uu + u[ip, j, k]) * rdx + 0.5 * abs(vv + v[i, jp, k]) * rdy
                     + 0.5 * abs(ww + w[i, j, k + 1]) / dzc[k])
                c = max(c, abs(uu) * rdx, abs(vv) * rdy, abs(ww) / dzc[k])
                if c > m:
                    m = c
                if ek < 0.0:
                    ek = 0.0
                se = math.sqrt(ek)
                r = 2.0 * ((cml[k] * se + nu_mol) * (rdx2 + rdy2) + (cml_v[k] * se + nu_mol) * rdz2[k])
                if r > dm:
                    dm = r
            if not math.isfinite(w[i, j, nz]):
                nb += 1
        part[i] = m
        dpart[i] = dm
        bad[i] = nb
    return part.max(), dpart.max(), bad.sum()


def health(grid, state, cml, cml_v, nu_mol, vertical: bool = True) -> tuple[float, float, int]:
    """(Courant rate, diffusion rate [s^-1], non-finite count); ``vertical`` False: horizontal."""
    rdz2 = 1.0 / grid.dz_c**2 if vertical else np.zeros(grid.nz)
    c, d, n = _health(state.u, state.v, state.w, state.e, 1.0 / grid.dx, 1.0 / grid.dy, grid.dz_c,
                      cml, cml_v, nu_mol, 1.0 / grid.dx**2, 1.0 / grid.dy**2, rdz2)
    return float(c), float(d), int(n)


def locate_nonfinite(state) -> None:
    """Raise SolverBlowUp at the first non-finite value of u, v, w, e (if any)."""
    for name in ("u", "v", "w", "e"):
        a = getattr(state, name)
        idx = first_nonfinite(a)
        if idx is not None:
            raise SolverBlowUp(state.step, state.t, name, idx, float(a[idx]))


def check_courant(state, courant_rate: float, dt: float) -> float:
    """Raise SolverBlowUp if courant_rate dt exceeds CFL_RUNAWAY; return the Courant number."""
    cfl = courant_rate * dt
    if not math.isfinite(cfl) or cfl > CFL_RUNAWAY:
        g = state.grid
        c = (np.abs(state.u) / g.dx + np.abs(state.v) / g.dy
             + np.abs(state.w[..., :-1]) / g.dz_c)
        idx = tuple(int(q) for q in np.unravel_index(int(np.argmax(c)), c.shape))
        i, j, k = idx
        # four digits: a step just past the bound must not print as equal to it
        raise SolverBlowUp(state.step, state.t, "u", idx, float(state.u[idx]),
                           reason=f"Courant number {cfl:.4f} beyond sqrt(3) = {CFL_RUNAWAY:.4f} "
                                  f"(cell centre x = {g.x_c[i]:.3g} m, y = {g.y_c[j]:.3g} m, "
                                  f"z = {g.z_c[k]:.3g} m)")
    return cfl
