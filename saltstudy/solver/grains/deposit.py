"""What a grain gives the air over a sub-step: the momentum of its drag (the reaction, two-way
coupling) and the TKE its drag removes (the particle sink), deposited on the cells of its
stencil.
"""
from __future__ import annotations

import math

from .interp import LOG_LEVEL, ijit, pool_add_tri, slab_of


@ijit
def _reaction(mu_, mv_, mw_, Qm, un, vn, wn, up, vp, wp, h, S):
    """The air's impulse over h: -Q m_p (Delta u - g h) plus the modelled impulse."""
    return mu_ - Qm * (un - up), mv_ - Qm * (vn - vp), mw_ - Qm * (wn - wp + S.g * h)


@ijit
def _reaction_to_air(O, st, ru, rv, rw, S, nx, ny):
    """Two-way: the air's impulse deposited with the weights of Stencil st."""
    if st.islog:
        kc = LOG_LEVEL
        fzc = 0.0
    else:
        kc = st.kc
        fzc = st.fzc
    pool_add_tri(O.pool, O.off, O.s, nx, ny, O.nk, ru, st.ixf, st.fxf, st.jyc, st.fyc, kc, fzc)
    pool_add_tri(O.pool, O.off + O.csz, O.s, nx, ny, O.nk, rv, st.ixc, st.fxc, st.jyf, st.fyf,
                 kc, fzc)
    pool_add_tri(O.pool, O.off + 2 * O.csz, O.s, nx, ny, O.nk, rw, st.ixc, st.fxc, st.jyc,
                 st.fyc, st.kf, st.fzf)


@ijit
def _tke_level(st):
    """The level whose TKE sink a parcel feeds: its cell's, LOG_LEVEL in the log region."""
    return LOG_LEVEL if st.islog else st.kcell


@ijit
def _tke_rate(e, tlc_k, Qm, k, tp, h, S):
    """The parcel's share of its cell's TKE-sink rate over h / dt of the step (0 where e <= 0)."""
    tl = tlc_k / math.sqrt(e)
    r = Qm / S.rho * 2.0 * (k * tp) / (tp + tl) * (h / S.dt)
    return r if e > 0.0 else 0.0


@ijit
def _tke_to_air(O, st, rate, S, nx, ny):
    """The TKE-sink rate deposited on the parcel's cell (_tke_level)."""
    kcell = _tke_level(st)
    kk = kcell if kcell < O.nk else O.nk - 1
    O.pool[O.off + ((O.ct * O.L + slab_of(st.ixf, O.s, nx)) * ny + st.jyf) * O.nk + kk] += rate


@ijit
def _to_air(O, F, st, mu_, mv_, mw_, qm, un, vn, wn, up, vp, wp, k, tp, h, S, nx, ny):
    """A sub-step's exchange with the air, one parcel alone: reaction and TKE sink."""
    if S.twoway:
        ru, rv, rw = _reaction(mu_, mv_, mw_, qm, un, vn, wn, up, vp, wp, h, S)
        _reaction_to_air(O, st, ru, rv, rw, S, nx, ny)
    if S.tke:
        kt = _tke_level(st)
        rate = _tke_rate(F.e[st.ixf, st.jyf, kt], F.tlc[kt], qm, k, tp, h, S)
        _tke_to_air(O, st, rate, S, nx, ny)
