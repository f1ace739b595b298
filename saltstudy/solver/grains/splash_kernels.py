"""Splash at the bed (paper section 2.3, eqs. 5-9) as serial numba kernels drawing from a numpy Generator.

All random draws of the grain component happen here, in serial loops, in a fixed order, so a run is
reproducible bit for bit (the Generators' ``bit_generator.state`` is checkpointed) and independent
of the number of threads. The impacts of a step are split into a fixed number of runs of
consecutive impacts (``ejecta_reserve``), each splashed by ``bed_events`` with its own Generator
and its own stretch of the parcel arrays, so the runs go in parallel (``splash_runs``) and the
result does not depend on how many threads there are.

Reading of section 2.3 (documented choice). "When a particle reaches the lower 0.5 mm layer ... [it]
is assumed to rebound, eject other particles, or deposit on the surface following its velocity."
The rebound is a Bernoulli draw with P_reb (eq. 6); "the rebounding particle can also eject other
particles", with N_ej (eq. 8) a function of v_imp only. We read the ejection as independent of the
rebound (as in Kok & Renno 2009, whose scheme the paper follows): *every* impact ejects
N_ej grains on average, whether the impactor rebounds or deposits. So an impact has one of four
outcomes: rebound, rebound + ejecta, deposit, deposit + ejecta.

Draws per impact, in this order:

1. rebound ~ Bernoulli(P_reb), P_reb = p_max (1 - exp(-gamma_reb v_imp))               (eq. 6)
2. if rebound: v_reb ~ N(0.6 v_imp, 0.25 v_imp) redrawn while negative               (eq. 7)
   alpha_v ~ N(30 deg, 15 deg) redrawn outside (0, 180) deg (the grain must leave the bed),
   alpha_h ~ N(0, 10 deg) relative to the impactor's horizontal direction of motion
3. N_ej = floor(nbar) + Bernoulli(nbar - floor(nbar)), nbar = a v_imp / sqrt(g <d_p>)  (eq. 8)
   (stochastic rounding: E[N_ej] = nbar exactly). The paper gives N_ej as "the number of newly
   ejected particles" without saying how it becomes whole; ``splash.ejection_rounding`` also
   offers the floor and the nearest integer (no draw), which eject nothing below
   1 / (a / sqrt(g <d>)) (1.48 m/s for 200 um) and half that
4. per ejectum: d from the soil (eq. 5), v_ej ~ Exp(mean 0.08 v_imp)                   (eq. 9)
   alpha_v ~ N(60, 15) deg redrawn outside (0, 180), alpha_h ~ N(0, 10) deg

Soil diameters (eq. 5): pick mode j with probability m_j, then d = mu_j exp(ln(sigma_j) xi),
xi ~ N(0, 1). Eq. 5 is a *mass* size distribution (dM/dln d); the paper draws ejecta "from the
multimodal mass size distribution of the soil", i.e. a parcel's diameter is distributed like the
soil's mass, not like its grain count (the count median would be mu_j exp(-3 ln^2 sigma_j), 10%
smaller for sigma = 1.2). We follow the paper.

The rebound and the ejecta start at the impact point, on the impact layer, and are integrated for
the rest of the step by the caller. With ``splash.detection_step`` dt_d > 0 the bed is met as a
code stepping by dt_d meets it: a grain that crossed the layer's top is found |w| U dt_d below it
(U uniform), its rebound and ejecta start there, and one that is not above the top after the next
dt_d (w_launch dt_d < depth) is left inside, where the next step splashes it again at its launch
velocity (the particle kernel splashes a grain found inside the layer before moving it).

Readings where the text is silent (config.Splash): ``impact_speed = "normal"`` gives eqs. 6 and 8
the normal impact speed |w| instead of |u_p| (eqs. 7 and 9 keep |u_p|); ``launch_height = "bed"``
launches the rebound and the ejecta from z = 0: each rises through the layer under gravity to its
top, or, if it cannot, is left at the top of its hop inside the layer, where the next step splashes
it at its speed there (_rise_from_bed).

The impact record (``ImpactLog``): every impact is counted by its speed and its angle to the bed
(``impact_hist``), with the rebounds and ejecta it gave (``impact_outcomes``: the replacement number
against impact speed), and, when the grain was launched at a known time and place (by a rebound
or an ejection; released and entrained grains are not), the hop that ended there: its flight time
and its streamwise length (``hop_time_hist``, ``hop_length_hist``). Counts only; the bins are the
``*_BIN`` constants below.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import prange

from ..._jit import jit, jit_borrow, pjit
from ...physics.splash import ejection_number_mean, rebound_probability

__all__ = ["splash_params", "soil_arrays", "draw_diameter", "draw_rebound", "draw_n_ejecta",
           "draw_ejectum", "bed_events", "ejecta_reserve", "splash_runs", "sample_impacts",
           "SP_IMPACT_LAYER", "SP_G", "SP_DMEAN", "SP_RHO_P", "ImpactLog", "EN_IMPACT", "EN_SPLASH",
           "EN_PX_IN", "EN_PX_OUT", "EN_PZ_IN", "EN_PZ_OUT", "N_EN", "impact_log_arrays",
           "IMPACT_SPEED_BIN", "N_SPEED_BINS", "IMPACT_ANGLE_BIN", "N_ANGLE_BINS", "HOP_TIME_BIN",
           "HOP_LENGTH_BIN", "N_HOP_BINS", "NO_LAUNCH"]

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
#: launch time of a grain not launched from the bed by a splash (released, entrained)
NO_LAUNCH = -1.0e30

#: what ``bed_events`` records of each impact (module doc): per-parcel launch time ``tl`` [s] and
#: place ``xl``, ``yl`` [m]; counts ``hist`` (speed bin, angle bin), ``outc`` (speed bin,
#: [impacts, rebounds, ejecta]), ``hop_t``, ``hop_l``; ``prm`` = [time at the end of the step,
#: Lx, Ly]
ImpactLog = namedtuple("ImpactLog", "tl xl yl hist outc hop_t hop_l prm")


def impact_log_arrays(runs: int):
    """Zeroed counts (hist, outc, hop_t, hop_l), one slab per run of impacts."""
    return (np.zeros((runs, N_SPEED_BINS, N_ANGLE_BINS), dtype=np.int64),
            np.zeros((runs, N_SPEED_BINS, 3), dtype=np.int64),
            np.zeros((runs, N_HOP_BINS), dtype=np.int64),
            np.zeros((runs, N_HOP_BINS), dtype=np.int64))

# indices into the splash parameter vector
SP_PMAX, SP_GAMMA, SP_REB_M, SP_REB_S, SP_RAV_M, SP_RAV_S, SP_RAH_M, SP_RAH_S = range(8)
SP_A, SP_EJ_M, SP_EAV_M, SP_EAV_S, SP_EAH_M, SP_EAH_S, SP_IMPACT_LAYER, SP_G, SP_DMEAN, SP_RHO_P = range(8, 18)
SP_EJ_ROUND = 18
SP_DETECT = 19
SP_NORMAL = 20  # 1: eqs. 6 and 8 take the normal impact speed |w| (config.Splash.impact_speed)
SP_FROM_BED = 21  # 1: rebounds and ejecta leave from the bed (config.Splash.launch_height)
#: what ``bed_events`` adds up per run in ``en`` (float64): kinetic energy of the impacting and of
#: the rebounding and ejected real grains [J]; streamwise momentum [kg m s^-1] brought to the bed
#: by the impacts and taken from it by the launches; vertical momentum likewise (|w| of the
#: impacts, w of the launches). (in - out) / (area time) is the stress the grains carry to the
#: bed and the bed's vertical impulse per unit area and time (the layer's momentum balance)
EN_IMPACT, EN_SPLASH, EN_PX_IN, EN_PX_OUT, EN_PZ_IN, EN_PZ_OUT = range(6)
N_EN = 6
#: how eq. 8's N_ej becomes a whole number of ejected parcels (config.Splash.ejection_rounding),
#: coded in the parameter vector: stochastic rounding, the floor, the nearest integer
EJECTION_ROUNDING = {"stochastic": 0.0, "floor": 1.0, "nearest": 2.0}


def splash_params(splash, soil, g: float) -> np.ndarray:
    """Pack the splash constants (config.Splash, angles to radians) and soil scalars for the kernels."""
    r = math.radians
    return np.array([
        splash.p_reb_max, splash.gamma_reb, splash.reb_speed_mean, splash.reb_speed_std,
        r(splash.reb_angle_v_mean), r(splash.reb_angle_v_std), r(splash.reb_angle_h_mean),
        r(splash.reb_angle_h_std), splash.a_ej, splash.ej_speed_mean, r(splash.ej_angle_v_mean),
        r(splash.ej_angle_v_std), r(splash.ej_angle_h_mean), r(splash.ej_angle_h_std),
        splash.impact_layer, g, soil.mean_diameter, soil.rho_p,
        EJECTION_ROUNDING[splash.ejection_rounding], splash.detection_step,
        1.0 if splash.impact_speed == "normal" else 0.0,
        1.0 if splash.launch_height == "bed" else 0.0,
    ], dtype=np.float64)


def soil_arrays(soil) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(cumulative mass fractions, mu_j, ln sigma_j) of the soil modes (eq. 5)."""
    m = np.array([mo.mass_fraction for mo in soil.modes], dtype=np.float64)
    cum = np.cumsum(m) / m.sum()
    cum[-1] = 1.0
    mu = np.array([mo.mu for mo in soil.modes], dtype=np.float64)
    lns = np.log(np.array([mo.sigma for mo in soil.modes], dtype=np.float64))
    return cum, mu, lns


@jit
def draw_diameter(rng, cum, mu, lnsig) -> float:
    """A diameter from the multimodal lognormal mass-size distribution (eq. 5), see module doc."""
    j = 0
    if cum.shape[0] > 1:
        r = rng.random()
        while j < cum.shape[0] - 1 and r >= cum[j]:
            j += 1
    return mu[j] * math.exp(lnsig[j] * rng.normal(0.0, 1.0))


@jit
def _angle(rng, mean, std):
    """Normal angle redrawn until it lies in (0, pi): the grain leaves the bed upwards."""
    for _ in range(1000):
        a = rng.normal(mean, std)
        if 0.0 < a < math.pi:
            return a
    return mean


@jit
def draw_rebound(rng, v_law, v_imp, sp):
    """Rebound draw (eqs. 6-7): (rebounds, v_reb, alpha_v, alpha_h) with angles in radians;
    ``v_law`` is the speed eq. 6 takes (config.Splash.impact_speed), ``v_imp`` the impact speed
    that eq. 7 scales."""
    p = rebound_probability(v_law, sp[SP_PMAX], sp[SP_GAMMA])
    if rng.random() >= p:
        return False, 0.0, 0.0, 0.0
    vr = -1.0
    for _ in range(1000):
        vr = rng.normal(sp[SP_REB_M] * v_imp, sp[SP_REB_S] * v_imp)
        if vr >= 0.0:
            break
    if vr < 0.0:
        vr = 0.0
    av = _angle(rng, sp[SP_RAV_M], sp[SP_RAV_S])
    ah = rng.normal(sp[SP_RAH_M], sp[SP_RAH_S])
    return True, vr, av, ah


@jit
def draw_n_ejecta(rng, v_law, sp) -> int:
    """N_ej of eq. 8, a v_imp / sqrt(g <d>), as a whole number: by stochastic rounding (its mean
    is eq. 8's; one uniform draw), its floor or the nearest integer (no draw), as
    ``sp[SP_EJ_ROUND]`` says (config.Splash.ejection_rounding); v_law: the speed eq. 8 takes."""
    nbar = ejection_number_mean(v_law, sp[SP_A], sp[SP_G], sp[SP_DMEAN])
    n0 = int(math.floor(nbar))
    mode = sp[SP_EJ_ROUND]
    if mode == 1.0:
        return n0
    if mode == 2.0:
        return n0 + 1 if nbar - n0 >= 0.5 else n0
    if rng.random() < nbar - n0:
        n0 += 1
    return n0


@jit
def draw_ejectum(rng, v_imp, sp):
    """(v_ej, alpha_v, alpha_h) of one ejected grain (eq. 9 and the ejection angles)."""
    ve = rng.exponential(sp[SP_EJ_M] * v_imp)
    av = _angle(rng, sp[SP_EAV_M], sp[SP_EAV_S])
    ah = rng.normal(sp[SP_EAH_M], sp[SP_EAH_S])
    return ve, av, ah


@jit
def _launch(speed, av, phi):
    """Velocity of a grain leaving the bed at speed, elevation av, heading phi (radians)."""
    c = speed * math.cos(av)
    return c * math.cos(phi), c * math.sin(phi), speed * math.sin(av)


@jit
def _ejecta_max(up, vp, wp, sp):
    """The most ejecta an impact at velocity (up, vp, wp) can draw: floor(nbar) + 1 (eq. 8)."""
    v_imp = math.sqrt(up * up + vp * vp + wp * wp)
    return int(math.floor(ejection_number_mean(v_imp, sp[SP_A], sp[SP_G], sp[SP_DMEAN]))) + 1


@jit_borrow
def ejecta_reserve(ev, n_ev, u, v, w, sp, lo, res):
    """Split the impacts ev[:n_ev] into ``res.shape[0]`` runs of consecutive entries (run r is
    ev[lo[r]:lo[r+1]], lo[r] = r n_ev // runs) and give each the most ejecta its impacts can
    draw: res[r] = sum over them of floor(nbar) + 1 (eq. 8, stochastic rounding)."""
    nr = res.shape[0]
    for r in range(nr + 1):
        lo[r] = (r * n_ev) // nr
    for r in range(nr):
        m = 0
        for i in range(lo[r], lo[r + 1]):
            p = ev[i]
            m += _ejecta_max(u[p], v[p], w[p], sp)
        res[r] = m


@jit_borrow
def _bin(value, width, n):
    """Index of the bin of ``value`` [0, n): bins of ``width`` from 0, the ends open."""
    b = int(value / width) if value > 0.0 else 0
    return b if b < n else n - 1


@jit_borrow
def _record_impact(L, r, p, up, vp, wp, v_imp, x, y, tr):
    """Count an impact of run r in the log (module doc); the hop it ends if its launch is known."""
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
def _depth_found(rng, z_p, w_p, h_imp, dstep):
    """How far below the impact layer's top [m] a grain is when a code stepping by ``dstep``
    finds it there: a grain still inside from an earlier splash is where it is; one that has just
    crossed is found at the end of the step in which it crossed, |w| U dstep deep, U uniform
    (where the crossing falls in that step). 0 with the crossing located exactly (dstep = 0)."""
    if dstep <= 0.0:
        return 0.0
    if z_p < h_imp:
        return h_imp - z_p
    return abs(w_p) * rng.random() * dstep


@jit_borrow
def _launch_height(w_l, depth, dstep, h_imp):
    """Height [m] a grain launched at vertical speed w_l from ``depth`` below the layer's top is
    found at the end of the next step of ``dstep``: above the top (it flies: launched from the
    top, as with the exact crossing), or still inside, where it is splashed again at its launch
    velocity in the next step."""
    if depth > 0.0 and w_l * dstep < depth:
        return h_imp - (depth - w_l * dstep)
    return h_imp


@jit
def _law_speed(v_imp, wp, sp):
    """The speed eqs. 6 and 8 take: the impact speed, or its normal component (SP_NORMAL)."""
    return abs(wp) if sp[SP_NORMAL] != 0.0 else v_imp


@jit_borrow
def _rise_from_bed(a, b, c, g, h_imp, x, y, Lx, Ly):
    """A grain launched from the bed at (a, b, c) rises through the impact layer under gravity
    (the drag over the ~1 ms in the layer is left out: k_p t < 0.01 for sand): if it reaches the
    top, its place and vertical speed there; if not, the top of its hop, where it is found inside
    the layer and meets the bed again in the next step at its speed there (the solver splashes a
    grain found inside the layer). Returns (x, y, z, w)."""
    c2 = c * c - 2.0 * g * h_imp
    if c2 > 0.0:
        wt = math.sqrt(c2)
        tr = (c - wt) / g
        xn = x + a * tr
        yn = y + b * tr
        return xn - Lx * math.floor(xn / Lx), yn - Ly * math.floor(yn / Ly), h_imp, wt
    ta = c / g
    xn = x + a * ta
    yn = y + b * ta
    return (xn - Lx * math.floor(xn / Lx), yn - Ly * math.floor(yn / Ly),
            min(0.5 * c * c / g, 0.999 * h_imp), 0.0)


@jit_borrow
def bed_events(rng, ev, n_ev, cursor, n, n_end, x, y, z, u, v, w, d, kd, flag, trem, dead, n_dead,
               sp, cum, mu, lnsig, Q, cnt, en, L, r):
    """Splash every parcel listed in ``ev[cursor:n_ev]`` (each sits on the impact layer with its
    impact velocity and ``trem`` seconds of the step left).

    Rebounding parcels are updated in place; ejecta are appended at index ``n`` (below
    ``n_end``); both carry the impactor's ``trem`` (integrated by the caller in the next step).
    Deposited parcels get ``flag = -1`` and are listed in ``dead``. ``cnt`` (int64: impacts,
    rebounds, ejections, depositions) and ``en`` (float64: impact and splash kinetic energy of the
    real grains, J) are incremented.

    Capacity: before an impact is drawn, room for its largest possible ejecta count is checked;
    if there is none (index ``n_end``) the kernel returns early, and the caller can make room and
    call again with the returned cursor (no draw is lost or repeated). Returns
    (cursor, n, n_dead). Each impact is recorded in the ImpactLog ``L`` (slab ``r``), and the
    rebound and the ejecta get its time and place as their launch; ``en`` adds up the energies
    and the momentum exchanged with the bed (``EN_*``; a launch from the bed counts its velocity
    there).
    """
    cap = n_end
    h_imp = sp[SP_IMPACT_LAYER]
    from_bed = sp[SP_FROM_BED] != 0.0
    g = sp[SP_G]
    Lx = L.prm[1]
    Ly = L.prm[2]
    for i in range(cursor, n_ev):
        p = ev[i]
        up = u[p]
        vp = v[p]
        wp = w[p]
        v2 = up * up + vp * vp + wp * wp
        v_imp = math.sqrt(v2)
        nmax = _ejecta_max(up, vp, wp, sp)
        if n + nmax > cap:
            return i, n, n_dead
        mp = math.pi / 6.0 * sp[SP_RHO_P] * d[p] ** 3
        cnt[0] += 1
        en[EN_IMPACT] += Q * 0.5 * mp * v2
        en[EN_PX_IN] += Q * mp * up
        en[EN_PZ_IN] += Q * mp * abs(wp)
        v_law = _law_speed(v_imp, wp, sp)
        phi = math.atan2(vp, up) if (up != 0.0 or vp != 0.0) else 0.0
        xp = x[p]
        yp = y[p]
        tr = trem[p]
        depth = _depth_found(rng, z[p], wp, h_imp, sp[SP_DETECT])
        iv, t_imp = _record_impact(L, r, p, up, vp, wp, v_imp, xp, yp, tr)
        reb, vr, av, ah = draw_rebound(rng, v_law, v_imp, sp)
        if reb:
            a, b, c = _launch(vr, av, phi + ah)
            en[EN_PX_OUT] += Q * mp * a
            en[EN_PZ_OUT] += Q * mp * c
            u[p] = a
            v[p] = b
            if from_bed:
                x[p], y[p], z[p], w[p] = _rise_from_bed(a, b, c, g, h_imp, xp, yp, Lx, Ly)
            else:
                w[p] = c
                z[p] = _launch_height(c, depth, sp[SP_DETECT], h_imp)
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
        nej = draw_n_ejecta(rng, v_law, sp)
        for _ in range(nej):
            q = n
            n += 1
            dq = draw_diameter(rng, cum, mu, lnsig)
            ve, av, ah = draw_ejectum(rng, v_imp, sp)
            a, b, c = _launch(ve, av, phi + ah)
            mq = math.pi / 6.0 * sp[SP_RHO_P] * dq ** 3
            en[EN_PX_OUT] += Q * mq * a
            en[EN_PZ_OUT] += Q * mq * c
            if from_bed:
                x[q], y[q], z[q], w[q] = _rise_from_bed(a, b, c, g, h_imp, xp, yp, Lx, Ly)
            else:
                x[q] = xp
                y[q] = yp
                z[q] = _launch_height(c, depth, sp[SP_DETECT], h_imp)
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
    """bed_events for each run r of impacts ev[lo[r]:lo[r+1]] (ejecta_reserve), in parallel, with
    the run's own Generator rngs[r]: its ejecta go to [base[r], base[r+1]), its dead list to
    dead[lo[r]:]; cnt[r], en[r] get its counts and energies and out[r] = (impacts done, end of
    its ejecta, dead count); run r counts its impacts in slab r of the ImpactLog L."""
    for r in prange(lo.shape[0] - 1):
        a = lo[r]
        b = lo[r + 1]
        cursor, end, nd = bed_events(rngs[r], ev[a:b], b - a, 0, base[r], base[r + 1], x, y, z, u,
                                     v, w, d, kd, flag, trem, dead[a:b], 0, sp, cum, mu, lnsig, Q,
                                     cnt[r], en[r], L, r)
        out[r, 0] = cursor
        out[r, 1] = end
        out[r, 2] = nd


@jit
def sample_impacts(rng, v_imp, d_imp, n_imp, sp, cum, mu, lnsig):
    """Statistics of ``n_imp`` impacts at speed ``v_imp`` by the same draws as ``bed_events``.

    Returns (n_rebounds, sum of v_reb, n_ejecta, sum of v_ej, sum of splash kinetic energy per
    impact normalised by the impact energy of a grain of diameter ``d_imp`` (<= 0: drawn from the
    soil for each impact)). For tests of eqs. 6-9 and of the energy budget.
    """
    nreb = 0
    svr = 0.0
    nej_tot = 0
    sve = 0.0
    ratio = 0.0
    for _ in range(n_imp):
        di = d_imp if d_imp > 0.0 else draw_diameter(rng, cum, mu, lnsig)
        m_imp = di ** 3
        e_out = 0.0
        reb, vr, av, ah = draw_rebound(rng, v_imp, v_imp, sp)
        if reb:
            nreb += 1
            svr += vr
            e_out += m_imp * vr * vr
        nej = draw_n_ejecta(rng, v_imp, sp)
        for _k in range(nej):
            dq = draw_diameter(rng, cum, mu, lnsig)
            ve, av, ah = draw_ejectum(rng, v_imp, sp)
            nej_tot += 1
            sve += ve
            e_out += dq ** 3 * ve * ve
        ratio += e_out / (m_imp * v_imp * v_imp)
    return nreb, svr, nej_tot, sve, ratio
