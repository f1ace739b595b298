"""Two-way momentum exchange between parcels and air (paper eq. 2) and the SGS TKE sink (eq. A1).

Momentum. The air at a velocity face (u at x-faces, v at y-faces, w at z-faces) of mass
``M = rho * dx * dy * dz`` (``dz = grid.dz_c[k]`` for u and v, ``grid.dz_f[k]`` for w) receives minus
the drag impulse of every parcel, ``-Q m_p (Delta u_p - g Delta t)``, spread with the *same*
trilinear weights (summing to one) that interpolated the fluid velocity at the parcel. The sum over
faces of the air's momentum change is therefore exactly minus the sum of the parcels' drag
impulses: the exchange conserves total momentum to round-off. Exceptions, by design: the share of a
vertical impulse that falls on the bed face (w, k = 0) goes into the ground, and parcels below the
first level (log-law region) deposit on the lowest level with the horizontal weights.

Point-implicit exchange (stiff, mass-loaded cells). Over a step ``dt`` a parcel with drag rate
``k_p = f(Re_p)/T_p`` (eqs. 3-4) relaxing exponentially towards the fluid velocity ``u_s`` it sees
changes its momentum by ``c_p (u_s - u~_p)`` with ``c_p = Q m_p (1 - E_p)``, ``E_p = exp(-k_p dt)``
and ``u~_p = u_p - g/k_p + g dt/(1 - E_p)`` (gravity folded in). If every parcel saw the air
velocity of the *start* of the step, a cell whose grain mass exceeds the air mass would overshoot.
Instead the air at each face is advanced backward-Euler in the drag, the parcels frozen::

    U_f' = (M_f U_f + sum_p w_pf c_p u~_p) / (M_f + sum_p w_pf c_p)      (a convex combination)

and every parcel sees the interpolated *new* air velocity ``u_s,p = sum_f w_pf U_f'`` (its own new
velocity is then a convex combination of u_s,p and u_p): no value leaves the range of the old
ones, whatever the mass loading and ``k_p dt`` (tested with grain mass 100x the air mass). The air
is given exactly ``U_f' - U_f``; summed over faces that is exactly minus the sum of the modelled
parcel impulses ``c_p (u_s,p - u~_p)`` (sum_f w_pf = 1). The parcels' *actual* impulses differ
slightly (drag-rate iteration, sub-steps, bed crossings); the difference (actual - modelled) is
deposited with the trilinear weights as well, so total momentum is conserved to round-off. (An
earlier version deposited the actual impulses with the weights and used the implicit estimate
only for the seen velocity: that is *not* stable for modes the interpolation smooths; it blew up
in the loading test.) Below the first level a parcel sees the log law of level 1 but deposits on
level 0; its offset ``o_p = u_raw,p - sum_f w_pf U_f`` (level-0 weights) is subtracted from u~_p so
that ``u_s,p`` is still its raw velocity plus the interpolated ``delta = U' - U``; level-0 modes
are then damped by (1 + a lambda)/(1 + a) <= 1 per step (a = loading, lambda <= 1 the
interpolation's smoothing factor).

TKE sink (eq. A1). Per cell, the rate [s^-1] multiplying e::

    s = (Q / V_cell) sum_p (m_p / rho) 2 f(Re_p) / (T_p + T_L),   T_L = 4 e / (3 C0 eps)

with ``eps = c_eps e^{3/2} / l`` (Deardorff 1980), hence ``T_L = 4 l / (3 C0 c_eps sqrt(e))``,
with the SGS model's own wall-limited length ``l(z)`` and ``c_eps = 0.19 + 0.74 l / Delta``
(:mod:`saltstudy.solver.sgs`), the local e of the cell, and ``C0 = 2.1``, a value
widely used for the Lagrangian structure-function constant in stochastic particle models; the
paper does not state its C0. Where ``e <= 0``, ``T_L`` is infinite and the sink vanishes. Each
parcel contributes to the cell that holds it, weighted by the fraction of the step it spent there.
"""
from __future__ import annotations

import math

import numpy as np
from numba import prange

from .._jit import jit, pjit
from ..physics.drag import drag_correction
from .interp import deposit_faces, interp_faces, interp_fluid, locate

__all__ = ["C0_LAGRANGIAN", "face_inverse_masses", "lagrangian_time_coefficients", "chunk_bounds",
           "implicit_coefficients", "implicit_corrections", "apply_exchange", "tke_rates",
           "N_CHUNKS"]

#: Lagrangian structure-function constant used in T_L (eq. A1); not given in the paper.
C0_LAGRANGIAN = 2.1

#: Fixed number of parcel chunks (each with its own deposit buffers). Fixed, not the thread count,
#: so that every reduction is summed in the same order whatever the number of numba threads: a run
#: is bit-for-bit identical with 1 or 2 threads.
N_CHUNKS = 4


def face_inverse_masses(grid, rho: float) -> tuple[np.ndarray, np.ndarray]:
    """1 / (air mass) of the u/v faces (nz,) and of the w faces (nz + 1,; 0 at the bed and lid)."""
    a = rho * grid.dx * grid.dy
    inv_c = 1.0 / (a * grid.dz_c)
    inv_w = np.zeros(grid.nz + 1)
    inv_w[1:-1] = 1.0 / (a * grid.dz_f[1:-1])
    return np.ascontiguousarray(inv_c), inv_w


def lagrangian_time_coefficients(grid, kappa: float, c0: float = C0_LAGRANGIAN) -> np.ndarray:
    """Per level k: ``4 l / (3 C0 c_eps)`` so that ``T_L = coef[k] / sqrt(e)`` (see module doc).

    l and c_eps are the SGS model's own (``sgs.length_scale``, ``sgs.c_eps_profile``), so the
    epsilon in T_L is the dissipation the TKE equation uses."""
    from .sgs import c_eps_profile, length_scale
    ell = length_scale(grid, kappa)
    c_eps = c_eps_profile(grid, ell)
    return np.ascontiguousarray(4.0 * ell / (3.0 * c0 * c_eps))


@jit
def chunk_bounds(n, c, nc):
    return (c * n) // nc, ((c + 1) * n) // nc


@jit
def drag_rate(rel, d, tp, nu):
    """k = f(Re_p) / T_p [s^-1] (eqs. 3-4), Re_p = |u - u_p| d / nu."""
    return drag_correction(rel * d / nu) / tp


@pjit
def implicit_coefficients(n, x, y, z, u, v, w, d, kd, flag, trem, uf, vf, wf, dt, prm, geo, z_f,
                          z_c, lut, A, B, k0):
    """Per chunk c, accumulate on the faces A[c, comp] += w c_p and B[c, comp] += w c_p (u~_p - o_p).

    prm: [rho, nu, g, rho_p, Q]; A, B: (N_CHUNKS, 3, nx, ny, nk), comp 0 = u, 1 = v, 2 = w.
    o_p is the log-law offset of a parcel below the first level (module doc), 0 elsewhere.
    """
    nx = uf.shape[0]
    ny = uf.shape[1]
    nz = uf.shape[2]
    rho = prm[0]
    nu = prm[1]
    g = prm[2]
    rho_p = prm[3]
    Q = prm[4]
    nc = A.shape[0]
    for c in prange(nc):
        A[c] = 0.0
        B[c] = 0.0
        lo, hi = chunk_bounds(n, c, nc)
        Au = A[c, 0]
        Av = A[c, 1]
        Aw = A[c, 2]
        Bu = B[c, 0]
        Bv = B[c, 1]
        Bw = B[c, 2]
        for p in range(lo, hi):
            if flag[p] != 0:
                continue
            ixf, fxf, ixc, fxc, jyf, fyf, jyc, fyc, kc, fzc, kf, fzf, lfac, islog, kcell = locate(
                x[p], y[p], z[p], geo, z_f, z_c, lut, nx, ny, nz)
            dp = d[p]
            tp = rho_p * dp * dp / (18.0 * rho * nu)
            k = kd[p]
            ou = 0.0
            ov = 0.0
            if islog or k <= 0.0:
                ur, vr, wr = interp_fluid(uf, vf, wf, ixf, fxf, ixc, fxc, jyf, fyf, jyc, fyc, kc,
                                          fzc, kf, fzf, lfac, islog, nx, ny)
                if k <= 0.0:
                    rel = math.sqrt((ur - u[p]) ** 2 + (vr - v[p]) ** 2 + (wr - w[p]) ** 2)
                    k = drag_rate(rel, dp, tp, nu)
                if islog:
                    u0, v0, w0 = interp_faces(uf, vf, wf, nz, nz + 1, ixf, fxf, ixc, fxc, jyf, fyf,
                                              jyc, fyc, kc, fzc, kf, fzf, islog, nx, ny)
                    ou = ur - u0
                    ov = vr - v0
            k0[p] = k
            T = dt + trem[p]  # the parcel's own step (time credit after a splash, particles.py)
            ome = -math.expm1(-k * T)
            cp = Q * (math.pi / 6.0) * rho_p * dp * dp * dp * ome
            wt = w[p] + g / k - g * T / ome
            deposit_faces(Au, Av, Aw, cp, cp, cp, ixf, fxf, ixc, fxc, jyf, fyf, jyc, fyc, kc, fzc,
                          kf, fzf, islog, nx, ny)
            deposit_faces(Bu, Bv, Bw, cp * (u[p] - ou), cp * (v[p] - ov), cp * wt, ixf, fxf, ixc,
                          fxc, jyf, fyf, jyc, fyc, kc, fzc, kf, fzf, islog, nx, ny)


@pjit
def implicit_corrections(A, B, inv_mc, inv_mw, uf, vf, wf, du, dv, dw):
    """delta_f = (sum_c B - U_f sum_c A) / (M_f + sum_c A) on the lowest nk levels of each face
    field: the backward-Euler air velocity change (a convex combination, see module doc)."""
    nc = A.shape[0]
    nx = du.shape[0]
    ny = du.shape[1]
    nk = dw.shape[2]
    for i in prange(nx):
        for j in range(ny):
            for k in range(nk):
                au = 0.0
                av = 0.0
                aw = 0.0
                bu = 0.0
                bv = 0.0
                bw = 0.0
                for c in range(nc):
                    au += A[c, 0, i, j, k]
                    av += A[c, 1, i, j, k]
                    aw += A[c, 2, i, j, k]
                    bu += B[c, 0, i, j, k]
                    bv += B[c, 1, i, j, k]
                    bw += B[c, 2, i, j, k]
                m = inv_mc[k]
                du[i, j, k] = (bu - au * uf[i, j, k]) * m / (1.0 + au * m)
                dv[i, j, k] = (bv - av * vf[i, j, k]) * m / (1.0 + av * m)
                m = inv_mw[k]
                dw[i, j, k] = (bw - aw * wf[i, j, k]) * m / (1.0 + aw * m)


@pjit
def apply_exchange(P, du, dv, dw, inv_mc, inv_mw, uf, vf, wf, tot):
    """Air update: U += delta + (sum_c P[c]) / M on the lowest nk levels (module doc).

    P holds, per face, the difference between the modelled and the actual drag impulses of the
    parcels (zero if they coincide) plus the full impulses of rebounds/ejecta. tot (3,) receives the
    momentum given to the air (kg m s^-1); the return value is the w impulse taken by the bed face.
    Sums are taken in a fixed order.
    """
    nc = P.shape[0]
    nx = uf.shape[0]
    ny = uf.shape[1]
    nk = P.shape[4]
    su = np.zeros(nx)
    sv = np.zeros(nx)
    sw = np.zeros(nx)
    sbed = np.zeros(nx)
    for i in prange(nx):
        for j in range(ny):
            for k in range(nk):
                pu = 0.0
                pv = 0.0
                pw = 0.0
                for c in range(nc):
                    pu += P[c, 0, i, j, k]
                    pv += P[c, 1, i, j, k]
                    pw += P[c, 2, i, j, k]
                pu += du[i, j, k] / inv_mc[k]
                pv += dv[i, j, k] / inv_mc[k]
                uf[i, j, k] += pu * inv_mc[k]
                vf[i, j, k] += pv * inv_mc[k]
                su[i] += pu
                sv[i] += pv
                if inv_mw[k] > 0.0:
                    pw += dw[i, j, k] / inv_mw[k]
                    wf[i, j, k] += pw * inv_mw[k]
                    sw[i] += pw
                else:
                    sbed[i] += pw
    a = 0.0
    b = 0.0
    cc = 0.0
    bed = 0.0
    for i in range(nx):
        a += su[i]
        b += sv[i]
        cc += sw[i]
        bed += sbed[i]
    tot[0] = a
    tot[1] = b
    tot[2] = cc
    return bed


@pjit
def tke_rates(T, inv_vol, nk_c, out):
    """out[:, :, :nk_c] = sum_c T[c] / V_cell; zero above (rates of eq. A1, s^-1)."""
    nc = T.shape[0]
    nx = out.shape[0]
    ny = out.shape[1]
    nz = out.shape[2]
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                if k < nk_c:
                    s = 0.0
                    for c in range(nc):
                        s += T[c, i, j, k]
                    out[i, j, k] = s * inv_vol[k]
                else:
                    out[i, j, k] = 0.0
