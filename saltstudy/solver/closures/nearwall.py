"""Near-wall mean-field eddy viscosity: a mixing-length closure for the under-resolved layer.

Why. Within a few horizontal grid spacings of the bed the wall-attached eddies (size ~ z) are
narrower than the horizontal grid can represent, yet the Deardorff SGS model is built to hand the
stress over to resolved eddies there. Neither carries enough of it, so the mean shear overshoots
the log law (phi = kappa z / u* dU/dz ~ 1.3 between 1.5 cm and 0.3 m on the reduced grid, measured
with `tests/test_solver_loglaw.py`): the well-known near-wall overshoot of LES over a rough wall.
In the paper's own LES "this departure starts probably too high" (Dupont et al. 2013, section 3.1).

What. As in the two-part model of Sullivan, McWilliams & Moeng (1994, Boundary-Layer Meteorol. 71,
247) an extra eddy viscosity nu_T(z) acts on the horizontal-mean shear only (so it adds no
dissipation to the resolved fluctuations). Here it is defined as the stress the LES lacks against
a mixing-length closure with length kappa z, the closure of a fully unresolved surface layer (the
hybrid RANS/LES idea: RANS where the grid cannot resolve the eddies, LES above):

    nu_T(z) = W(z) max(0, (kappa z)^2 S - tau_les / S),     S = |d<U_h>/dz|,

with tau_les the resolved + SGS stress along the mean shear (horizontal means on the w faces).
W = 1 for z <= a dx, falling as cos^2 to 0 at z = b dx (``Closure.near_wall_layer`` = (a, b),
in horizontal grid spacings dx = max(dx, dy)): the layer where an eddy of size z spans fewer than
a few grid points. Where the LES already carries the stress (phi <= 1) nu_T is zero. Under
saltation tau_les is the air's stress alone, so the closure is the mixing-length law of the air
in the grain layer (the grains' share of the stress is not the air's).

nu_T is computed once per time step from the state at its start and held over the RK3 stages, as
a tendency of the mean velocity only: d<u>/dt += d/dz (nu_T d<u>/dz) (a horizontally uniform
tendency is divergence-free, so the projection leaves it alone). The bed and lid fluxes of this
term are zero (the bed stress is the wall model's).

The tendency is linearly implicit: the flux is evaluated on the backward-Euler profile U* of the
step, (U* - U) / dt = d/dz (nu_T dU*/dz) (a tridiagonal solve of nz unknowns), and held over the
stages, so the step changes <u> by exactly U* - U. Why: explicitly, 2 nu_T / (dz_c dz_f) limited
the time step, and right after saltation starts (the column still fast, the grains taking its
momentum near the bed) it was the tightest limit of all, 2-3x the SGS one (reduced grid, case 6:
341 against 157 s^-1 in the first second). Backward Euler is unconditionally stable and
conserves the column's momentum exactly (zero end fluxes); for a slow mean-field term its first
order in time is no loss.
"""
from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..._jit import jit, pjit

__all__ = ["NearWallMeanViscosity", "layer_weight", "mean_flux_profiles"]


def layer_weight(z: np.ndarray, dx: float, a: float, b: float) -> np.ndarray:
    """W(z) [-]: 1 below a dx, cos^2 taper to 0 at b dx, 0 above (see module doc)."""
    za, zb = a * dx, b * dx
    s = np.clip((np.asarray(z, dtype=np.float64) - za) / max(zb - za, 1e-300), 0.0, 1.0)
    return np.where(s < 1.0, np.cos(0.5 * math.pi * s) ** 2, 0.0)


@pjit
def mean_flux_profiles(u, v, w, e, cml, nu_mol, rdx, rdy, dzf, out):
    """Horizontal means for the closure, in place into ``out`` (4, nz+1):

    out[0, k] = <u>, out[1, k] = <v> at level k (k < nz);
    out[2, k], out[3, k] = the LES flux of x- and y-momentum down through face k (1 <= k < nz):
    -<u'w'> (resolved, the advection scheme's face means) + <T_13> (SGS, nu at the edge as in
    sgs.diff_u_at; ``cml`` = c_m l_v, the vertical viscosity's), and the same for v. [m s^-1] and [m^2 s^-2].
    """
    nx, ny, nz = u.shape
    part = np.zeros((nx, 4, nz + 1))
    for i in prange(nx):
        im = (i - 1) % nx
        for j in range(ny):
            jm = (j - 1) % ny
            for k in range(nz):
                part[i, 0, k] += u[i, j, k]
                part[i, 1, k] += v[i, j, k]
            for k in range(1, nz):
                rdz = 1.0 / dzf[k]
                nu00 = cml[k - 1] * math.sqrt(max(e[i, j, k - 1], 0.0)) + nu_mol
                nu01 = cml[k] * math.sqrt(max(e[i, j, k], 0.0)) + nu_mol
                num0 = cml[k - 1] * math.sqrt(max(e[im, j, k - 1], 0.0)) + nu_mol
                num1 = cml[k] * math.sqrt(max(e[im, j, k], 0.0)) + nu_mol
                nuy0 = cml[k - 1] * math.sqrt(max(e[i, jm, k - 1], 0.0)) + nu_mol
                nuy1 = cml[k] * math.sqrt(max(e[i, jm, k], 0.0)) + nu_mol
                wx = 0.5 * (w[i, j, k] + w[im, j, k])
                wy = 0.5 * (w[i, j, k] + w[i, jm, k])
                uz = 0.5 * (u[i, j, k] + u[i, j, k - 1])
                vz = 0.5 * (v[i, j, k] + v[i, j, k - 1])
                nux = 0.25 * (nu00 + nu01 + num0 + num1)
                nuy = 0.25 * (nu00 + nu01 + nuy0 + nuy1)
                part[i, 2, k] += -wx * uz + nux * ((u[i, j, k] - u[i, j, k - 1]) * rdz
                                                   + (w[i, j, k] - w[im, j, k]) * rdx)
                part[i, 3, k] += -wy * vz + nuy * ((v[i, j, k] - v[i, j, k - 1]) * rdz
                                                   + (w[i, j, k] - w[i, jm, k]) * rdy)
    out[...] = 0.0
    for i in range(nx):
        for q in range(4):
            for k in range(nz + 1):
                out[q, k] += part[i, q, k]
    out /= nx * ny


class NearWallMeanViscosity:
    """nu_T(z) on the w faces and the mean-velocity tendency it drives (module doc)."""

    def __init__(self, grid, kappa: float, layer: tuple[float, float]):
        self.grid = grid
        self.kappa = float(kappa)
        dxh = max(grid.dx, grid.dy)
        self.weight = layer_weight(grid.z_f, dxh, float(layer[0]), float(layer[1]))
        self.weight[0] = 0.0
        self.weight[-1] = 0.0
        nz = grid.nz
        self._means = np.zeros((4, nz + 1))
        self.nu_T = np.zeros(nz + 1)
        self.tend_u = np.zeros(nz)
        self.tend_v = np.zeros(nz)
        self.flux_u = np.zeros(nz + 1)   # nu_T dU*/dz on the faces, the stress the term carries
        self.flux_v = np.zeros(nz + 1)

    def update(self, state, cml: np.ndarray, nu_mol: float, dt: float) -> None:
        """nu_T and the (linearly implicit, see module doc) tendencies for a step of dt [s] from
        the state at its start."""
        g = self.grid
        m = self._means
        mean_flux_profiles(state.u, state.v, state.w, state.e, cml, nu_mol, 1.0 / g.dx, 1.0 / g.dy,
                           g.dz_f, m)
        nz = g.nz
        U, V = m[0, :nz], m[1, :nz]
        dU = np.zeros(nz + 1)
        dV = np.zeros(nz + 1)
        dU[1:nz] = np.diff(U) / g.dz_f[1:nz]
        dV[1:nz] = np.diff(V) / g.dz_f[1:nz]
        S = np.hypot(dU, dV)
        ok = (S > 0) & (self.weight > 0)
        Sa = np.where(ok, S, 1.0)
        tau_les = (m[2] * dU + m[3] * dV) / Sa
        tau_ml = (self.kappa * g.z_f) ** 2 * S * S
        nu = np.where(ok, self.weight * np.maximum(tau_ml - tau_les, 0.0) / Sa, 0.0)
        self.nu_T[:] = nu
        Us, Vs = _backward_euler_diffusion(U, V, nu, g.dz_c, g.dz_f, dt)
        for prof, flux, tend in ((Us, self.flux_u, self.tend_u), (Vs, self.flux_v, self.tend_v)):
            flux[0] = flux[nz] = 0.0
            flux[1:nz] = nu[1:nz] * np.diff(prof) / g.dz_f[1:nz]
            tend[:] = (flux[1:] - flux[:-1]) / g.dz_c

    def apply(self, u, v, cdt: float) -> None:
        """u += cdt d/dz(nu_T dU/dz), v likewise (horizontally uniform)."""
        u += (cdt * self.tend_u)[None, None, :]
        v += (cdt * self.tend_v)[None, None, :]

    def stress_profile(self) -> np.ndarray:
        """The mean stress this term carried in the last step, on the w faces (nz+1,) [m^2 s^-2]
        (x component)."""
        return self.flux_u.copy()


@jit
def _backward_euler_diffusion(U, V, nu, dzc, dzf, dt):
    """(U*, V*) with (X* - X) / dt = d/dz (nu dX*/dz), zero flux at both ends (Thomas algorithm).

    ``nu`` on the nz+1 faces, the profiles on the nz centres; the matrix is diagonally dominant
    (an M-matrix), so the solve is stable for any dt >= 0.
    """
    nz = U.size
    lo = np.zeros(nz)
    up = np.zeros(nz)
    for k in range(nz):
        if k > 0:
            lo[k] = -dt * nu[k] / (dzf[k] * dzc[k])
        if k < nz - 1:
            up[k] = -dt * nu[k + 1] / (dzf[k + 1] * dzc[k])
    # the factorisation is shared by both profiles
    cp = np.zeros(nz)
    inv = np.zeros(nz)
    for k in range(nz):
        b = 1.0 - lo[k] - up[k]
        if k > 0:
            b -= lo[k] * cp[k - 1]
        inv[k] = 1.0 / b
        cp[k] = up[k] * inv[k]
    out = np.zeros((2, nz))
    for q in range(2):
        d = U if q == 0 else V
        x = out[q]
        x[0] = d[0] * inv[0]
        for k in range(1, nz):
            x[k] = (d[k] - lo[k] * x[k - 1]) * inv[k]
        for k in range(nz - 2, -1, -1):
            x[k] -= cp[k] * x[k + 1]
    return out[0], out[1]
