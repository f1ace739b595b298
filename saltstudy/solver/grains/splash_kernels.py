"""Splash at the bed (paper section 2.3, eqs. 5-9) as numba kernels drawing from numpy Generators.

physics.splash's and physics.soil's laws applied to the parcels that met the bed in a step, with
the books kept. Every draw happens in a serial loop in a fixed order: the impacts are split into
a fixed number of runs (``ejecta_reserve``), each splashed by ``bed_events`` with its own
Generator and stretch of the parcel arrays, in parallel (``splash_runs``): bit for bit the same
whatever the thread count. Every impact ejects N_ej grains on average, whether the impactor
rebounds or deposits; rebound and ejecta start at the impact point on the impact layer.

The impact record (``ImpactLog``, counts): each impact by speed and angle (``impact_hist``) with
the rebounds and ejecta it gave (``impact_outcomes``), and for a grain launched by a splash the
hop that ended there, its flight time and streamwise length (``hop_time_hist``,
``hop_length_hist``).
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import prange

from ..._jit import jit_borrow, pjit
from ...physics.splash import (SP_IMPACT_LAYER, SP_RHO_P, draw_ejectum, draw_impact, ejecta_max,
                               launch_velocity, law_speed)

#: impact speed bins [m s^-1]: [i, i+1) x IMPACT_SPEED_BIN, the last bin open above
IMPACT_SPEED_BIN = 0.1
N_SPEED_BINS = 80
#: impact angle to the bed [deg], bins of IMPACT_ANGLE_BIN from 0 to 90
IMPACT_ANGLE_BIN = 2.0
N_ANGLE_BINS = 45
#: hop flight time [s] and streamwise length [m] bins, the last bin open above (a length below
#: zero, a grain blown back, counts in the first bin)
HOP_TIME_BIN = 0.005
HOP_LENGTH_BIN = 0.01
N_HOP_BINS = 300
#: launch time of a grain not launched from the bed by a splash (released)
NO_LAUNCH = -1.0e30

#: what ``bed_events`` records of each impact: per-parcel launch time ``tl`` [s] and place
#: ``xl``, ``yl`` [m]; counts ``hist`` (speed bin, angle bin), ``outc`` (speed bin, [impacts,
#: rebounds, ejecta]), ``hop_t``, ``hop_l``; ``prm`` = [time at the end of the step, Lx, Ly]
ImpactLog = namedtuple("ImpactLog", "tl xl yl hist outc hop_t hop_l prm")
#: the record's names in samples.nc, for (hist, outc, hop_t, hop_l)
IMPACT_RECORD = ("impact_hist", "impact_outcomes", "hop_time_hist", "hop_length_hist")


def impact_log_arrays(runs: int):
    """Zeroed counts (hist, outc, hop_t, hop_l), one slab per run of impacts."""
    return (np.zeros((runs, N_SPEED_BINS, N_ANGLE_BINS), dtype=np.int64),
            np.zeros((runs, N_SPEED_BINS, 3), dtype=np.int64),
            np.zeros((runs, N_HOP_BINS), dtype=np.int64),
            np.zeros((runs, N_HOP_BINS), dtype=np.int64))


#: what ``bed_events`` adds up per run in ``en``: kinetic energy of the impacting and of the
#: launched real grains [J]; streamwise momentum [kg m s^-1] brought to the bed by the impacts
#: and taken by the launches; vertical momentum likewise (|w| in, w out)
EN_IMPACT, EN_SPLASH, EN_PX_IN, EN_PX_OUT, EN_PZ_IN, EN_PZ_OUT = range(6)
N_EN = 6


@jit_borrow
def ejecta_reserve(ev, n_ev, u, v, w, sp, lo, res):
    """Split the impacts into runs ev[lo[r]:lo[r+1]], each with room for its most ejecta."""
    nr = res.shape[0]
    for r in range(nr + 1):
        lo[r] = (r * n_ev) // nr
    for r in range(nr):
        m = 0
        for i in range(lo[r], lo[r + 1]):
            p = ev[i]
            m += ejecta_max(math.sqrt(u[p] * u[p] + v[p] * v[p] + w[p] * w[p]), sp)
        res[r] = m


@jit_borrow
def _bin(value, width, n):
    """Index of the bin of ``value`` [0, n): bins of ``width`` from 0, the ends open."""
    b = int(value / width) if value > 0.0 else 0
    return b if b < n else n - 1


@jit_borrow
def _record_impact(L, r, p, up, vp, wp, v_imp, x, y, tr):
    """Count an impact of run r in the log, and the hop it ends if its launch is known."""
    vh = math.sqrt(up * up + vp * vp)
    angle = math.degrees(math.atan2(-wp, vh)) if (vh > 0.0 or wp != 0.0) else 0.0
    iv = _bin(v_imp, IMPACT_SPEED_BIN, N_SPEED_BINS)
    L.hist[r, iv, _bin(angle, IMPACT_ANGLE_BIN, N_ANGLE_BINS)] += 1
    L.outc[r, iv, 0] += 1
    t_imp = L.prm[0] - tr
    t0 = L.tl[p]
    if t0 > NO_LAUNCH:
        Lx = L.prm[1]
        dxh = x - L.xl[p]
        dxh -= Lx * math.floor(dxh / Lx + 0.5)    # the shorter way round the periodic domain
        L.hop_t[r, _bin(t_imp - t0, HOP_TIME_BIN, N_HOP_BINS)] += 1
        L.hop_l[r, _bin(dxh, HOP_LENGTH_BIN, N_HOP_BINS)] += 1
    return iv, t_imp


@jit_borrow
def bed_events(rng, ev, n_ev, cursor, n, n_end, x, y, z, u, v, w, d, kd, flag, trem, dead, n_dead,
               sp, cum, mu, lnsig, Q, cnt, en, L, r):
    """Splash the parcels ``ev[cursor:n_ev]`` (on the impact layer, ``trem`` of the step left):
    rebounds in place, ejecta from ``n``, both launched at the impact's time and place; the
    deposited get flag -1 and go to ``dead``; ``cnt``, ``en`` and slab ``r`` of ``L`` count. Out
    of room for the most ejecta of an impact it returns early. Returns (cursor, n, n_dead)."""
    cap = n_end
    h_imp = sp[SP_IMPACT_LAYER]
    for i in range(cursor, n_ev):
        p = ev[i]
        up = u[p]
        vp = v[p]
        wp = w[p]
        v2 = up * up + vp * vp + wp * wp
        v_imp = math.sqrt(v2)
        if n + ejecta_max(v_imp, sp) > cap:
            return i, n, n_dead
        mp = math.pi / 6.0 * sp[SP_RHO_P] * d[p] ** 3
        cnt[0] += 1
        en[EN_IMPACT] += Q * 0.5 * mp * v2
        en[EN_PX_IN] += Q * mp * up
        en[EN_PZ_IN] += Q * mp * abs(wp)
        phi = math.atan2(vp, up) if (up != 0.0 or vp != 0.0) else 0.0
        xp = x[p]
        yp = y[p]
        tr = trem[p]
        iv, t_imp = _record_impact(L, r, p, up, vp, wp, v_imp, xp, yp, tr)
        reb, vr, av, ah, nej = draw_impact(rng, law_speed(v_imp, wp, sp), v_imp, sp)
        if reb:
            a, b, c = launch_velocity(vr, av, phi + ah)
            en[EN_PX_OUT] += Q * mp * a
            en[EN_PZ_OUT] += Q * mp * c
            u[p] = a
            v[p] = b
            w[p] = c
            z[p] = h_imp
            kd[p] = 0.0  # velocity jumped: the drag rate is re-estimated from scratch
            flag[p] = 0
            L.tl[p] = t_imp
            L.xl[p] = xp
            L.yl[p] = yp
            L.outc[r, iv, 1] += 1
            cnt[1] += 1
            en[EN_SPLASH] += Q * 0.5 * mp * vr * vr
        else:
            flag[p] = -1
            dead[n_dead] = p
            n_dead += 1
            cnt[3] += 1
        for _ in range(nej):
            q = n
            n += 1
            dq, ve, av, ah = draw_ejectum(rng, v_imp, sp, cum, mu, lnsig)
            a, b, c = launch_velocity(ve, av, phi + ah)
            mq = math.pi / 6.0 * sp[SP_RHO_P] * dq ** 3
            en[EN_PX_OUT] += Q * mq * a
            en[EN_PZ_OUT] += Q * mq * c
            x[q] = xp
            y[q] = yp
            z[q] = h_imp
            w[q] = c
            u[q] = a
            v[q] = b
            d[q] = dq
            kd[q] = 0.0
            flag[q] = 0
            trem[q] = tr
            L.tl[q] = t_imp
            L.xl[q] = xp
            L.yl[q] = yp
            L.outc[r, iv, 2] += 1
            cnt[2] += 1
            en[EN_SPLASH] += Q * 0.5 * mq * ve * ve
    return n_ev, n, n_dead


@pjit
def splash_runs(rngs, ev, lo, base, x, y, z, u, v, w, d, kd, flag, trem, dead, sp, cum, mu, lnsig,
                Q, cnt, en, out, L):
    """bed_events of each run r, ev[lo[r]:lo[r+1]], in parallel: its Generator, its ejecta in
    [base[r], base[r+1]), dead from dead[lo[r]]; out[r] = (impacts done, ejecta end, dead)."""
    for r in prange(lo.shape[0] - 1):
        a = lo[r]
        b = lo[r + 1]
        cursor, end, nd = bed_events(rngs[r], ev[a:b], b - a, 0, base[r], base[r + 1], x, y, z, u,
                                     v, w, d, kd, flag, trem, dead[a:b], 0, sp, cum, mu, lnsig, Q,
                                     cnt[r], en[r], L, r)
        out[r, 0] = cursor
        out[r, 1] = end
        out[r, 2] = nd
