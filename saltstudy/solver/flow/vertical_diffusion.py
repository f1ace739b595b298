"""Vertically implicit SGS diffusion: the RK3 stage with the vertical diffusion of u, v, w and e
(and the SGS dissipation) solved per column, everything else explicit.

Why: with 1 cm first levels against dx = 0.1-0.16 m the explicit diffusion limit sets 88-100 % of
the steps of every scene (reports/stability) at a third of the Courant step; implicit (as in ARPS
for thin vertical spacings, Xue et al. 2000, Meteorol. Atmos. Phys. 75, 161) it sets none.

Each Wicker-Skamarock stage restarts from phi(n):

    phi(k) = phi(n) + c_k dt [ E(phi(k-1)) + (1 - theta) D phi(n) + theta D phi(k) ],

E the explicit tendencies of the stage input, D the vertical diffusion with its eddy viscosity.
theta = 1/2 (the default) keeps second order, but a stiff mode's amplification tends to -1 (-0.6
at c_k dt |lambda| = 8: it rings); theta = 1 damps it at once, at first order. The stage carries
the last step's pressure gradient and the projection finds its increment: otherwise the vertical
diffusion (not divergence-free: T_33 carries 2 nu, and nu varies) acts on a part the projection
removes afterwards, and the step is first order (tests/test_solver_vertical_diffusion.py).

The dissipation, linearised about the stage input, is fully implicit, eps(k) = (c_eps e_in^{1/2}
/ l) e(k): e >= 0 for any rate (~10^2 s^-1 near the bed), P = eps exact. The bed stress stays
explicit (a few s^-1); the lid is free slip; w is solved on the interior faces. A column's rows
are built in scratch and written after its solve: in the last stage the output is the base
state, whose neighbours Crank-Nicolson reads.
"""
from __future__ import annotations

import numpy as np
from numba import prange

from ..._jit import device, like, pjit
from .advection import (C1, C3, adv_scalar4_at, adv_scalar_at, adv_u4_at, adv_u_at, adv_v4_at,
                        adv_v_at, adv_w4_at, adv_w_at, wrap_down)
from ..closures.sgs import diff_u_split_at, diff_v_split_at, diff_w_split_at, tke_split_at, vertical_coupling

#: the vertical diffusion schemes a fidelity can name (config.TimeStepping.vertical_diffusion)
VERTICAL_DIFFUSION = ("explicit", "implicit")


@device
def solve_tridiagonal(lo, di, up, r, cp, k0, k1):
    """lo x[k-1] + di x[k] + up x[k+1] = r[k], k0 <= k < k1, solved in place of r (Thomas)."""
    b = di[k0]
    cp[k0] = up[k0] / b
    r[k0] = r[k0] / b
    for k in range(k0 + 1, k1):
        m = di[k] - lo[k] * cp[k - 1]
        cp[k] = up[k] / m
        r[k] = (r[k] - lo[k] * r[k - 1]) / m
    for k in range(k1 - 2, k0 - 1, -1):
        r[k] -= cp[k] * r[k + 1]


@device
def _uv_rows(u, v, w, nu, rv, taux, tauy, ub, vb, p, i, j, k, im, ip, jm, jp, top, bot, cdt, theta,
             rdx, rdy, dzc, dzf, fck, fcuk, srck, horder, S):
    """Row k of the u (S[0:4]) and v (S[4:8]) systems of column (i, j); horder: the advection's and
    the carried gradient's order (the projection's), negative without advection."""
    one = like(u, 1.0)
    c1_ = like(u, C1)
    c3_ = like(u, C3)
    r = one / dzc[k]
    pc = p[i, j, k]
    if horder == 4 or horder == -4:
        # G4 of the projection: the carried gradient is then one the projection can remove
        im2 = wrap_down(im, p.shape[0])
        jm2 = wrap_down(jm, p.shape[1])
        gpx = c1_ * (pc - p[im, j, k]) - c3_ * (p[ip, j, k] - p[im2, j, k])
        gpy = c1_ * (pc - p[i, jm, k]) - c3_ * (p[i, jp, k] - p[i, jm2, k])
        tu = srck - fcuk * u[i, j, k] - gpx * rdx
        tv = -fck * v[i, j, k] - gpy * rdy
    else:
        tu = srck - fcuk * u[i, j, k] - (pc - p[im, j, k]) * rdx
        tv = -fck * v[i, j, k] - (pc - p[i, jm, k]) * rdy
    if horder == 4:
        tu += adv_u4_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, r)
        tv += adv_v4_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, r)
    elif horder == 2:
        tu += adv_u_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, r)
        tv += adv_v_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, r)
    xu, au, cu = diff_u_split_at(u, v, w, nu, rv, taux, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy,
                                 dzc, dzf)
    xv, av, cv = diff_v_split_at(u, v, w, nu, rv, tauy, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy,
                                 dzc, dzf)
    ex = one - theta
    S[0, k] = ub[i, j, k] + cdt * (tu + xu + ex * vertical_coupling(ub, i, j, k, au, cu, top, bot))
    S[4, k] = vb[i, j, k] + cdt * (tv + xv + ex * vertical_coupling(vb, i, j, k, av, cv, top, bot))
    ct = cdt * theta
    S[1, k] = -ct * au
    S[2, k] = one + ct * (au + cu)
    S[3, k] = -ct * cu
    S[5, k] = -ct * av
    S[6, k] = one + ct * (av + cv)
    S[7, k] = -ct * cv


@device
def _uvw_column_rows(u, v, w, nu, rv, taux, tauy, ub, vb, wb, p, i, j, im, ip, cdt, theta, rdx, rdy,
                     dzc, dzf, fc, fcu, ff, u_drive, gx, horder, S):
    # the rows of the u, v and w systems of column (i, j); called with a literal horder = 4 (as
    # stepper._uvw_column, where the measurement is)
    half = like(w, 0.5)
    one = like(w, 1.0)
    ny, nz = u.shape[1], u.shape[2]
    jm = j - 1 if j > 0 else ny - 1
    jp = j + 1 if j + 1 < ny else 0
    _uv_rows(u, v, w, nu, rv, taux, tauy, ub, vb, p, i, j, 0, im, ip, jm, jp, True, False, cdt,
             theta, rdx, rdy, dzc, dzf, fc[0], fcu[0], gx + fcu[0] * u_drive, horder, S)
    for k in range(1, nz - 1):
        _uv_rows(u, v, w, nu, rv, taux, tauy, ub, vb, p, i, j, k, im, ip, jm, jp, True, True,
                 cdt, theta, rdx, rdy, dzc, dzf, fc[k], fcu[k], gx + fcu[k] * u_drive,
                 horder, S)
    _uv_rows(u, v, w, nu, rv, taux, tauy, ub, vb, p, i, j, nz - 1, im, ip, jm, jp, False, True,
             cdt, theta, rdx, rdy, dzc, dzf, fc[nz - 1], fcu[nz - 1],
             gx + fcu[nz - 1] * u_drive, horder, S)
    # interior w faces 1..nz-1 (w = 0 on faces 0 and nz: their couplings drop out)
    ct = cdt * theta
    ex = one - theta
    for k in range(1, nz):
        tw = -ff[k] * w[i, j, k] - (p[i, j, k] - p[i, j, k - 1]) / dzf[k]
        hzm = half * dzc[k - 1] / dzf[k]
        hzp = half * dzc[k] / dzf[k]
        if horder == 4:
            tw += adv_w4_at(u, v, w, i, j, k, im, ip, jm, jp, rdx, rdy, hzm, hzp, one / dzf[k])
        elif horder == 2:
            tw += adv_w_at(u, v, w, i, j, k, im, ip, jm, jp, rdx, rdy, hzm, hzp, one / dzf[k])
        xw, aw, cw = diff_w_split_at(u, v, w, nu, rv, i, j, k, im, ip, jm, jp, rdx, rdy, dzc,
                                     dzf)
        S[8, k] = wb[i, j, k] + cdt * (tw + xw + ex * vertical_coupling(wb, i, j, k, aw, cw,
                                                                        True, True))
        S[9, k] = -ct * aw
        S[10, k] = one + ct * (aw + cw)
        S[11, k] = -ct * cw


@pjit
def momentum_stage_implicit(u, v, w, nu, rv, taux, tauy, ub, vb, wb, uo, vo, wo, p, cdt, theta, rdx,
                            rdy, dzc, dzf, fc, fcu, ff, u_drive, gx, with_adv, order):
    """uo = ub + cdt (E(u) - G p + (1 - theta) D ub + theta D uo) for u, v and interior w, per
    column (module doc); p [m^2 s^-2]; other arguments as stepper._momentum_stage."""
    nx, ny, nz = u.shape
    horder = order if with_adv else -order
    for i in prange(nx):
        im = (i - 1) % nx
        ip = (i + 1) % nx
        S = np.empty((12, nz + 1), u.dtype)
        cp = np.empty(nz + 1, u.dtype)
        for j in range(ny):
            if horder == 4:
                _uvw_column_rows(u, v, w, nu, rv, taux, tauy, ub, vb, wb, p, i, j, im, ip, cdt,
                                 theta, rdx, rdy, dzc, dzf, fc, fcu, ff, u_drive, gx, 4, S)
            else:
                _uvw_column_rows(u, v, w, nu, rv, taux, tauy, ub, vb, wb, p, i, j, im, ip, cdt,
                                 theta, rdx, rdy, dzc, dzf, fc, fcu, ff, u_drive, gx, horder, S)
            solve_tridiagonal(S[1], S[2], S[3], S[0], cp, 0, nz)
            solve_tridiagonal(S[5], S[6], S[7], S[4], cp, 0, nz)
            for k in range(nz):
                uo[i, j, k] = S[0, k]
                vo[i, j, k] = S[4, k]
            wo[i, j, 0] = 0.0
            wo[i, j, nz] = 0.0
            if nz > 1:
                solve_tridiagonal(S[9], S[10], S[11], S[8], cp, 1, nz)
                for k in range(1, nz):
                    wo[i, j, k] = S[8, k]


@device
def _e_rows(e, u, v, w, nu, rv, eb, i, j, k, im, ip, jm, jp, top, bot, cdt, theta, rdx, rdy, rdzc,
            rdzf, rlog, ceps_lk, order, S):
    """Row k of the e system of column (i, j) into S[0:4] (module doc)."""
    one = like(e, 1.0)
    if order == 4:
        te = adv_scalar4_at(e, u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc[k])
    else:
        te = adv_scalar_at(e, u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc[k])
    x, a, c, rd = tke_split_at(e, u, v, w, nu, rv, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc,
                               rdzf, rlog, ceps_lk)
    S[0, k] = eb[i, j, k] + cdt * (te + x + (one - theta) * vertical_coupling(eb, i, j, k, a, c, top,
                                                                                bot))
    ct = cdt * theta
    S[1, k] = -ct * a
    S[2, k] = one + ct * (a + c) + cdt * rd
    S[3, k] = -ct * c


@device
def _e_column_rows(e, u, v, w, nu, rv, eb, i, j, im, ip, cdt, theta, rdx, rdy, rdzc, rdzf, rlog,
                   ceps_l, order, S):
    # the rows of the e system of column (i, j); called with a literal order = 4
    ny, nz = e.shape[1], e.shape[2]
    jm = j - 1 if j > 0 else ny - 1
    jp = j + 1 if j + 1 < ny else 0
    _e_rows(e, u, v, w, nu, rv, eb, i, j, 0, im, ip, jm, jp, True, False, cdt, theta, rdx,
            rdy, rdzc, rdzf, rlog, ceps_l[0], order, S)
    for k in range(1, nz - 1):
        _e_rows(e, u, v, w, nu, rv, eb, i, j, k, im, ip, jm, jp, True, True, cdt, theta, rdx,
                rdy, rdzc, rdzf, rlog, ceps_l[k], order, S)
    _e_rows(e, u, v, w, nu, rv, eb, i, j, nz - 1, im, ip, jm, jp, False, True, cdt, theta,
            rdx, rdy, rdzc, rdzf, rlog, ceps_l[nz - 1], order, S)


@pjit
def tke_stage_implicit(e, u, v, w, nu, rv, eb, eo, cdt, theta, rdx, rdy, rdzc, rdzf, rlog, ceps_l,
                       e_min, order):
    """eo = max(eb + cdt (the e equation, vertical part theta-weighted), e_min) (module doc)."""
    nx, ny, nz = e.shape
    for ii in prange(nx):
        i = np.int64(ii)  # signed: strain_sq_at indexes with i directly
        im = (i - 1) % nx
        ip = (i + 1) % nx
        S = np.empty((4, nz), e.dtype)
        cp = np.empty(nz, e.dtype)
        for j in range(ny):
            if order == 4:
                _e_column_rows(e, u, v, w, nu, rv, eb, i, j, im, ip, cdt, theta, rdx, rdy, rdzc,
                               rdzf, rlog, ceps_l, 4, S)
            else:
                _e_column_rows(e, u, v, w, nu, rv, eb, i, j, im, ip, cdt, theta, rdx, rdy, rdzc,
                               rdzf, rlog, ceps_l, order, S)
            solve_tridiagonal(S[1], S[2], S[3], S[0], cp, 0, nz)
            for k in range(nz):
                val = S[0, k]
                eo[i, j, k] = val if val > e_min else e_min
