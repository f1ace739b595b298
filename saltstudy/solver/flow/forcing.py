"""Drive of the flow (``forcing.drive``; docs/ARCHITECTURE.md, "Forcing").

Pressure gradient: a uniform streamwise body force G = -(1/rho) dP/dx [m s^-2] under a free-slip
lid. The steady mean balance d tau/dz = -G, tau(H) = 0 makes the total (resolved + SGS + grain)
stress tau(z) = G (H - z) whatever the turbulence or the grains do; G = u*s^2 / (H - z_hold) holds
it at u*s^2 at the bed (``PG_HOLD_HEIGHT`` = 0) at every fidelity, and within a few per cent of it
at the top of the saltation layer (z_m/H ~ 0.05). The equilibrium shear is u*(z)/(kappa z),
u*(z) = u*_0 sqrt(1 - z/H) (diagnostics.flow.fit_log_law with H).

Top (the paper's): the Rayleigh layer pulls u towards ``state.u_drive``, feeding the x-momentum
M = sum_k f_k (u_drive - <u>_k) dz_c[k] [m^2 s^-2], in a steady state the total stress at every
height below the layer. The controller relaxes u_drive over ``forcing.controller_timescale`` T_c
to the value giving M = u*s^2, from the log law's (u*s/kappa) ln(z_top/z0) + u*s^2/F:

    u_ff = (u*s^2 + sum_k f_k <u>_k dz_c[k]) / F,     F = sum_k f_k dz_c[k].

The stress at z_ref_eff = min(z_ref, (Lz - D)/2), the air's, is measured every step and filtered
over T_c for the record.
"""
from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..._jit import jit_with, pjit

#: height [m] where the pressure-gradient drive holds the stress at u*s^2 (0: the bed)
PG_HOLD_HEIGHT = 0.0


def z_ref_effective(z_ref: float, Lz: float, damping_depth: float) -> float:
    """min(z_ref, (Lz - D)/2) [m]: where u* is read (and, top drive, held)."""
    return min(z_ref, 0.5 * (Lz - damping_depth))


def pressure_gradient_force(u_star: float, Lz: float, z_hold: float = PG_HOLD_HEIGHT) -> float:
    """G = u*^2 / (Lz - z_hold) [m s^-2]: the stress G (Lz - z) is u*^2 at z_hold."""
    if not 0.0 <= z_hold < Lz:
        raise ValueError(f"pressure_gradient_force: hold height {z_hold:g} m must lie in [0, Lz={Lz:g} m)")
    return u_star ** 2 / (Lz - z_hold)


@pjit
def total_stress_at_face(u, w, e, k, cml, nu_mol, dzf, rdx, taux):
    """(resolved, SGS) horizontal means of the u-w stress on face k [m^2 s^-2], the resolved with
    the advection's face means (the mean budget closes); at k = 0 the bed stress."""
    nx, ny, nz = u.shape
    res = np.zeros(nx)
    sgs = np.zeros(nx)
    wm = np.zeros(nx)
    um = np.zeros(nx)
    for i in prange(nx):
        im = (i - 1) % nx
        for j in range(ny):
            if k == 0:
                sgs[i] += taux[i, j]
            elif k < nz:
                wx = 0.5 * (w[im, j, k] + w[i, j, k])
                uz = 0.5 * (u[i, j, k - 1] + u[i, j, k])
                res[i] += wx * uz
                wm[i] += wx
                um[i] += uz
                nu = 0.25 * (cml[k - 1] * (math.sqrt(max(e[im, j, k - 1], 0.0))
                                           + math.sqrt(max(e[i, j, k - 1], 0.0)))
                             + cml[k] * (math.sqrt(max(e[im, j, k], 0.0))
                                         + math.sqrt(max(e[i, j, k], 0.0)))) + nu_mol
                sgs[i] -= nu * ((u[i, j, k] - u[i, j, k - 1]) / dzf[k] + (w[i, j, k] - w[im, j, k]) * rdx)
    n = nx * ny
    r = 0.0
    s = 0.0
    a = 0.0
    b = 0.0
    for i in range(nx):  # fixed-order sums: bit-for-bit reproducible
        r += res[i]
        s += sgs[i]
        a += wm[i]
        b += um[i]
    return r / n - (a / n) * (b / n), s / n


@jit_with(parallel=True, fastmath=False)
def level_means(a, k0, out):
    """out[k] = the float64 horizontal mean of a[:, :, k], k0 <= k < nz, bit for bit numpy's
    ``a.mean(axis=(0, 1))`` (summed in array order, no fastmath)."""
    nx, ny, nz = a.shape
    n = nz - k0
    groups = min(n, 8)
    for q in prange(groups):
        ka = k0 + (q * n) // groups
        kb = k0 + ((q + 1) * n) // groups
        acc = np.zeros(kb - ka)
        for i in range(nx):
            for j in range(ny):
                for k in range(ka, kb):
                    acc[k - ka] += a[i, j, k]
        for k in range(ka, kb):
            out[k] = acc[k - ka] / (nx * ny)


class DriveController:
    """Feed-forward momentum-flux controller of ``state.u_drive`` (module doc)."""

    def __init__(self, grid, u_star: float, z_ref: float, timescale: float, f_c: np.ndarray,
                 kappa: float, z0: float):
        self.grid = grid
        self.u_star = float(u_star)
        self.z_ref = float(z_ref)
        self.timescale = float(timescale)
        self.f_dz = np.ascontiguousarray(f_c * grid.dz_c)
        self.F = float(self.f_dz.sum())
        self.kappa, self.z0 = float(kappa), float(z0)
        # faces bracketing z_ref and the linear weight between them
        zf = grid.z_f
        kb = int(np.clip(np.searchsorted(zf, self.z_ref) - 1, 0, grid.nz - 1))
        self.k_lo, self.k_hi = kb, kb + 1
        self.w_hi = float((self.z_ref - zf[kb]) / (zf[kb + 1] - zf[kb]))
        self.tau_ref_filtered = math.nan   # running mean of the total stress at z_ref [m^2 s^-2]
        self.tau_ref_last = math.nan

    def initial_u_drive(self) -> float:
        """Log-law feed-forward: (u*/kappa) ln(z_top/z0) + u*^2/F [m s^-1]."""
        damped = np.nonzero(self.f_dz > 0)[0]
        depth = 0.0 if damped.size == 0 else float(self.grid.Lz - self.grid.z_f[damped[0]])
        ztop = float(self.grid.Lz - depth)
        u_top = self.u_star / self.kappa * math.log(max(ztop, 2 * self.z0) / self.z0)
        return u_top + (self.u_star ** 2 / self.F if self.F > 0 else 0.0)

    def feed_forward(self, u_mean: np.ndarray) -> float:
        """u_ff for the horizontal-mean profile <u>(z) (nz,) [m s^-1]."""
        if self.F <= 0:
            return float(u_mean[-1])
        return (self.u_star ** 2 + float(np.dot(self.f_dz, u_mean))) / self.F

    def measure(self, state, cml: np.ndarray, nu_mol: float, taux: np.ndarray) -> float:
        """Total kinematic stress -<u'w'> magnitude at z_ref [m^2 s^-2] (positive for a drag)."""
        g = self.grid
        vals = []
        for k in (self.k_lo, self.k_hi):
            r, s = total_stress_at_face(state.u, state.w, state.e, k, cml, nu_mol, g.dz_f,
                                        1.0 / g.dx, taux)
            vals.append(r + s)
        tau = (1.0 - self.w_hi) * vals[0] + self.w_hi * vals[1]
        return -tau

    def update(self, state, dt: float, u_mean: np.ndarray, tau_ref: float) -> None:
        """Advance the stress filter and u_drive over dt (u_drive lags by T_c)."""
        self.tau_ref_last = tau_ref
        a = min(1.0, dt / self.timescale)
        f = self.tau_ref_filtered  # an exponential running mean, started by the first sample
        self.tau_ref_filtered = tau_ref if math.isnan(f) else f + a * (tau_ref - f)
        state.u_drive += a * (self.feed_forward(u_mean) - state.u_drive)

    def checkpoint(self) -> dict:
        return {"tau_ref_filtered": float(self.tau_ref_filtered), "tau_ref_last": float(self.tau_ref_last)}

    def restore(self, data: dict) -> None:
        self.tau_ref_filtered = float(data["tau_ref_filtered"])
        self.tau_ref_last = float(data["tau_ref_last"])
