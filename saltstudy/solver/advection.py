"""Second-order, energy-conserving centred advection on the staggered grid stretched in z.

Flux form on each staggered control volume (Harlow & Welch 1965; Morinishi et al. 1998, J. Comput.
Phys. 143, 90, for the energy argument; Verstappen & Veldman 2003 for non-uniform grids): the
advecting *volume flux* through a face of the control volume is the average of the two neighbouring
mass-conserving fluxes, and the advected quantity on that face is the *arithmetic* mean of the two
neighbours (not the distance-weighted one, even on the stretched z grid). Then the discrete operator
is skew-symmetric with respect to the control volumes,

    sum_cv V_cv phi_cv A(phi)_cv = 0   whenever the discrete divergence (pressure.divergence) is 0,

so the discrete kinetic energy sum(V_u u^2 + V_v v^2 + V_w w^2)/2 is conserved by advection exactly
(to round-off), and the scheme adds no numerical dissipation: all dissipation comes from the SGS model.

Control volumes: u at (x_f[i], y_c[j], z_c[k]) has volume dx dy dz_c[k]; v likewise; w at the interior
face k (1..nz-1) has volume dx dy dz_f[k] with dz_f[k] = (dz_c[k-1] + dz_c[k]) / 2. The horizontal
volume flux through the side of a w volume is the thickness-weighted sum of the two u (v) half faces,
which is what makes the w-volume continuity the mean of the two cell divergences.

The ``*_at`` functions are per-point kernels (inlined into the fused stage kernel of stepper.py);
``advection_tendencies`` evaluates them over the whole grid (tests, diagnostics). Units: m s^-2
(momentum), m^2 s^-3 (SGS TKE e).
"""
from __future__ import annotations

import numpy as np
from numba import prange

from .._jit import jit_with, pjit

#: per-point kernels: inlined in numba IR into the fused stage kernels (an out-of-line call with
#: a dozen array arguments per grid point costs more than the stencil itself)
device = jit_with(inline="always")

__all__ = ["adv_u_at", "adv_v_at", "adv_w_at", "adv_scalar_at", "advection_tendencies",
           "scalar_advection"]


@device
def adv_u_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc_k):
    """-div(u u) at the u point (i, j, k) [m s^-2].

    top/bot: whether the cell has an interior face above/below (False at the lid/bed, where w = 0).
    Callers pass literal flags for the peeled first and last levels so that the branches vanish
    from the vectorised interior loop.
    """
    uc = u[i, j, k]
    ue = 0.5 * (uc + u[ip, j, k])
    uw = 0.5 * (u[im, j, k] + uc)
    vn = 0.5 * (v[im, jp, k] + v[i, jp, k])
    vs = 0.5 * (v[im, j, k] + v[i, j, k])
    un = 0.5 * (uc + u[i, jp, k])
    us = 0.5 * (u[i, jm, k] + uc)
    ft = 0.0
    fb = 0.0
    if top:
        ft = 0.5 * (w[im, j, k + 1] + w[i, j, k + 1]) * 0.5 * (uc + u[i, j, k + 1])
    if bot:
        fb = 0.5 * (w[im, j, k] + w[i, j, k]) * 0.5 * (u[i, j, k - 1] + uc)
    return -((ue * ue - uw * uw) * rdx + (vn * un - vs * us) * rdy + (ft - fb) * rdzc_k)


@device
def adv_v_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc_k):
    """-div(u v) at the v point (i, j, k) [m s^-2]."""
    vc = v[i, j, k]
    ue = 0.5 * (u[ip, jm, k] + u[ip, j, k])
    uw = 0.5 * (u[i, jm, k] + u[i, j, k])
    ve = 0.5 * (vc + v[ip, j, k])
    vw = 0.5 * (v[im, j, k] + vc)
    vn = 0.5 * (vc + v[i, jp, k])
    vs = 0.5 * (v[i, jm, k] + vc)
    ft = 0.0
    fb = 0.0
    if top:
        ft = 0.5 * (w[i, jm, k + 1] + w[i, j, k + 1]) * 0.5 * (vc + v[i, j, k + 1])
    if bot:
        fb = 0.5 * (w[i, jm, k] + w[i, j, k]) * 0.5 * (v[i, j, k - 1] + vc)
    return -((ue * ve - uw * vw) * rdx + (vn * vn - vs * vs) * rdy + (ft - fb) * rdzc_k)


@device
def adv_w_at(u, v, w, i, j, k, im, ip, jm, jp, rdx, rdy, hzm, hzp, rdzf_k):
    """-div(u w) at the interior w point (i, j, k), 1 <= k <= nz-1 [m s^-2].

    hzm = dz_c[k-1] / (2 dz_f[k]), hzp = dz_c[k] / (2 dz_f[k]): weights of the two half faces.
    """
    wc = w[i, j, k]
    ue = hzm * u[ip, j, k - 1] + hzp * u[ip, j, k]
    uw = hzm * u[i, j, k - 1] + hzp * u[i, j, k]
    vn = hzm * v[i, jp, k - 1] + hzp * v[i, jp, k]
    vs = hzm * v[i, j, k - 1] + hzp * v[i, j, k]
    we = 0.5 * (wc + w[ip, j, k])
    ww = 0.5 * (w[im, j, k] + wc)
    wn = 0.5 * (wc + w[i, jp, k])
    ws = 0.5 * (w[i, jm, k] + wc)
    wt = 0.5 * (wc + w[i, j, k + 1])
    wb = 0.5 * (w[i, j, k - 1] + wc)
    return -((ue * we - uw * ww) * rdx + (vn * wn - vs * ws) * rdy + (wt * wt - wb * wb) * rdzf_k)


@device
def adv_scalar_at(s, u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc_k):
    """-div(u s) for a cell-centred scalar (the SGS TKE e) [units of s per s].

    Same arithmetic-mean face values: conservative, and the quadratic sum(V s^2) is conserved when
    the flow is divergence-free.
    """
    sc = s[i, j, k]
    fe = u[ip, j, k] * 0.5 * (sc + s[ip, j, k])
    fw = u[i, j, k] * 0.5 * (s[im, j, k] + sc)
    fn = v[i, jp, k] * 0.5 * (sc + s[i, jp, k])
    fs = v[i, j, k] * 0.5 * (s[i, jm, k] + sc)
    ft = 0.0
    fb = 0.0
    if top:
        ft = w[i, j, k + 1] * 0.5 * (sc + s[i, j, k + 1])
    if bot:
        fb = w[i, j, k] * 0.5 * (s[i, j, k - 1] + sc)
    return -((fe - fw) * rdx + (fn - fs) * rdy + (ft - fb) * rdzc_k)


@pjit
def _advection_kernel(u, v, w, dx, dy, dzc, dzf, au, av, aw):
    nx, ny, nz = u.shape
    rdx = 1.0 / dx
    rdy = 1.0 / dy
    for i in prange(nx):
        im = (i - 1) % nx
        ip = (i + 1) % nx
        for j in range(ny):
            jm = (j - 1) % ny
            jp = (j + 1) % ny
            for k in range(nz):
                r = 1.0 / dzc[k]
                au[i, j, k] = adv_u_at(u, v, w, i, j, k, im, ip, jm, jp, k < nz - 1, k > 0, rdx, rdy, r)
                av[i, j, k] = adv_v_at(u, v, w, i, j, k, im, ip, jm, jp, k < nz - 1, k > 0, rdx, rdy, r)
            aw[i, j, 0] = 0.0
            aw[i, j, nz] = 0.0
            for k in range(1, nz):
                hzm = 0.5 * dzc[k - 1] / dzf[k]
                hzp = 0.5 * dzc[k] / dzf[k]
                aw[i, j, k] = adv_w_at(u, v, w, i, j, k, im, ip, jm, jp, rdx, rdy, hzm, hzp,
                                       1.0 / dzf[k])


@pjit
def _scalar_kernel(s, u, v, w, dx, dy, dzc, out):
    nx, ny, nz = s.shape
    for i in prange(nx):
        im = (i - 1) % nx
        ip = (i + 1) % nx
        for j in range(ny):
            jm = (j - 1) % ny
            jp = (j + 1) % ny
            for k in range(nz):
                out[i, j, k] = adv_scalar_at(s, u, v, w, i, j, k, im, ip, jm, jp, k < nz - 1, k > 0, 1.0 / dx,
                                             1.0 / dy, 1.0 / dzc[k])


def advection_tendencies(grid, u, v, w):
    """(A_u, A_v, A_w) = -div(u u_i) on the u, v, w points [m s^-2] (A_w zero at the end faces)."""
    au = np.empty_like(u)
    av = np.empty_like(v)
    aw = np.empty_like(w)
    _advection_kernel(u, v, w, grid.dx, grid.dy, grid.dz_c, grid.dz_f, au, av, aw)
    return au, av, aw


def scalar_advection(grid, s, u, v, w):
    """-div(u s) for a cell-centred scalar."""
    out = np.empty_like(s)
    _scalar_kernel(s, u, v, w, grid.dx, grid.dy, grid.dz_c, out)
    return out
