"""A grain's motion over one sub-step: the wind it sees, the relaxation of its velocity towards it
under the drag rate, the move, gravity, and the crossing of the 0.5 mm impact layer.
"""
from __future__ import annotations

import math

from ..._jit import jit
from ...physics.drag import clift_factor, particle_response_time, relaxation, relaxed_position
from .coupling import estimate_weights, parcel_weight
from ..numerics.elementary import expm1_small
from .interp import LOG_LEVEL, Stencil, _bil, _tri, ijit, locate, wrap_periodic
from .layout import (
    MAX_SUBSTEPS, _ACTIVE, _D, _DNU, _DU, _DV, _DW, _DZK, _E0, _EC, _EMQ, _FIX, _FXC, _FXF,
    _FYC, _FYF, _FZC, _FZF, _H, _HIT, _IH, _IRELQ, _ITER, _ITP, _K, _KC, _KCELL, _KD, _KF, _KQ,
    _LOG, _MU, _MV, _MW, _QM, _RPQ, _RT, _RU, _RV, _RW, _T, _TLC, _TP, _U, _UN,
    _US, _V, _VN, _VS, _W, _WN, _WS, _X, _XC, _XF, _XN, _Y, _YC, _YF, _YN, _Z, _ZN)
from .drag import _expm1_arg, _expm1_near, _pow687
from .deposit import _reaction, _tke_level, _tke_rate


@jit
def _crossing_time(z0, wt, a, k, h, zc, zh):
    """First t in [0, h] with z(t) = zc, z(0) = z0 >= zc > z(h) = zh, unique (z'' keeps one sign).
    Safeguarded Newton from the root of z's Taylor quadratic at 0 or the apex (or the chord),
    stopped below 1e-14 h, at an exact zero or once the next error |z''| step^2 / (2 |z'|) is
    below a tenth of that: 2.5 evaluations per crossing on the bench's."""
    lo = 0.0
    hi = h
    wp = wt + a
    tol = 1e-14 * h
    t = 0.5 * (lo + hi)
    if wp > 0.0 and wt < 0.0:
        ta = math.log(a / (-wt)) / k  # apex: w_t + a exp(-k t) = 0
        if ta > 0.0:
            lo = min(ta, h)
            # from the apex's Taylor quadratic: z(ta) = z0 + w_t ta + w_p / k, z''(ta) = k w_t
            dz = z0 + wt * ta + wp / k - zc
            if dz > 0.0:
                tq = ta + math.sqrt(2.0 * dz / (-k * wt))
                t = tq if lo < tq < hi else 0.5 * (lo + hi)
    if lo == 0.0 and z0 > zh:
        t = h * (z0 - zc) / (z0 - zh)  # the chord's root
        # z0 + w_p t - (a k / 2) t^2 = zc, in the form without cancellation
        dsc = wp * wp + 2.0 * a * k * (z0 - zc)
        if dsc >= 0.0:
            den = math.sqrt(dsc) - wp
            if den > 0.0:
                tq = 2.0 * (z0 - zc) / den
                if 0.0 < tq < h:
                    t = tq
    for _ in range(100):
        em = expm1_small(-k * t)
        F = z0 + wt * t - a * em / k - zc  # z(t) - zc
        if F == 0.0:
            break
        if F > 0.0:
            lo = t
        else:
            hi = t
        dF = wt + a * (1.0 + em)
        tn = t - F / dF if dF < 0.0 else 0.5 * (lo + hi)
        st = tn - t
        if abs(st) <= tol:
            t = tn
            break
        if lo < tn < hi:
            if dF < 0.0 and st * st * abs(a * k * (1.0 + em)) <= 0.2 * tol * -dF:
                t = tn
                break
        else:
            tn = 0.5 * (lo + hi)
        if hi - lo <= tol:
            t = tn
            break
        t = tn
    return min(max(t, 0.0), h)


@ijit
def _wind_seen(F, G, xp, yp, zp, S, nx, ny, nz):
    """(Stencil, wind) at the parcel; two-way the air after the implicit exchange, U = u + delta."""
    st = locate(xp, yp, zp, G, nx, ny, nz)
    if st.islog:  # the log law of the (new) air at the level read, where the drag goes
        if S.twoway and LOG_LEVEL < S.nkb:
            us = st.lfac * _bil(F.U, st.ixf, st.fxf, st.jyc, st.fyc, LOG_LEVEL, nx, ny)
            vs = st.lfac * _bil(F.V, st.ixc, st.fxc, st.jyf, st.fyf, LOG_LEVEL, nx, ny)
        else:
            us = st.lfac * _bil(F.u, st.ixf, st.fxf, st.jyc, st.fyc, LOG_LEVEL, nx, ny)
            vs = st.lfac * _bil(F.v, st.ixc, st.fxc, st.jyf, st.fyf, LOG_LEVEL, nx, ny)
    elif S.twoway and st.kc + 1 < S.nkb:
        us = _tri(F.U, st.ixf, st.fxf, st.jyc, st.fyc, st.kc, st.fzc, nx, ny)
        vs = _tri(F.V, st.ixc, st.fxc, st.jyf, st.fyf, st.kc, st.fzc, nx, ny)
    else:
        us = _tri(F.u, st.ixf, st.fxf, st.jyc, st.fyc, st.kc, st.fzc, nx, ny)
        vs = _tri(F.v, st.ixc, st.fxc, st.jyf, st.fyf, st.kc, st.fzc, nx, ny)
    if S.twoway and st.kf + 1 < S.nkb:
        ws = _tri(F.W, st.ixc, st.fxc, st.jyc, st.fyc, st.kf, st.fzf, nx, ny)
    else:
        ws = _tri(F.w, st.ixc, st.fxc, st.jyc, st.fyc, st.kf, st.fzf, nx, ny)
    return st, us, vs, ws


@ijit
def _substep_length(T, t, wp, dzk, nsub):
    """The rest of the step, cut to one cell height dzk at |wp| (>= T / MAX_SUBSTEPS)."""
    h = T - t
    if nsub < MAX_SUBSTEPS - 1:
        awp = abs(wp) + 1e-30
        if h * awp > dzk:
            h = max(dzk / awp, T / MAX_SUBSTEPS)
            if h > T - t:
                h = T - t
    return h


@ijit
def _load_lane(lf, li, l, P, p, T, F, G, S, nx, ny, nz):
    """Stage 1 of lane l (parcel p, step T): the parcel, its stencil and the wind it sees."""
    xp = P.x[p]
    yp = P.y[p]
    zp = P.z[p]
    st, us, vs, ws = _wind_seen(F, G, xp, yp, zp, S, nx, ny, nz)
    lf[_X + l] = xp
    lf[_Y + l] = yp
    lf[_Z + l] = zp
    lf[_U + l] = P.u[p]
    lf[_V + l] = P.v[p]
    lf[_W + l] = P.w[p]
    lf[_D + l] = P.d[p]
    lf[_KD + l] = P.kd[p]
    lf[_T + l] = T
    lf[_US + l] = us
    lf[_VS + l] = vs
    lf[_WS + l] = ws
    lf[_DZK + l] = G.dz_c[st.kcell]
    if S.tke:
        kt = _tke_level(st)
        lf[_EC + l] = F.e[st.ixf, st.jyf, kt]
        lf[_TLC + l] = F.tlc[kt]
    lf[_FXF + l] = st.fxf
    lf[_FXC + l] = st.fxc
    lf[_FYF + l] = st.fyf
    lf[_FYC + l] = st.fyc
    lf[_FZC + l] = st.fzc
    lf[_FZF + l] = st.fzf
    li[_ACTIVE + l] = 1
    li[_XF + l] = st.ixf
    li[_XC + l] = st.ixc
    li[_YF + l] = st.jyf
    li[_YC + l] = st.jyc
    li[_KC + l] = st.kc
    li[_KF + l] = st.kf
    li[_LOG + l] = 1 if st.islog else 0
    li[_KCELL + l] = st.kcell


@ijit
def _lane_stencil(lf, li, l):
    """Lane l's Stencil (interp.locate) as _load_lane kept it."""
    return Stencil(li[_XF + l], lf[_FXF + l], li[_XC + l], lf[_FXC + l], li[_YF + l],
                   lf[_FYF + l], li[_YC + l], lf[_FYC + l], li[_KC + l], lf[_FZC + l],
                   li[_KF + l], lf[_FZF + l], 1.0, li[_LOG + l] != 0, li[_KCELL + l])


@ijit
def _lane_start(lf, li, l, S, exact):
    """Stage 2 of lane l: constants, sub-step, modelled impulse, slip, drag iteration's start."""
    active = li[_ACTIVE + l] != 0
    dp = lf[_D + l]
    T = lf[_T + l]
    up = lf[_U + l]
    vp = lf[_V + l]
    wp = lf[_W + l]
    us = lf[_US + l]
    vs = lf[_VS + l]
    ws = lf[_WS + l]
    k = lf[_KD + l]
    tp = particle_response_time(dp, S.rho_p, S.rho, S.nu)
    qm = parcel_weight(S.Q, S.rho_p, dp)
    h = _substep_length(T, 0.0, wp, lf[_DZK + l], 0)
    k0 = k if k > 0.0 else -k
    mu_ = 0.0
    mv_ = 0.0
    mw_ = 0.0
    em0 = 0.0
    ok = True
    if S.twoway:
        em0, ok = _expm1_arg(-k0 * T, exact)
        cc, wtil = estimate_weights(em0, k0, T, qm, wp, S.g)
        if cc > 0.0:
            mu_ = cc * (us - up)
            mv_ = cc * (vs - vp)
            mw_ = cc * (ws - wtil)
    Du = us - up
    Dv = vs - vp
    Dw = ws - wp
    dnu = dp / S.nu
    if k <= 0.0:  # drag_rate (coupling.py)
        rp, ok2 = _pow687(math.sqrt(Du * Du + Dv * Dv + Dw * Dw) * dnu, exact)
        k = clift_factor(rp) / tp
        ok = ok and ok2
    lf[_TP + l] = tp
    lf[_ITP + l] = 1.0 / tp
    lf[_DNU + l] = dnu
    lf[_QM + l] = qm
    lf[_H + l] = h
    lf[_IH + l] = 1.0 / h
    lf[_DU + l] = Du
    lf[_DV + l] = Dv
    lf[_DW + l] = Dw
    lf[_US + l] = us
    lf[_VS + l] = vs
    lf[_WS + l] = ws
    lf[_MU + l] = mu_
    lf[_MV + l] = mv_
    lf[_MW + l] = mw_
    lf[_K + l] = k
    lf[_KQ + l] = -1.0  # no evaluation yet
    lf[_EMQ + l] = em0
    lf[_IRELQ + l] = 0.0
    lf[_RPQ + l] = 0.0
    li[_E0 + l] = 1 if (S.twoway and h == T and k == k0) else 0
    li[_ITER + l] = 1 if active else 0
    li[_FIX + l] = 1 if (active and not ok) else 0


@ijit
def _bed_crossing(zp, zn, k, ik, h, us, vs, wt, up, vp, wp, h_imp):
    """The sub-step cut at the impact layer's crossing, and the parcel's velocities there."""
    h = _crossing_time(zp, wt, wp - wt, k, h, h_imp, zn)
    em = expm1_small(-k * h)
    un, vn, wn, ome_k = relaxation(em, ik, us, vs, wt, up, vp, wp)
    return h, un, vn, wn, ome_k


@ijit
def _move(xp, yp, zn, wn, us, vs, up, vp, h, ome_k, S):
    """(x, y, z, w) after h: the horizontal move wrapped, a parcel above the lid reflected."""
    xn = relaxed_position(xp, us, up, h, ome_k)
    yn = relaxed_position(yp, vs, vp, h, ome_k)
    if zn > S.Lz:  # reflect at the lid
        zn = 2.0 * S.Lz - zn
        wn = -wn
    return wrap_periodic(xn, S.Lx), wrap_periodic(yn, S.Ly), zn, wn


@ijit
def _relax_and_move(xp, yp, zp, up, vp, wp, us, vs, ws, k, kq, emq, h, S, exact):
    """A sub-step of h at drag rate k: relaxation, bed crossing (exact only), move. Returns (x, y,
    z, u, v, w), h as taken, whether it ended at the bed and whether the numbers are exact."""
    ik = 1.0 / k
    em, ok = _expm1_near(k, h, kq, emq, exact)
    wt = ws - S.g * ik
    un, vn, wn, ome_k = relaxation(em, ik, us, vs, wt, up, vp, wp)
    zn = relaxed_position(zp, wt, wp, h, ome_k)
    hit = zn < S.h_imp
    if exact and hit:
        h, un, vn, wn, ome_k = _bed_crossing(zp, zn, k, ik, h, us, vs, wt, up, vp, wp, S.h_imp)
        zn = S.h_imp
    xn, yn, zn, wn = _move(xp, yp, zn, wn, us, vs, up, vp, h, ome_k, S)
    return xn, yn, zn, un, vn, wn, h, hit, ok and not hit


@ijit
def _lane_move(lf, li, l, S, exact):
    """Stage 4 of lane l (vectorized; exact: a lane it left): _relax_and_move, _HIT at the bed."""
    active = li[_ACTIVE + l] != 0
    xn, yn, zn, un, vn, wn, h, hit, ok = _relax_and_move(
        lf[_X + l], lf[_Y + l], lf[_Z + l], lf[_U + l], lf[_V + l], lf[_W + l], lf[_US + l],
        lf[_VS + l], lf[_WS + l], lf[_K + l], lf[_KQ + l], lf[_EMQ + l], lf[_H + l], S, exact)
    lf[_XN + l] = xn
    lf[_YN + l] = yn
    lf[_ZN + l] = zn
    lf[_UN + l] = un
    lf[_VN + l] = vn
    lf[_WN + l] = wn
    lf[_H + l] = h
    qm = lf[_QM + l]
    ru, rv, rw = _reaction(lf[_MU + l], lf[_MV + l], lf[_MW + l], qm, un, vn, wn, lf[_U + l],
                           lf[_V + l], lf[_W + l], h, S)
    lf[_RU + l] = ru
    lf[_RV + l] = rv
    lf[_RW + l] = rw
    if S.tke:
        lf[_RT + l] = _tke_rate(lf[_EC + l], lf[_TLC + l], qm, lf[_K + l], lf[_TP + l], h, S)
    li[_HIT + l] = 1 if (exact and hit) else 0
    li[_FIX + l] = 1 if (active and not ok) else 0
