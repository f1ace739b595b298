"""The drag rate's fixed point (eq. 3 with Clift's correction, physics/drag.py), its Newton update,
and the short series that update exp(-k h) and Re^0.687 from their last evaluation, scalar and
per lane.
"""
from __future__ import annotations

import math

from ...physics.drag import clift_factor, clift_slope
from ..numerics.elementary import (
    EXPM1_TAYLOR_MAX, expm1_small, expm1_taylor, pow_0687, pow_0687_table)
from .interp import ijit
from .layout import (
    DRAG_MAXIT, NEWTON_MAXIT, _B1, _B10, _B2, _B3, _B4, _B5, _B6, _B7, _B8, _B9, _DNU, _DU, _DV,
    _DW, _E0, _EMQ, _FIX, _H, _IH, _IRELQ, _ITER, _ITP, _K, _KQ, _NEAR, _RPQ, _X2, _X3, _X4,
    _X5, _X6, _X7, _X8, _X9)


@ijit
def _expm1_shift(k, h, kq, emq):
    """expm1(-k h) from emq = expm1(-kq h), a series in (kq - k) h (exact for |.| <= _NEAR)."""
    x = (kq - k) * h
    t = x * (1.0 + x * (_X2 + x * (_X3 + x * (_X4 + x * (_X5 + x * (_X6 + x * (
        _X7 + x * (_X8 + x * _X9))))))))
    return emq + (1.0 + emq) * t


@ijit
def _re687_shift(rel, irelq, rpq):
    """(rel dnu)^0.687 from rpq = (relq dnu)^0.687 by a binomial series (irelq = 1 / relq)."""
    e = rel * irelq - 1.0
    return rpq * (1.0 + e * (_B1 + e * (_B2 + e * (_B3 + e * (_B4 + e * (_B5 + e * (
        _B6 + e * (_B7 + e * (_B8 + e * (_B9 + e * _B10))))))))))


@ijit
def _expm1_arg(x, exact):
    """(expm1(x), whether exact): expm1_small with ``exact``, else the Taylor polynomial alone."""
    if exact:
        return expm1_small(x), True
    return expm1_taylor(x), abs(x) <= EXPM1_TAYLOR_MAX


@ijit
def _expm1_near(k, h, kq, emq, exact):
    """(expm1(-k h), whether exact), by _expm1_shift if |(kq - k) h| <= _NEAR (kq <= 0: none)."""
    near = kq > 0.0 and abs((kq - k) * h) <= _NEAR
    if exact:
        if near:
            return _expm1_shift(k, h, kq, emq), True
        return expm1_small(-k * h), True
    v, ok = _expm1_arg(-k * h, False)
    if near:
        v = _expm1_shift(k, h, kq, emq)
    return v, near or ok


@ijit
def _pow687(x, exact):
    """(x^0.687, whether exact): pow_0687 with ``exact``, else the table path alone."""
    if exact:
        return pow_0687(x), True
    return pow_0687_table(x)


@ijit
def _re687_near(rel, dnu, irelq, rpq, exact):
    """((rel dnu)^0.687, whether exact), by _re687_shift if |rel / relq - 1| <= _NEAR."""
    near = irelq > 0.0 and abs(rel * irelq - 1.0) <= _NEAR
    if exact:
        if near:
            return _re687_shift(rel, irelq, rpq), True
        return pow_0687(rel * dnu), True
    v, ok = pow_0687_table(rel * dnu)
    if near:
        v = _re687_shift(rel, irelq, rpq)
    return v, near or ok


@ijit
def _slip_at(k, em, ih, Du, Dv, Dw, g):
    """The slip F(k) is evaluated at, E (mean slip) + (1 - E) (end slip) over h with k frozen
    (particles.py); returns it, its size and dF/dk's factors; em = expm1(-k h), ih = 1 / h."""
    ik = 1.0 / k
    E = 1.0 + em
    phi = -em * ik * ih
    beta = E * (phi - em)
    gk = g * ik
    ax = Du * beta
    ay = Dv * beta
    az = gk + (Dw - gk) * beta
    rel = math.sqrt(ax * ax + ay * ay + az * az)
    return ax, ay, az, rel, ik, E, phi, beta, gk


@ijit
def _newton_update(k, rp, ax, ay, az, rel, ik, E, phi, beta, gk, h, Du, Dv, Dw, itp, newton,
                   S):
    """F(k) = f(Re_p) / T_p and the next k (safeguarded Newton, or a fixed-point update): (k,
    |F(k) - k| within S.tol k (S.tol_fp k), 1 / |slip|)."""
    irel = 1.0 / rel if rel > 0.0 else 0.0
    F = clift_factor(rp) * itp
    G = F - k
    kn = F
    lim = S.tol_fp
    if newton and rel > 0.0:
        # dF/dk = 0.15 * 0.687 Re^0.687 / (rel T_p) d|slip|/dk
        db = E * ((E - phi) * ik + h * E) - h * beta
        daz = (Dw - gk) * db - gk * ik * (1.0 - beta)
        drel = ((ax * Du + ay * Dv) * db + az * daz) * irel
        den = 1.0 - clift_slope(rp) * drel * irel * itp
        if den > 0.1:
            kt = k + G / den
            if kt > 0.0:
                kn = kt
                lim = S.tol
    return kn, abs(G) <= lim * k, irel


@ijit
def _drag_rate_update(k, em, h, ih, Du, Dv, Dw, itp, dnu, irelq, rpq, newton, S, first, exact):
    """One update of k towards k = F(k), em = expm1(-k h): (next k, within the tolerance,
    1 / |slip|, Re_p^0.687 for the next update, whether that is exact)."""
    ax, ay, az, rel, ik, E, phi, beta, gk = _slip_at(k, em, ih, Du, Dv, Dw, S.g)
    rp, ok = _re687_lane(rel, dnu, irelq, rpq, first, exact)
    kn, done, irel = _newton_update(k, rp, ax, ay, az, rel, ik, E, phi, beta, gk, h, Du, Dv, Dw,
                                    itp, newton, S)
    return kn, done, irel, rp, ok


@ijit
def _expm1_lane(k, h, kq, emq, first, e0, exact):
    """(expm1(-k h), whether exact) for an update: the estimate's first (``e0``: same k, h), then
    _expm1_near; vectorized, the usual path only, a lane off it left to the exact pass."""
    if exact:
        if first and e0:
            return emq, True
        return _expm1_near(k, h, kq, emq, True)
    if first:
        return emq, e0
    return _expm1_shift(k, h, kq, emq), kq > 0.0 and abs((kq - k) * h) <= _NEAR


@ijit
def _re687_lane(rel, dnu, irelq, rpq, first, exact):
    """((rel dnu)^0.687, whether exact) for an update (as _expm1_lane)."""
    if exact:
        return _re687_near(rel, dnu, irelq, rpq, True)
    if first:
        return pow_0687_table(rel * dnu)
    return _re687_shift(rel, irelq, rpq), irelq > 0.0 and abs(rel * irelq - 1.0) <= _NEAR


@ijit
def _lane_drag_update(lf, li, l, it, S, first, exact):
    """Update ``it`` of lane l's drag rate (as selects); 1 if it iterates on (_FIX: exact pass)."""
    going = li[_ITER + l] != 0
    k = lf[_K + l]
    h = lf[_H + l]
    kq = lf[_KQ + l]
    emq = lf[_EMQ + l]
    irelq = lf[_IRELQ + l]
    rpq = lf[_RPQ + l]
    em, ok1 = _expm1_lane(k, h, kq, emq, first, li[_E0 + l] != 0, exact)
    kn, done, irel, rp, ok2 = _drag_rate_update(k, em, h, lf[_IH + l], lf[_DU + l], lf[_DV + l],
                                                lf[_DW + l], lf[_ITP + l], lf[_DNU + l], irelq,
                                                rpq, it < NEWTON_MAXIT, S, first, exact)
    upd = going and ok1 and ok2
    lf[_K + l] = kn if upd else k
    lf[_KQ + l] = k if upd else kq
    lf[_EMQ + l] = em if upd else emq
    lf[_IRELQ + l] = irel if upd else irelq
    lf[_RPQ + l] = rp if upd else rpq
    li[_FIX + l] = 1 if (going and not upd) else 0
    stop = upd and done
    li[_ITER + l] = 0 if stop else li[_ITER + l]
    return 1 if (going and not stop) else 0


@ijit
def _drag_lanes(lf, li, nb, S):
    """The drag rates of lanes 0..nb-1 iterated in lockstep (on vector units)."""
    for it in range(DRAG_MAXIT):
        left = 0
        if it == 0:
            for l in range(nb):
                left += _lane_drag_update(lf, li, l, it, S, True, False)
        else:
            for l in range(nb):
                left += _lane_drag_update(lf, li, l, it, S, False, False)
        for l in range(nb):
            if li[_FIX + l] != 0:
                left -= 1 - _lane_drag_update(lf, li, l, it, S, it == 0, True)
        if left == 0:
            break


@ijit
def _drag_rate(k, h, Du, Dv, Dw, itp, dnu, S):
    """A drag rate at its fixed point, one parcel alone, with the last evaluation's k and expm1."""
    ih = 1.0 / h
    kq = -1.0
    emq = 0.0
    irelq = 0.0
    rpq = 0.0
    for it in range(DRAG_MAXIT):
        em, _ = _expm1_near(k, h, kq, emq, True)
        kn, done, irelq, rpq, _ = _drag_rate_update(k, em, h, ih, Du, Dv, Dw, itp, dnu, irelq,
                                                    rpq, it < NEWTON_MAXIT, S, it == 0, True)
        kq = k
        emq = em
        k = kn
        if done:
            break
    return k, kq, emq
