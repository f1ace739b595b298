"""Two-part SGS model of Sullivan, McWilliams & Moeng (1994, Boundary-Layer Meteorol. 71, 247): an
isotropy factor on the fluctuating eddy viscosity and a mean-field eddy viscosity that holds the
log law at the first level. A departure from the paper's closure (``closure.two_part``), kept as a
measured option: see reports/loglaw/.

Why. Near the bed the resolved strain is dominated by the mean shear, and an eddy viscosity built
for isotropic fluctuations, acting on the whole strain, damps the resolved eddies there and carries
too little of the mean stress at the same time. Sullivan et al. split the SGS stress in two:

    tau_ij = -2 gamma nu_t S_ij - 2 nu_T <S_ij>

- ``gamma(z) = S' / (S' + <S>)``, with <S> = sqrt(2 <S_ij><S_ij>) the plane-mean strain (here
  exactly the mean shear, sqrt(dU/dz^2 + dV/dz^2): the plane means of the horizontal derivatives
  vanish in a periodic box and <w> = 0 on every face) and S' = sqrt(2 <s'_ij s'_ij>) the r.m.s.
  of the fluctuating strain. gamma -> 1 where the fluctuations dominate (aloft) and falls near the
  bed; it scales the fluctuating viscosity nu_t of either closure (Deardorff's c_m l sqrt(e), or
  the dynamic model's (C_s Delta)^2 |S|);
- ``nu_T(z)`` acts on the horizontal-mean shear only: at the first interior face z_1 it supplies
  the stress that the resolved and the gamma-scaled SGS stresses lack against the log law,

      nu_T* = u* kappa z_1 - <gamma nu_t>(z_1) - kappa z_1 / u* |<u'w'>_res(z_1)|     (>= 0),

  u* from the plane-mean wall stress, and decays above as the mean shear does:
  nu_T(z) = nu_T* kappa z_1 <S>(z) / u*.

In the Deardorff model the SGS TKE e is then the energy of the fluctuations: its shear production
is gamma nu_t |s'|^2, with the plane-mean shear taken out of the strain (sgs.strain_sq_fluct_at).

Time stepping. gamma, the mean shear and nu_T are computed once per step from the state at its
start and held over the RK3 stages (slow mean-field quantities, as nearwall.py does); the mean
tendency d<U>/dt = d/dz (nu_T d<U>/dz) is linearly implicit (backward Euler on the mean profile,
nearwall._backward_euler_diffusion), so it sets no time-step limit and conserves the column's
momentum exactly (zero end fluxes).
"""
from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..._jit import pjit
from .nearwall import _backward_euler_diffusion
from .sgs import strain_sq_at

__all__ = ["TwoPartModel", "plane_strain_statistics", "GAMMA_MIN"]

#: floor of the isotropy factor (keeps some fluctuating viscosity where the mean shear dominates)
GAMMA_MIN = 0.01


@pjit
def plane_strain_statistics(u, v, w, rdx, rdy, rdzc, rdzf, rlog, out):
    """Plane means per level, in place into ``out`` (4, nz+1):

    out[0, k] = <u>, out[1, k] = <v> on level k; out[2, k] = <2 S_ij S_ij> on level k [s^-2] (the
    strain of sgs.strain_sq_at); out[3, k] = the resolved <u'w'> on face k (1 <= k < nz, the
    advection scheme's face means) [m^2 s^-2]: the mean product <u w> is the covariance, since
    <w> = 0 on every face of a divergence-free field with w = 0 at the bed.
    """
    nx, ny, nz = u.shape
    part = np.zeros((nx, 4, nz + 1))
    for ii in prange(nx):
        i = np.int64(ii)
        im = (i - 1) % nx
        ip = (i + 1) % nx
        for j in range(ny):
            jm = (j - 1) % ny
            jp = (j + 1) % ny
            for k in range(nz):
                part[i, 0, k] += u[i, j, k]
                part[i, 1, k] += v[i, j, k]
                sh, sv = strain_sq_at(u, v, w, i, j, k, im, ip, jm, jp, k < nz - 1, k > 0, rdx, rdy,
                                      rdzc, rdzf, rlog)
                part[i, 2, k] += sh + sv
            for k in range(1, nz):
                part[i, 3, k] += 0.5 * (w[i, j, k] + w[im, j, k]) * 0.5 * (u[i, j, k] + u[i, j, k - 1])
    out[...] = 0.0
    for i in range(nx):
        for q in range(4):
            for k in range(nz + 1):
                out[q, k] += part[i, q, k]
    out /= nx * ny


class TwoPartModel:
    """gamma(z), the plane-mean shear on the faces and nu_T(z) of one step (module doc).

    ``gamma`` (nz,) is read by the stepper to scale the fluctuating viscosity; ``mdu``, ``mdv``
    (nz+1,) are the plane-mean shears dU/dz, dV/dz on the faces [s^-1] (face 0: the log-law shear
    of the first level, as the strain kernels use) that the Deardorff TKE production takes out."""

    def __init__(self, grid, kappa: float, rlog: float):
        self.grid = grid
        self.kappa = float(kappa)
        self.rlog = float(rlog)
        nz = grid.nz
        self.gamma = np.ones(nz)
        self.mdu = np.zeros(nz + 1)
        self.mdv = np.zeros(nz + 1)
        self.nu_T = np.zeros(nz + 1)
        self.nu_T_star = 0.0
        self._stats = np.zeros((4, nz + 1))
        self.tend_u = np.zeros(nz)
        self.tend_v = np.zeros(nz)
        self.flux_u = np.zeros(nz + 1)
        self.flux_v = np.zeros(nz + 1)

    def update_gamma(self, state) -> None:
        """gamma, the mean shear and the plane statistics from the state (module doc)."""
        g = self.grid
        st = self._stats
        plane_strain_statistics(state.u, state.v, state.w, 1.0 / g.dx, 1.0 / g.dy, g.rdz_c, g.rdz_f,
                                self.rlog, st)
        nz = g.nz
        U, V = st[0, :nz], st[1, :nz]
        self.mdu[:] = 0.0
        self.mdv[:] = 0.0
        self.mdu[0] = U[0] * self.rlog
        self.mdv[0] = V[0] * self.rlog
        self.mdu[1:nz] = np.diff(U) / g.dz_f[1:nz]
        self.mdv[1:nz] = np.diff(V) / g.dz_f[1:nz]
        # the mean strain on level k the way the kernels form it: the faces' shears averaged in square
        s_mean_sq = 0.5 * (self.mdu[:nz] ** 2 + self.mdu[1:] ** 2 + self.mdv[:nz] ** 2 + self.mdv[1:] ** 2)
        s_fluct = np.sqrt(np.maximum(st[2, :nz] - s_mean_sq, 0.0))
        s_mean = np.sqrt(s_mean_sq)
        tot = s_fluct + s_mean
        self.gamma[:] = np.where(tot > 0, np.maximum(s_fluct / np.where(tot > 0, tot, 1.0), GAMMA_MIN),
                                 1.0)

    def update_mean_viscosity(self, nu_fluct_face1: float, u_star: float, dt: float) -> None:
        """nu_T(z) and the implicit mean tendencies for a step of dt [s]; ``nu_fluct_face1`` the
        plane mean of the gamma-scaled SGS viscosity on the first interior face [m^2 s^-1],
        ``u_star`` the plane-mean wall stress's friction velocity [m s^-1]."""
        g = self.grid
        nz = g.nz
        st = self._stats
        z1 = float(g.z_f[1])
        nu_T = self.nu_T
        nu_T[:] = 0.0
        if u_star > 0.0:
            kz1 = self.kappa * z1
            star = u_star * kz1 - nu_fluct_face1 - kz1 / u_star * abs(st[3, 1])
            self.nu_T_star = max(star, 0.0)
            s_face = np.hypot(self.mdu, self.mdv)
            nu_T[1:nz] = self.nu_T_star * kz1 * s_face[1:nz] / u_star
        else:
            self.nu_T_star = 0.0
        U, V = st[0, :nz], st[1, :nz]
        Us, Vs = _backward_euler_diffusion(U.copy(), V.copy(), nu_T, g.dz_c, g.dz_f, dt)
        for prof, flux, tend in ((Us, self.flux_u, self.tend_u), (Vs, self.flux_v, self.tend_v)):
            flux[0] = flux[nz] = 0.0
            flux[1:nz] = nu_T[1:nz] * np.diff(prof) / g.dz_f[1:nz]
            tend[:] = (flux[1:] - flux[:-1]) / g.dz_c

    def apply(self, u, v, cdt: float) -> None:
        """u += cdt d/dz(nu_T dU/dz), v likewise (horizontally uniform)."""
        u += (cdt * self.tend_u)[None, None, :]
        v += (cdt * self.tend_v)[None, None, :]

    def stress_profile(self) -> np.ndarray:
        """The mean stress nu_T carried in the last step, on the w faces (nz+1,) [m^2 s^-2]."""
        return self.flux_u.copy()


def face_mean_viscosity(nu: np.ndarray, k: int) -> float:
    """Plane mean of a centred viscosity field interpolated to face k (two-level mean) [m^2 s^-1]."""
    return 0.5 * float(nu[:, :, k - 1].mean() + nu[:, :, k].mean())


def wall_friction_velocity(taux: np.ndarray, tauy: np.ndarray) -> float:
    """sqrt|<tau_s>| from the wall stress fields [m s^-1]."""
    return math.sqrt(math.hypot(float(taux.mean()), float(tauy.mean())))
