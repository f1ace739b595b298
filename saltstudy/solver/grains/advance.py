"""The advance of all grains over a step, chunk by chunk: blocks of lanes through the vectorized
passes, the exact pass for the lanes that need it, the further sub-steps of the few that need
them, the impacts flagged for the bed.
"""
from __future__ import annotations

from numba import prange

from ..._jit import jit_borrow, pjit
from .interp import ijit
from .layout import (
    _ACTIVE, _DT, _FIX, _G, _H, _HIMP, _HIT, _K, _LANES, _LZ, _NU, _Out, _Q, _QM, _RHO, _RHOP,
    _RT, _RU, _RV, _RW, _Step, _T, _TKE, _TOL, _TP, _TWOWAY, _UN, _VN, _WN, _XN, _YN, _ZN)
from .drag import _drag_lanes, _drag_rate
from .motion import (
    _lane_move, _lane_start, _lane_stencil, _load_lane, _relax_and_move, _substep_length,
    _wind_seen)
from .deposit import _reaction_to_air, _tke_to_air, _to_air


@ijit
def _rest_of_step(P, p, t, T, xp, yp, zp, up, vp, wp, k, tp, qm, F, G, O, S, nx, ny, nz):
    """The sub-steps after the first: (state, hit, time left)."""
    itp = 1.0 / tp
    dnu = P.d[p] / S.nu
    nsub = 1
    while True:
        st, us, vs, ws = _wind_seen(F, G, xp, yp, zp, S, nx, ny, nz)
        h = _substep_length(T, t, wp, G.dz_c[st.kcell], nsub)
        k, kq, emq = _drag_rate(k, h, us - up, vs - vp, ws - wp, itp, dnu, S)
        xn, yn, zn, un, vn, wn, h, hit, _ = _relax_and_move(xp, yp, zp, up, vp, wp, us, vs, ws,
                                                            k, kq, emq, h, S, True)
        _to_air(O, F, st, 0.0, 0.0, 0.0, qm, un, vn, wn, up, vp, wp, k, tp, h, S, nx, ny)
        xp, yp, zp, up, vp, wp = xn, yn, zn, un, vn, wn
        t += h
        nsub += 1
        if hit or not t < T:
            return xp, yp, zp, up, vp, wp, k, hit, T - t


@ijit
def _finish_lane(lf, li, l, P, p, F, G, O, S, nx, ny, nz):
    """Stage 5 of lane l: deposits, further sub-steps, store; (hit, time left, u, v)."""
    st = _lane_stencil(lf, li, l)
    k = lf[_K + l]
    h = lf[_H + l]
    T = lf[_T + l]
    tp = lf[_TP + l]
    qm = lf[_QM + l]
    xn = lf[_XN + l]
    yn = lf[_YN + l]
    zn = lf[_ZN + l]
    un = lf[_UN + l]
    vn = lf[_VN + l]
    wn = lf[_WN + l]
    hit = li[_HIT + l] != 0
    if S.twoway:
        _reaction_to_air(O, st, lf[_RU + l], lf[_RV + l], lf[_RW + l], S, nx, ny)
    if S.tke:
        _tke_to_air(O, st, lf[_RT + l], S, nx, ny)
    left = T - h
    if not hit and h < T:
        xn, yn, zn, un, vn, wn, k, hit, left = _rest_of_step(P, p, h, T, xn, yn, zn, un, vn, wn,
                                                             k, tp, qm, F, G, O, S, nx, ny, nz)
    P.x[p] = xn
    P.y[p] = yn
    P.z[p] = zn
    P.u[p] = un
    P.v[p] = vn
    P.w[p] = wn
    P.kd[p] = k
    return hit, left, un, vn


@ijit
def _hit(P, p, trem, nh):
    """Flag parcel p for the bed events with trem of its step left; returns the hit count."""
    P.flag[p] = 1
    P.trem[p] = trem
    return nh + 1


@ijit
def _track_speed(vm, u, v):
    """The chunk's largest horizontal parcel speed (max_dt)."""
    sp = max(abs(u), abs(v))
    return sp if sp > vm else vm


@jit_borrow
def _advance_chunk(c, dt, nk, ncomp, ct, prm, P, F, G, W):
    """Integrate chunk c's parcels over dt plus their credit; hits get flag 1 and their time left
    in trem (W.nhit[c]), W.vmax[c] the largest horizontal speed. Deposits (zeroed first) minus
    the drag impulse plus, two-way, the modelled impulse; in blocks of _LANES (layout.py)."""
    nx = F.u.shape[0]
    ny = F.u.shape[1]
    nz = G.z_c.shape[0]
    tol = prm[_TOL]
    S = _Step(prm[_DT], prm[_G], prm[_HIMP], tol, tol * tol, G.geo[2], G.geo[3], prm[_LZ],
              prm[_RHO], prm[_NU], prm[_RHOP], prm[_Q], prm[_TWOWAY] != 0.0, prm[_TKE] != 0.0,
              F.du.shape[2])
    s = W.ranges[c, 0]
    L = W.ranges[c, 1]
    off = W.ranges[c, 2]
    csz = L * ny * nk
    O = _Out(W.pool, s, L, off, csz, nk, ct)
    W.pool[off:off + ncomp * csz] = 0.0
    vm = 0.0
    nh = 0
    lf = W.lane_f[c]
    li = W.lane_i[c]
    qend = W.cstart[c + 1]
    for q0 in range(W.cstart[c], qend, _LANES):
        nb = min(_LANES, qend - q0)
        for l in range(nb):
            p = W.idx[q0 + l]
            tr = P.trem[p]  # time credit of a parcel that left the bed during the last step
            T = dt + tr
            if tr != 0.0:  # few have one: the array is not rewritten every step
                P.trem[p] = 0.0
            if P.z[p] < S.h_imp:  # placed inside the impact layer (add_parcels): splash now
                li[_ACTIVE + l] = 0
                if P.kd[p] < 0.0:  # the implicit estimate's k0 (coupling.py): none yet
                    P.kd[p] = 0.0
                nh = _hit(P, p, T, nh)
                vm = _track_speed(vm, P.u[p], P.v[p])
                continue
            _load_lane(lf, li, l, P, p, T, F, G, S, nx, ny, nz)
        for l in range(nb):
            _lane_start(lf, li, l, S, False)
        for l in range(nb):
            if li[_FIX + l] != 0:
                _lane_start(lf, li, l, S, True)
        _drag_lanes(lf, li, nb, S)
        for l in range(nb):
            _lane_move(lf, li, l, S, False)
        for l in range(nb):
            if li[_ACTIVE + l] == 0:
                continue
            if li[_FIX + l] != 0:
                _lane_move(lf, li, l, S, True)
            p = W.idx[q0 + l]
            hit, left, un, vn = _finish_lane(lf, li, l, P, p, F, G, O, S, nx, ny, nz)
            if hit:
                nh = _hit(P, p, left, nh)
            vm = _track_speed(vm, un, vn)
    W.vmax[c] = vm
    W.nhit[c] = nh


@pjit
def advance_all(dt, nk, ncomp, ct, prm, P, F, G, W):
    """All parcels over dt, chunk-parallel (see _advance_chunk)."""
    for c in prange(W.ranges.shape[0]):
        _advance_chunk(c, dt, nk, ncomp, ct, prm, P, F, G, W)
