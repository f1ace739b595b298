"""Drive of the flow: ``forcing.drive = "pressure_gradient"`` (a uniform mean body force) or ``"top"``
(the base-state wind u_drive in the top Rayleigh layer and its controller).

Pressure-gradient drive
-----------------------
A uniform streamwise body force G = -(1/rho) dP/dx [m s^-2] acts on u everywhere; the lid is free
slip and nothing relaxes u. The horizontally averaged x-momentum balance in a steady state is
d tau/dz = -G with tau(H) = 0, so the total (resolved + SGS + grain) kinematic stress is exactly

    tau(z) = G (H - z),        u*(z) = u*_0 sqrt(1 - z/H),   u*_0^2 = G H,

whatever the turbulence or the grains do (no controller, no drift). G is set so that the stress at
the hold height z_hold equals u*s^2: G = u*s^2 / (H - z_hold). We hold it at the bed (z_hold = 0,
``PG_HOLD_HEIGHT``): the surface stress of the grain-free flow -- and, under saltation, the total
(air + grain) stress at the bed and within a few per cent of it at the top of the saltation layer
(z_m/H ~ 0.05) -- is then rho u*s^2 as in the paper's constant-stress layer, independently of the
domain height (the same grain physics at every fidelity). The stress at z_ref (2 m) is then
u*s^2 (1 - z_ref/H); ``pressure_gradient_force`` takes the hold height as an argument should a
run prefer to hold it there instead. No Rayleigh damping is applied with this drive (the free-slip
lid needs none in a neutral flow; see model.py). The local-equilibrium mean shear is
dU/dz = u*(z)/(kappa z); ``diagnostics_flow.fit_log_law`` fits that profile.

Top drive
---------

The paper drives its surface layer from above (a base-state wind with a Rayleigh layer), which gives
a constant-stress layer below the damping layer (its Fig. 2b). Here the Rayleigh layer pulls u towards
``state.u_drive``; the x-momentum it feeds into the domain per unit area is

    M = sum_k f_k (u_drive - <u>_k) dz_c[k]   [m^2 s^-2]   (f_k the damping rate, damping.py).

In a statistically steady state the horizontally averaged momentum balance makes the total stress
(resolved + SGS + grain) equal to M at every height below the damping layer. The controller therefore
sets u_drive so that M = u*s^2 (feed-forward on the measured layer-mean <u>), i.e.

    u_ff = (u*s^2 + sum_k f_k <u>_k dz_c[k]) / F,     F = sum_k f_k dz_c[k]   [m s^-1],

and lets u_drive relax to u_ff with the time scale ``forcing.controller_timescale`` T_c (so the drive
changes slowly and the noisy layer mean is filtered). The total stress at z_ref_eff = min(z_ref,
(Lz - D)/2) is measured every step and filtered with an exponential running mean of time scale T_c
(``tau_ref_filtered``) for the record; the drive itself needs no integral term: the steady balance
already pins the stress to what it feeds. The grains' stress is zero at z_ref (above the saltation
layer), so the measured stress is the air's, resolved plus SGS.

Initial u_drive (feed-forward from the log law): U_top + u*s^2/F with U_top = (u*s/kappa)
ln(z_top/z0), z_top the top of the free (undamped) region.
"""
from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..._jit import pjit

__all__ = ["DriveController", "z_ref_effective", "total_stress_at_face", "pressure_gradient_force",
           "PG_HOLD_HEIGHT", "stress_profile_pg"]

#: height [m] where the pressure-gradient drive holds the stress at u*s^2 (0: the bed; see above)
PG_HOLD_HEIGHT = 0.0


def z_ref_effective(z_ref: float, Lz: float, damping_depth: float) -> float:
    """min(z_ref, (Lz - D)/2) [m]: the height where u* is read (and, top drive, held).

    For the pressure-gradient drive pass damping_depth = 0 (no damping layer): min(z_ref, Lz/2)."""
    return min(z_ref, 0.5 * (Lz - damping_depth))


def pressure_gradient_force(u_star: float, Lz: float, z_hold: float = PG_HOLD_HEIGHT) -> float:
    """G = u*^2 / (Lz - z_hold) [m s^-2]: the body force whose steady stress G (Lz - z) is u*^2 at
    z_hold [m] (0 <= z_hold < Lz)."""
    if not 0.0 <= z_hold < Lz:
        raise ValueError(f"pressure_gradient_force: hold height {z_hold:g} m must lie in [0, Lz={Lz:g} m)")
    return u_star ** 2 / (Lz - z_hold)


def stress_profile_pg(z, G: float, Lz: float):
    """Steady total kinematic stress magnitude G (Lz - z) [m^2 s^-2] of the pressure-gradient drive."""
    return G * (Lz - np.asarray(z, dtype=np.float64))


@pjit
def total_stress_at_face(u, w, e, k, cml, nu_mol, dzf, rdx, taux):
    """(resolved, SGS) horizontal means of the u-w stress on face k [m^2 s^-2].

    Resolved: <w_x u_z> - <w><u> with the same face means as the advection scheme uses (so the
    horizontal-mean momentum budget closes). SGS: -<nu (du/dz + dw/dx)>; at k = 0 the bed stress.
    """
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


def _running_mean(mean: float, x: float, a: float) -> float:
    """Exponential running mean updated with weight a; the first sample (mean NaN) starts it."""
    return x if math.isnan(mean) else mean + a * (x - mean)


class DriveController:
    """Feed-forward momentum-flux controller of ``state.u_drive`` (see module docstring)."""

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

    @property
    def target_stress(self) -> float:
        return self.u_star ** 2

    def z_free_top(self) -> float:
        return float(self.grid.Lz - self._damping_depth_estimate())

    def _damping_depth_estimate(self) -> float:
        nz_damped = np.nonzero(self.f_dz > 0)[0]
        return 0.0 if nz_damped.size == 0 else float(self.grid.Lz - self.grid.z_f[nz_damped[0]])

    def initial_u_drive(self) -> float:
        """Log-law feed-forward: (u*/kappa) ln(z_top/z0) + u*^2/F [m s^-1]."""
        ztop = self.z_free_top()
        u_top = self.u_star / self.kappa * math.log(max(ztop, 2 * self.z0) / self.z0)
        return u_top + (self.target_stress / self.F if self.F > 0 else 0.0)

    def momentum_target(self) -> float:
        """M the drive feeds [m^2 s^-2]: u*s^2."""
        return self.target_stress

    def feed_forward(self, u_mean: np.ndarray) -> float:
        """u_ff for the horizontal-mean profile <u>(z) (nz,) [m s^-1]."""
        if self.F <= 0:
            return float(u_mean[-1])
        return (self.momentum_target() + float(np.dot(self.f_dz, u_mean))) / self.F

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
        self.tau_ref_filtered = _running_mean(self.tau_ref_filtered, tau_ref, a)
        state.u_drive += a * (self.feed_forward(u_mean) - state.u_drive)

    # ---- checkpoint ------------------------------------------------------------------------
    def checkpoint(self) -> dict:
        return {"tau_ref_filtered": float(self.tau_ref_filtered), "tau_ref_last": float(self.tau_ref_last)}

    def restore(self, data: dict) -> None:
        self.tau_ref_filtered = float(data["tau_ref_filtered"])
        self.tau_ref_last = float(data["tau_ref_last"])
