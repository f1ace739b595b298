"""Two-way momentum exchange between parcels and air (paper eq. 2) and the SGS TKE sink (eq. A1).

Momentum. The air at a velocity face (mass ``M = rho dx dy dz``, dz = ``dz_c[k]`` for u, v,
``dz_f[k]`` for w) receives minus each parcel's drag impulse ``-Q m_p (Delta u_p - g Delta t)``
with the trilinear weights (summing to one) that interpolated the air at the parcel: momentum is
conserved to round-off. The share of a vertical impulse on the bed face goes into the ground; a
parcel in the log region (interp.py) deposits on level 1, the level it reads.

Point-implicit exchange. Relaxing at drag rate ``k_p`` (eqs. 3-4) towards the wind ``u_s`` it
sees, a parcel gains ``c_p (u_s - u~_p)`` over ``dt``, ``c_p = Q m_p (1 - E_p)``, ``E_p =
exp(-k_p dt)``, ``u~_p = u_p - g/k_p + g dt/(1 - E_p)``. With the wind of the start of the step a
cell whose grain mass exceeds its air mass would overshoot, so each face is advanced
backward-Euler in the drag, the parcels frozen (``l_p = ln(z_p/z0) / ln(z_c[1]/z0)`` in the log
region, 1 elsewhere)::

    U_f' = (M_f U_f + sum_p w_pf c_p u~_p) / (M_f + sum_p w_pf c_p l_p)      (a convex combination)

and each parcel sees ``u_s,p = l_p sum_f w_pf U_f'``: no value leaves the old range whatever the
loading (tested at grain mass 100x the air mass). The air gets ``U_f' - U_f``, plus the actual
minus the modelled impulses (drag iteration, sub-steps, bed crossings) with the same weights.
(Depositing the actual impulses, the estimate serving only the seen wind, blows up in the loading
test for modes the interpolation smooths.)

Buffers. Each of ``N_CHUNKS`` chunks of consecutive x-slabs deposits into its own range of one
pool kept across steps (its slabs widened by the stencil and by how far its parcels can move);
the ranges are summed in chunk order: the result does not depend on the thread count.

TKE sink (eq. A1). Per cell, the rate [s^-1] multiplying e::

    s = (Q / V_cell) sum_p (m_p / rho) 2 f(Re_p) / (T_p + T_L),   T_L = 4 e / (3 C0 eps)

with ``eps = c_eps e^{3/2} / l`` (Deardorff 1980; sgs.py's l and c_eps) and ``C0 = 2.1``, a value
widely used for the Lagrangian structure-function constant (the paper does not state its C0); 0
where ``e <= 0``. A parcel feeds the cell holding it (log region: the level-1 cell it read) for
the fraction of the step it spent there.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import prange

from ..._jit import jit, jit_borrow, pjit
from ...physics.drag import clift_factor, particle_response_time
from ..numerics.elementary import EXPM1_TAYLOR_MAX, expm1_small, expm1_taylor, pow_0687
from ..closures.sgs import C0_LAGRANGIAN
from .interp import ijit, interp_fluid, locate, pool_add_tri2, wrap_index

#: The grain kernels' records (named tuples: numba passes each as one argument, its fields static
#: members). The parcels' arrays (length: capacity; the first n live):
Parcels = namedtuple("Parcels", "x y z u v w d kd flag trem")
#: The air at the start of the step: u, v, w, SGS TKE e; tlc per level, T_L = tlc[k] / sqrt(e);
#: two-way, the implicit change du, dv, dw on the lowest nk levels and U = u + du etc. there
#: (placeholders of shape (1, 1, 1) one-way):
Flow = namedtuple("Flow", "u v w e tlc U V W du dv dw")


#: parcel chunks, each with its own deposit buffers: fixed, not the thread count, so that every
#: sum runs in the same order and a run is bit-for-bit the same with 1 or 2 threads
N_CHUNKS = 4


def face_inverse_masses(grid, rho: float) -> tuple[np.ndarray, np.ndarray]:
    """1 / (air mass) of the u/v faces (nz,) and of the w faces (nz + 1,; 0 at the bed and lid)."""
    a = rho * grid.dx * grid.dy
    inv_c = 1.0 / (a * grid.dz_c)
    inv_w = np.zeros(grid.nz + 1)
    inv_w[1:-1] = 1.0 / (a * grid.dz_f[1:-1])
    return np.ascontiguousarray(inv_c), inv_w


def lagrangian_time_coefficients(grid, kappa: float, c0: float = C0_LAGRANGIAN,
                                 delta: str = "scotti") -> np.ndarray:
    """4 l / (3 C0 c_eps) per level [m s^-1], T_L = coef[k] / sqrt(e) (the SGS model's l, c_eps)."""
    from ..closures.sgs import c_eps_profile, length_scale
    ell = length_scale(grid, kappa, delta=delta)
    c_eps = c_eps_profile(grid, ell, delta)
    return np.ascontiguousarray(4.0 * ell / (3.0 * c0 * c_eps))


@ijit
def drag_rate(rel, dnu, tp):
    """k = f(Re_p) / T_p [s^-1] (eqs. 3-4), Re_p = |u - u_p| d / nu; dnu = d / nu [s m^-1]."""
    return clift_factor(pow_0687(rel * dnu)) / tp


@ijit
def parcel_weight(Q, rho_p, d):
    """Q m_p [kg]: the mass of the Q real grains of diameter d a parcel stands for."""
    return Q * (math.pi / 6.0) * rho_p * d * d * d


@ijit
def estimate_weights(em, k0, T, qm, wp, g):
    """(c_p, vertical u~_p) of a parcel, em = expm1(-k0 T) (module doc; horizontal u~_p = u_p)."""
    ome = -em
    return qm * ome, wp + g / k0 - g * T / ome


@ijit
def implicit_estimate(k0, T, qm, wp, g):
    """(expm1(-k0 T), c_p, the vertical u~_p) of a parcel (estimate_weights)."""
    em = expm1_small(-k0 * T)
    cp, wt = estimate_weights(em, k0, T, qm, wp, g)
    return em, cp, wt


#: parcel blocks of chunk_assign's parallel passes (fixed, so the result is thread-count free)
_ASSIGN_BLOCKS = 32


@pjit
def chunk_assign(n, x, u, flag, trem, dx, nx, hist, slab_stats, bounds, cid, cstart, idx,
                 stats, v, w, z, pmax):
    """Split the live parcels into chunks of consecutive x-slabs with about equal counts: chunk c
    owns slabs [bounds[c], bounds[c+1]), its parcels idx[cstart[c]:cstart[c+1]] in index order;
    stats[c] = (max |u_p|, max trem); pmax: the max horizontal speed, height and speed. Two
    parallel passes over _ASSIGN_BLOCKS blocks, the second filing from each block's offsets."""
    nc = cstart.shape[0] - 1
    nb = _ASSIGN_BLOCKS
    hb = np.zeros((nb, nx), dtype=np.int64)
    sb = np.zeros((nb, nx, 2))
    pb = np.zeros((nb, 3))
    for b in prange(nb):
        vh = 0.0
        zt = 0.0
        v2 = 0.0
        for p in range((b * n) // nb, ((b + 1) * n) // nb):
            if flag[p] != 0:
                continue
            i = wrap_index(int(x[p] / dx), nx)
            cid[p] = i
            hb[b, i] += 1
            a = abs(u[p])
            if a > sb[b, i, 0]:
                sb[b, i, 0] = a
            if trem[p] > sb[b, i, 1]:
                sb[b, i, 1] = trem[p]
            a = max(abs(u[p]), abs(v[p]))
            if a > vh:
                vh = a
            if z[p] > zt:
                zt = z[p]
            a = u[p] * u[p] + v[p] * v[p] + w[p] * w[p]  # squared: one square root at the end
            if a > v2:
                v2 = a
        pb[b, 0] = vh
        pb[b, 1] = zt
        pb[b, 2] = v2
    for r in range(3):
        m = 0.0
        for b in range(nb):
            if pb[b, r] > m:
                m = pb[b, r]
        pmax[r] = m
    pmax[2] = math.sqrt(pmax[2])
    live = 0
    for i in range(nx):
        m = 0
        for r in range(2):
            slab_stats[i, r] = 0.0
        for b in range(nb):
            m += hb[b, i]
            for r in range(2):
                if sb[b, i, r] > slab_stats[i, r]:
                    slab_stats[i, r] = sb[b, i, r]
        hist[i] = m
        live += m
    bounds[0] = 0
    c = 1
    acc = 0
    for i in range(nx):
        acc += hist[i]
        while c < nc and acc * nc >= c * live:
            bounds[c] = i + 1
            c += 1
    while c < nc:
        bounds[c] = nx
        c += 1
    bounds[nc] = nx
    # per chunk: parcel count and maxima; then slab -> chunk (reusing hist)
    cstart[0] = 0
    for c in range(nc):
        m = 0
        stats[c, 0] = 0.0
        stats[c, 1] = 0.0
        for i in range(bounds[c], bounds[c + 1]):
            m += hist[i]
            for r in range(2):
                if slab_stats[i, r] > stats[c, r]:
                    stats[c, r] = slab_stats[i, r]
            hist[i] = c
        cstart[c + 1] = cstart[c] + m
    # fill pointers per block and chunk: the chunk's start plus the earlier blocks' parcels
    fill = np.zeros((nb, nc), dtype=np.int64)
    for c in range(nc):
        o = cstart[c]
        for b in range(nb):
            fill[b, c] = o
            for i in range(bounds[c], bounds[c + 1]):
                o += hb[b, i]
    for b in prange(nb):
        for p in range((b * n) // nb, ((b + 1) * n) // nb):
            if flag[p] != 0:
                continue
            c = hist[cid[p]]
            idx[fill[b, c]] = p
            fill[b, c] += 1


@jit
def chunk_ranges(bounds, margin, nx, per_slab, ranges):
    """ranges[c] = (first slab, L, pool offset): chunk c's slabs widened by margin[c]."""
    nc = ranges.shape[0]
    off = 0
    for c in range(nc):
        L = bounds[c + 1] - bounds[c]
        if L == 0:
            ranges[c, 0] = 0
            ranges[c, 1] = 0
            ranges[c, 2] = off
            continue
        m = margin[c]
        L = L + 2 * m
        st = bounds[c] - m
        if L >= nx:
            L = nx
            st = 0
        if st < 0:
            st += nx
        ranges[c, 0] = st
        ranges[c, 1] = L
        ranges[c, 2] = off
        off += L * per_slab
    return off


@jit_borrow
def air_maxima(u, w, umax):
    """max |w| (returned) and umax[k] = max |u| of level k. Serial: a parallel region's wake-up
    cost 5.5 ms for 0.15 ms of work (1e5 parcels, shared machine, `bench particles --phases`)."""
    nx = u.shape[0]
    ny = u.shape[1]
    nz = u.shape[2]
    nzw = w.shape[2]
    for k in range(nz + 1):
        umax[k] = 0.0
    m = 0.0
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                a = abs(u[i, j, k])
                if a > umax[k]:
                    umax[k] = a
            for k in range(nzw):
                a = abs(w[i, j, k])
                if a > m:
                    m = a
    umax[nz] = m
    return m


#: parcels whose estimates _implicit_chunk computes together: scalar passes (locate, deposits)
#: around a branch-free loop LLVM vectorizes (expm1 and the weights, ~20 dependent multiply-adds);
#: row r of lane l at r * EST_LANES + l of the advance's lane scratch (layout.Work)
EST_LANES = 64
(_EU, _EV, _EW, _ED, _EK, _ET, _ELF, _ECP, _EWT,
 _EFXF, _EFXC, _EFYF, _EFYC, _EFZC, _EFZF) = (r * EST_LANES for r in range(15))
(_EXF, _EXC, _EYF, _EYC, _EKC, _EKF, _EOK) = (r * EST_LANES for r in range(7))
#: rows of the lane scratch the estimate needs (floats, integers)
EST_ROWS_F = 15
EST_ROWS_I = 7


@ijit
def _estimate_load(lf, li, l, p, P, F, dt, nu, rho, rho_p, G, nx, ny, nz):
    """Stage 1 of implicit lane l (parcel p): stencil, values, a first drag rate if it has none."""
    st = locate(P.x[p], P.y[p], P.z[p], G, nx, ny, nz)
    dp = P.d[p]
    k = P.kd[p]
    up = P.u[p]
    vp = P.v[p]
    wp = P.w[p]
    if k <= 0.0:
        ur, vr, wr = interp_fluid(F.u, F.v, F.w, st, nx, ny)
        rel = math.sqrt((ur - up) ** 2 + (vr - vp) ** 2 + (wr - wp) ** 2)
        k = drag_rate(rel, dp / nu, particle_response_time(dp, rho_p, rho, nu))
        P.kd[p] = -k  # the advance takes k0 = -kd and finds its own first rate in the new air
    lf[_EU + l] = up
    lf[_EV + l] = vp
    lf[_EW + l] = wp
    lf[_ED + l] = dp
    lf[_EK + l] = k
    lf[_ET + l] = dt + P.trem[p]  # the parcel's own step (time credit after a splash)
    lf[_ELF + l] = st.lfac  # A's horizontal weight factor (1 above the log region)
    lf[_EFXF + l] = st.fxf
    lf[_EFXC + l] = st.fxc
    lf[_EFYF + l] = st.fyf
    lf[_EFYC + l] = st.fyc
    lf[_EFZC + l] = st.fzc
    lf[_EFZF + l] = st.fzf
    li[_EXF + l] = st.ixf
    li[_EXC + l] = st.ixc
    li[_EYF + l] = st.jyf
    li[_EYC + l] = st.jyc
    li[_EKC + l] = st.kc
    li[_EKF + l] = st.kf


@ijit
def _estimate_lane(lf, li, l, g, Q, rho_p, exact):
    """Stage 2 of implicit lane l: c_p, vertical u~_p; _EOK 0 if Taylor's expm1 does not hold."""
    k = lf[_EK + l]
    T = lf[_ET + l]
    x = -k * T
    if exact:
        em = expm1_small(x)
    else:
        em = expm1_taylor(x)
    cp, wt = estimate_weights(em, k, T, parcel_weight(Q, rho_p, lf[_ED + l]), lf[_EW + l], g)
    lf[_ECP + l] = cp
    lf[_EWT + l] = wt
    li[_EOK + l] = 1 if (exact or abs(x) <= EXPM1_TAYLOR_MAX) else 0


@ijit
def _estimate_deposit(lf, li, l, pool, off, csz, s, nx, ny, nk):
    """Stage 3 of implicit lane l: (A, B) of its three components on the faces."""
    cp = lf[_ECP + l]
    ah = cp * lf[_ELF + l]
    ixf = li[_EXF + l]
    ixc = li[_EXC + l]
    jyf = li[_EYF + l]
    jyc = li[_EYC + l]
    kc = li[_EKC + l]
    fxf = lf[_EFXF + l]
    fxc = lf[_EFXC + l]
    fyf = lf[_EFYF + l]
    fyc = lf[_EFYC + l]
    fzc = lf[_EFZC + l]
    pool_add_tri2(pool, off, s, nx, ny, nk, ah, cp * lf[_EU + l], ixf, fxf, jyc, fyc, kc, fzc)
    pool_add_tri2(pool, off + csz, s, nx, ny, nk, ah, cp * lf[_EV + l], ixc, fxc, jyf, fyf, kc,
                  fzc)
    pool_add_tri2(pool, off + 2 * csz, s, nx, ny, nk, cp, cp * lf[_EWT + l], ixc, fxc, jyc, fyc,
                  li[_EKF + l], lf[_EFZF + l])


@jit_borrow
def _implicit_chunk(c, cstart, idx, P, F, dt, prm, G, pool, ranges, nk, lane_f, lane_i):
    """Chunk c of implicit_coefficients: blocks of EST_LANES parcels in three passes."""
    nx = F.u.shape[0]
    ny = F.u.shape[1]
    nz = F.u.shape[2]
    rho = prm[0]
    nu = prm[1]
    g = prm[2]
    rho_p = prm[3]
    Q = prm[4]
    s = ranges[c, 0]
    L = ranges[c, 1]
    off = ranges[c, 2]
    csz = L * ny * nk * 2
    pool[off:off + 3 * csz] = 0.0
    lf = lane_f[c]
    li = lane_i[c]
    qend = cstart[c + 1]
    for q0 in range(cstart[c], qend, EST_LANES):
        nb = min(EST_LANES, qend - q0)
        for l in range(nb):
            _estimate_load(lf, li, l, idx[q0 + l], P, F, dt, nu, rho, rho_p, G, nx, ny, nz)
        for l in range(nb):
            _estimate_lane(lf, li, l, g, Q, rho_p, False)
        for l in range(nb):
            if li[_EOK + l] == 0:
                _estimate_lane(lf, li, l, g, Q, rho_p, True)
        for l in range(nb):
            _estimate_deposit(lf, li, l, pool, off, csz, s, nx, ny, nk)


@pjit
def implicit_coefficients(cstart, idx, P, F, dt, prm, G, pool, ranges, nk, lane_f, lane_i):
    """Per chunk, A += w c_p (l_p in the log region) and B += w c_p u~_p on the faces, interleaved
    (L, ny, nk, 2) per comp; a parcel without a drag rate gets one, stored as kd = -k0."""
    for c in prange(ranges.shape[0]):
        _implicit_chunk(c, cstart, idx, P, F, dt, prm, G, pool, ranges, nk, lane_f, lane_i)


@ijit
def _covers(ranges, c, i, nx):
    """Chunk c's local index of slab i, or -1 if its pool range does not cover slab i."""
    ii = i - ranges[c, 0]
    if ii < 0:
        ii += nx
    return ii if ii < ranges[c, 1] else -1


@pjit
def implicit_corrections(pool, ranges, inv_mc, inv_mw, uf, vf, wf, du, dv, dw, Uc, Vc, Wc, dmax,
                         acc):
    """delta_f = (sum_c B - U_f sum_c A) / (M_f + sum_c A) on the lowest nk levels (module doc),
    Uc = U + delta etc., dmax[i] = max |delta| of slab i; chunks summed in chunk order."""
    nc = ranges.shape[0]
    nx = du.shape[0]
    ny = du.shape[1]
    nk = dw.shape[2]
    for i in prange(nx):
        a = acc[i]
        dm = 0.0
        for j in range(ny):
            for r in range(6):
                for k in range(nk):
                    a[r, k] = 0.0
            for c in range(nc):
                ii = _covers(ranges, c, i, nx)
                if ii < 0:
                    continue
                csz = ranges[c, 1] * ny * nk * 2
                q = ranges[c, 2] + 2 * (ii * ny + j) * nk
                for k in range(nk):
                    a[0, k] += pool[q + 2 * k]
                    a[1, k] += pool[q + 2 * k + 1]
                    a[2, k] += pool[q + csz + 2 * k]
                    a[3, k] += pool[q + csz + 2 * k + 1]
                    a[4, k] += pool[q + 2 * csz + 2 * k]
                    a[5, k] += pool[q + 2 * csz + 2 * k + 1]
            # one loop per component: few arrays written each, so that LLVM vectorizes it
            for k in range(nk):
                m = inv_mc[k]
                x = (a[1, k] - a[0, k] * uf[i, j, k]) * m / (1.0 + a[0, k] * m)
                y = (a[3, k] - a[2, k] * vf[i, j, k]) * m / (1.0 + a[2, k] * m)
                m = inv_mw[k]
                a[4, k] = (a[5, k] - a[4, k] * wf[i, j, k]) * m / (1.0 + a[4, k] * m)
                a[0, k] = x
                a[2, k] = y
            for k in range(nk):  # (a float max reduction does not vectorize without nnan)
                dm = max(dm, max(abs(a[0, k]), abs(a[2, k])))
            for k in range(nk):
                du[i, j, k] = a[0, k]
                Uc[i, j, k] = uf[i, j, k] + a[0, k]
            for k in range(nk):
                dv[i, j, k] = a[2, k]
                Vc[i, j, k] = vf[i, j, k] + a[2, k]
            for k in range(nk):
                dw[i, j, k] = a[4, k]
                Wc[i, j, k] = wf[i, j, k] + a[4, k]
        dmax[i] = dm


@ijit
def _momentum_to_air(pool, ranges, i, j, nx, ny, nk, a, du, dv, dw, inv_mc, inv_mw, m_c, m_w,
                     uf, vf, wf):
    """Column (i, j) of apply_exchange: (momentum to the air (x, y, z), bed-face w impulse)."""
    nc = ranges.shape[0]
    for r in range(3):
        for k in range(nk):
            a[r, k] = 0.0
    for c in range(nc):
        ii = _covers(ranges, c, i, nx)
        if ii < 0:
            continue
        csz = ranges[c, 1] * ny * nk
        q = ranges[c, 2] + (ii * ny + j) * nk
        for k in range(nk):
            a[0, k] += pool[q + k]
            a[1, k] += pool[q + csz + k]
            a[2, k] += pool[q + 2 * csz + k]
    su = 0.0
    sv = 0.0
    sw = 0.0
    sbed = 0.0
    for k in range(nk):
        pu = a[0, k] + du[i, j, k] * m_c[k]
        uf[i, j, k] += pu * inv_mc[k]
        su += pu
    for k in range(nk):
        pv = a[1, k] + dv[i, j, k] * m_c[k]
        vf[i, j, k] += pv * inv_mc[k]
        sv += pv
    for k in range(nk):
        pw = a[2, k]
        if inv_mw[k] > 0.0:
            pw += dw[i, j, k] * m_w[k]
            wf[i, j, k] += pw * inv_mw[k]
            sw += pw
        else:
            sbed += pw
    return su, sv, sw, sbed


@ijit
def _tke_rates(pool, ranges, i, j, nx, ny, comp, nk_c, nz, a, inv_vol, out):
    """Column (i, j) of apply_exchange: out[i, j, :nk_c] = sum_c T[c] / V_cell, 0 up to nz."""
    nc = ranges.shape[0]
    for k in range(nk_c):
        a[0, k] = 0.0
    for c in range(nc):
        ii = _covers(ranges, c, i, nx)
        if ii < 0:
            continue
        q = ranges[c, 2] + ((comp * ranges[c, 1] + ii) * ny + j) * nk_c
        for k in range(nk_c):
            a[0, k] += pool[q + k]
    for k in range(nk_c):
        out[i, j, k] = a[0, k] * inv_vol[k]
    for k in range(nk_c, nz):
        out[i, j, k] = 0.0


@pjit
def apply_exchange(pool, ranges, nk, two, du, dv, dw, inv_mc, inv_mw, m_c, m_w, uf, vf, wf, tot,
                   tke, comp, nz_tke, inv_vol, tke_out, acc, part):
    """The air's side of the step in one pass (one parallel region fewer). Two-way: U += delta +
    (sum_c P[c]) / M, P the modelled minus the actual impulses; tot gets the momentum to the
    air [kg m s^-1]. TKE: tke_out[:, :, :nk] = sum_c T[c] / V_cell [s^-1], zero up to nz_tke."""
    nx = uf.shape[0]
    ny = uf.shape[1]
    for i in prange(nx):
        a = acc[i]
        su = 0.0
        sv = 0.0
        sw = 0.0
        sbed = 0.0
        for j in range(ny):
            if two:
                x, y, z, b = _momentum_to_air(pool, ranges, i, j, nx, ny, nk, a, du, dv, dw,
                                              inv_mc, inv_mw, m_c, m_w, uf, vf, wf)
                su += x
                sv += y
                sw += z
                sbed += b
            if tke:
                _tke_rates(pool, ranges, i, j, nx, ny, comp, nk, nz_tke, a, inv_vol, tke_out)
        part[i, 0] = su
        part[i, 1] = sv
        part[i, 2] = sw
        part[i, 3] = sbed
    a = 0.0
    b = 0.0
    cc = 0.0
    bed = 0.0
    for i in range(nx):
        a += part[i, 0]
        b += part[i, 1]
        cc += part[i, 2]
        bed += part[i, 3]
    tot[0] = a
    tot[1] = b
    tot[2] = cc
    return bed
