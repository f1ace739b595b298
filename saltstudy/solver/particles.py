"""The saltation component: Lagrangian parcels of sand grains (paper sections 2.1-2.4).

Each parcel stands for ``Q = scene.Q`` real grains of one diameter. Parcels live in a struct of
arrays (``x, y, z, u, v, w, d`` plus the drag-rate warm start ``kd``, a status ``flag`` and the time
left in the step ``trem``) that grows by doubling; only the first ``n`` entries are alive. Periodic
in x and y (positions wrapped by ``x - Lx floor(x / Lx)``, right for any displacement).

Equation of motion (eqs. 3-4)::

    du_p/dt = k_p (u_s - u_p) + g,    k_p = f(Re_p) / T_p,   T_p = rho_p d^2 / (18 rho nu),
    f(Re_p) = 1 + 0.15 Re_p^0.687 (Clift et al. 1978),        g = (0, 0, -g)

integrated *exactly* over a (sub)step h with k_p and the seen fluid velocity u_s frozen::

    u(h) = u_t + (u_p - u_t) E,   x(h) = x_p + u_t h + (u_p - u_t)(1 - E)/k_p,
    u_t = u_s + g / k_p,          E = exp(-k_p h)

so a grain with T_p << h is stable and lands on its terminal velocity. k_p is evaluated at the
slip ``E * (mean slip over the step) + (1 - E) * (end-of-step slip)`` of the frozen-k solution, by a
fixed-point iteration warm-started from the previous step (tolerance ``DRAG_TOL``). For
k_p h << 1 this is the step-mean slip (second order in h); for k_p h >> 1 it is the end slip, and
then a grain falling from rest cannot overshoot its terminal velocity whatever h / T_p (if the end
slip exceeded the terminal slip, k_p would exceed its terminal value and the end slip would fall
short of it); it lands on the root of f(Re) w = g T_p to the iteration tolerance.
The fixed point k = F(k) is found by safeguarded Newton (dF/dk is analytic: no extra
transcendental per iteration; plain fixed-point updates if Newton would leave (0, inf) or F is
not contracting), stopped when ``|F(k) - k| <= DRAG_TOL k``; the last Newton update is then
applied, so k is accurate to about DRAG_TOL^2 (a plain fixed-point update must meet DRAG_TOL^2
itself; typically two evaluations of F).

Sub-steps: a parcel is sub-stepped so that it moves at most one local cell height per sub-step
(re-interpolating the fluid velocity), at most ``MAX_SUBSTEPS`` per step. A parcel that crosses the
impact layer (z = ``splash.impact_layer``, 0.5 mm) is stopped at the crossing, found by safeguarded
Newton on the analytic z(t); it then splashes (:mod:`splash_kernels`). The rebound and the ejecta
start at the impact point with the rest of the step as a time credit and are integrated over
``dt + credit`` in the next step, inside that step's implicit exchange (integrating them at once
would exchange their momentum explicitly, which is unstable for small grains at high loading). A parcel reaching the lid
is reflected (it does not happen at the cases' heights).

Fluid velocity at a parcel: trilinear on the staggered grid, log law from the second level near
the bed: in the whole first cell with the drag going back to the second level (the paper's [12],
``particles.near_bed_wind = "paper"``) or below the first level only (``"blend"``), see
:mod:`interp`. Two-way coupling, the point-implicit exchange and the TKE sink: :mod:`coupling`.

Work split: the per-parcel integration is ``prange``-parallel over a fixed number of chunks with
chunk-private deposit buffers (race-free, and reductions in a fixed order, so results do not
depend on the numba thread count). The bed events are split into a fixed number of runs of
consecutive impacts, each with its own random stream, splashed in parallel
(splash_kernels.splash_runs); the other random draws (release, SGS velocity, entrainment) are in
serial kernels on the component's main stream. A chunk is a run of x-slabs with about
n / N_CHUNKS parcels (processed in index order), so its buffers cover only those slabs plus a
margin (coupling.py), and only the levels parcels can reach within the step; the buffers persist
across steps. The per-parcel code is inlined (interp.py ``ijit``) into a serial per-chunk loop
(``_advance_chunk``: blocks of parcels in passes over the block, the branch-free ones vectorized
by LLVM; see the comment above ``_wind_seen``) called from the prange. Two-way, the modelled
impulse of the implicit estimate and the first sub-step's drag impulse share their weights and
are deposited as one value; the advance recomputes the estimate's coefficients from the same
inputs (coupling.implicit_estimate), so nothing per parcel is kept between the two passes. A
step has few parallel regions (chunk assignment, the estimate, its solve, the advance, the bed
events, the air's update), and each runs on all the numba threads or on one, whichever its
recent calls ran faster (``Threads``): on a machine shared with other jobs a region first
waits for its worker threads to get a core, milliseconds, more than a region's work at 10^5
parcels. The results are the same either way.

Optional processes (off by default, not constructed when off):

* ``physics.sgs_particle_velocity``: the seen velocity gets a stochastic SGS part, an
  Ornstein-Uhlenbeck process per parcel with variance (2/3) e and time scale T_L (same T_L as the
  TKE sink), ``u' <- R u' + sqrt(1 - R^2) sqrt(2e/3) xi``, ``R = exp(-dt / T_L)`` - a simplified
  form of the Vinkovic et al. (2006) model the paper cites (isotropic, no drift correction).
* ``physics.aerodynamic_entrainment``: in each surface cell where the local surface stress
  tau_s = rho (kappa U_1 / ln(z_c0 / z0))^2 exceeds tau_t = rho u*t^2 (Shao & Lu 2000, with <d>),
  grains are lifted at the rate N_a = zeta (tau_s - tau_t) [grains m^-2 s^-1] (the excess-stress
  form of Anderson & Haff 1991, also used by Kok & Renno 2009). ``ENTRAINMENT_ZETA`` = 1e5
  grains N^-1 s^-1 is an order-of-magnitude value, not verified against the sources: tune it. Parcels
  (rate * area * dt / Q, stochastically rounded) start on the impact layer at a random point of the
  cell, straight up at the local u*, diameters from the soil.
"""
from __future__ import annotations

import json
import math
import time
from collections import namedtuple

import numba
import numpy as np
from numba import prange

from .._jit import jit, jit_borrow, pjit
# (the parallel kernels are called by name through Threads)
from .coupling import (EST_LANES, EST_ROWS_F, EST_ROWS_I, N_CHUNKS, Flow, Parcels, air_maxima,
                       apply_exchange, chunk_assign, chunk_ranges, estimate_weights,  # noqa: F401
                       face_inverse_masses, implicit_coefficients,  # noqa: F401
                       implicit_corrections, lagrangian_time_coefficients,  # noqa: F401
                       parcel_weight)
from .elementary import (CLIFT_EXPONENT, EXPM1_TAYLOR_MAX, binomial_coefficients, expm1_small,
                         expm1_taylor, pow_0687, pow_0687_table)
from .grid import Grid
from .interp import (GEO_LOG_LEVEL, GEO_LOG_READ, GridGeometry, Stencil, _bil, _tri, ijit,
                     interp_fluid, level_of, locate, pool_add_tri, slab_of, wrap_index,
                     wrap_periodic)
from .splash_kernels import (EN_IMPACT, EN_PX_IN, EN_PX_OUT, EN_PZ_IN, EN_PZ_OUT, EN_SPLASH, N_EN,
                             NO_LAUNCH, ImpactLog, draw_diameter, ejecta_reserve,
                             impact_log_arrays, soil_arrays, splash_params,
                             splash_runs)  # noqa: F401
from .state import FlowState

__all__ = ["Saltation", "DRAG_TOL", "MAX_SUBSTEPS", "RNG_SPAWN_KEY",
           "ENTRAINMENT_ZETA"]

#: stop of the end-of-step drag-rate iteration: |F(k) - k| <= DRAG_TOL k before a Newton update
#: (its error is then ~DRAG_TOL^2: bench steps agree with a 1e-12 tolerance to 1e-13 m/s), or
#: <= DRAG_TOL^2 k before a plain fixed-point update
DRAG_TOL = 1e-3
DRAG_MAXIT = 40
#: Newton updates of the drag-rate iteration at most (then plain fixed-point updates)
NEWTON_MAXIT = 12
#: sub-steps per step at most (a parcel then moves more than a cell height in a sub-step)
MAX_SUBSTEPS = 16
#: parcels advanced together (in lockstep passes) by _advance_chunk (its lane rows: below)
_LANES = 64
#: the grains' main random stream: SeedSequence(case.seed, spawn_key=(RNG_SPAWN_KEY,)), distinct
#: from any stream the flow derives from the same seed with another key
RNG_SPAWN_KEY = 0x5A17
#: Anderson & Haff (1991) excess-stress entrainment coefficient [grains N^-1 s^-1] (see doc)
ENTRAINMENT_ZETA = 1.0e5
#: the impacts of a step are splashed in this many runs, each with its own random stream
#: SeedSequence(case.seed, spawn_key=(RNG_SPAWN_KEY, SPLASH_STREAM, run)); fixed, not the thread
#: count, so that a run is bit-for-bit the same with any number of threads
N_SPLASH_RUNS = 4
SPLASH_STREAM = 1
#: parcels are reordered by cell every this many steps (cache locality of gathers and scatters)
SORT_INTERVAL = 10


class Threads:
    """The thread count of one of the step's parallel kernels, chosen per call: the numba
    threads or one, by their recent times per unit of work. The results do not depend on it
    (a fixed number of chunks and runs, each with its own buffers, stream and stretch; every
    sum in a fixed order; the same compiled code).

    Which is faster depends on the machine's load, not on the model: on a quiet machine the
    worker threads start at once and the threads win by up to their count; on a machine shared
    with other jobs a parallel region first waits for its workers to get a core (an empty
    4-iteration prange, 2 threads, load 4: median 8.0 ms over 2000 calls; with
    numba.set_num_threads(1) 3.6 us), more than the kernel's work at 10^5 parcels. Every
    ``EXPLORE``-th call takes the other count, so that a change of load is noticed; a kernel's
    first call in the process (its compilation or cache load) is not timed. The kernel is
    looked up by name in this module at each call (the bench's ``--phases`` wraps it there)."""

    EXPLORE = 32

    def __init__(self, kernel: str):
        self.kernel = kernel
        self.cost = [0.0, 0.0]  # recent seconds per unit of work, [all threads, one]; 0: untimed
        self.calls = 0
        self.seen = False

    def __call__(self, work: int, *args):
        self.calls += 1
        if self.cost[0] == 0.0 or self.cost[1] == 0.0:
            i = 0 if self.cost[0] == 0.0 else 1  # an untimed count first
        else:
            best = 0 if self.cost[0] <= self.cost[1] else 1
            i = best if self.calls % self.EXPLORE else 1 - best
        nt = numba.get_num_threads()
        if nt == 1:
            return globals()[self.kernel](*args)
        t0 = time.perf_counter()
        if i == 1:
            numba.set_num_threads(1)
            try:
                out = globals()[self.kernel](*args)
            finally:
                numba.set_num_threads(nt)
        else:
            out = globals()[self.kernel](*args)
        c = (time.perf_counter() - t0) / max(work, 1)
        if self.seen:
            self.cost[i] = c if self.cost[i] == 0.0 else 0.5 * (self.cost[i] + c)
        self.seen = True
        return out


#: the thread counts of the step's parallel kernels (work: parcels, impacts or grid columns)
_ASSIGN = Threads("chunk_assign")
_IMPLICIT = Threads("implicit_coefficients")
_CORRECT = Threads("implicit_corrections")
_ADVANCE = Threads("_advance_all")
_SPLASH = Threads("splash_runs")
_APPLY = Threads("apply_exchange")
_GATHER = Threads("_gather")

# indices of the kernels' parameter vector
_RHO, _NU, _G, _RHOP, _Q, _HIMP, _TOL, _LZ, _DT, _TWOWAY, _TKE, _SGS = range(12)


#: The drag-rate iteration evaluates exp(-k h) and Re_p^0.687 at arguments close to those of its
#: previous evaluation; there they are updated from the previous values by short series, exact to
#: round-off (truncation < 1e-19 relative), instead of new evaluations:
#: expm1(-k h) = em_q + E_q expm1((k_q - k) h) and Re^a = Re_q^a (1 + eps)^a (binomial series).
#: New evaluations are inlined too (elementary.py: no libm calls, which spill the registers).
_NEAR = 0.02
_X2, _X3, _X4, _X5, _X6, _X7, _X8, _X9 = (1.0 / math.factorial(i) for i in range(2, 10))

_B1, _B2, _B3, _B4, _B5, _B6, _B7, _B8, _B9, _B10 = binomial_coefficients(CLIFT_EXPONENT, 10)


@ijit
def _expm1_shift(k, h, kq, emq):
    """expm1(-k h) from emq = expm1(-kq h) by the series in x = (kq - k) h (exact to round-off
    for |x| <= _NEAR)."""
    x = (kq - k) * h
    t = x * (1.0 + x * (_X2 + x * (_X3 + x * (_X4 + x * (_X5 + x * (_X6 + x * (
        _X7 + x * (_X8 + x * _X9))))))))
    return emq + (1.0 + emq) * t


@ijit
def _re687_shift(rel, irelq, rpq):
    """(rel dnu)^0.687 from rpq = (relq dnu)^0.687 by the binomial series in e = rel / relq - 1
    (exact to round-off for |e| <= _NEAR); irelq = 1 / relq."""
    e = rel * irelq - 1.0
    return rpq * (1.0 + e * (_B1 + e * (_B2 + e * (_B3 + e * (_B4 + e * (_B5 + e * (
        _B6 + e * (_B7 + e * (_B8 + e * (_B9 + e * _B10))))))))))


@jit
def _crossing_time(z0, wt, a, k, h, zc, zh):
    """First t in [0, h] with z(t) = zc, given z(0) = z0 >= zc > z(h) = zh.

    z'' = -a k exp(-k t) keeps one sign: if the parcel starts upwards (w_p > 0, then a > 0 and z
    is concave) the crossing lies after the apex, where z is decreasing; otherwise z decreases
    from the start or is convex with z(h) < zc. Either way the root in the bracket is unique.

    Safeguarded Newton (bisection when a step leaves the bracket), started at the root of z's
    Taylor quadratic at 0 or at the apex (or of the chord), and stopped once the step is below
    1e-14 h or the next step's error, |z''| step^2 / (2 |z'|), would be below a tenth of that:
    2.5 evaluations per crossing on the bench's crossings (3.1 without the apex start). An exact
    zero of F ends it too: kept as a bracket end, it sent Newton's next point onto that end, out
    of the open bracket, and bisection then walked away from the root (10.8 evaluations on
    average, up to 55, before these changes)."""
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


# ---- the advance of one parcel, process by process (inlined into _advance_chunk) ----------------
# A block of up to _LANES parcels takes its first sub-step in passes over all its lanes. Where a
# parcel's work branches or reads the grid (locating it and reading the wind there; the
# deposits) the passes are scalar; between them, the step's coefficients, the drag rate's fixed
# point and the relaxation and move are loops without branches or calls, which LLVM vectorizes
# (8 lanes per instruction with AVX-512; the helpers' ``exact=False``). The few lanes whose
# arithmetic there needs libm (an argument beyond the inlined expm1's or Re^0.687's range) or a
# bed crossing are redone one at a time by the same helpers with ``exact=True`` (branches and
# libm allowed; the same formulas wherever both apply, equal to round-off: LLVM may contract the
# two differently, tests/test_particles_lanes.py), and a parcel that needs more sub-steps
# takes them alone (_rest_of_step). Between the passes a lane's values wait in the chunk's lane
# scratch, one row of _LANES values per quantity, flat: row r of lane l at r * _LANES + l (a
# constant offset from one base pointer).
(_X, _Y, _Z, _U, _V, _W, _D, _KD, _T, _US, _VS, _WS, _SU, _SV, _SW, _DZK, _EC, _TLC,
 _FXF, _FXC, _FYF, _FYC, _FZC, _FZF,
 _TP, _ITP, _DNU, _QM, _H, _IH, _DU, _DV, _DW, _MU, _MV, _MW,
 _K, _KQ, _EMQ, _IRELQ, _RPQ,
 _XN, _YN, _ZN, _UN, _VN, _WN, _RU, _RV, _RW, _RT) = (r * _LANES for r in range(51))
# _X ... _W the parcel at the start, _D its diameter, _KD its stored drag rate, _T its step (dt
# plus its time credit); _US, _VS, _WS the resolved wind it sees (with the SGS part _SU, _SV, _SW
# once _lane_start has added it); _DZK the height of the cell holding it; _EC the SGS TKE of
# the cell its TKE sink goes to and _TLC that level's T_L coefficient; _FXF ... _FZF the
# stencil's fractions; _TP T_p, _ITP 1 / T_p, _DNU d / nu, _QM Q m_p; _H the sub-step, _IH 1 / h;
# _DU, _DV, _DW the slip at its start; _MU, _MV, _MW the modelled impulse of the implicit
# estimate; _K the drag rate (the iteration's current value), _KQ, _EMQ, _IRELQ, _RPQ the
# iteration's last evaluation (_EMQ: the estimate's expm1 before the first); _XN ... _WN the
# parcel at the end of the sub-step (_H then the sub-step as taken); _RU, _RV, _RW the air's
# impulse and _RT the TKE-sink rate the sub-step deposits
_LANE_ROWS_F = 51
(_ACTIVE, _ITER, _FIX, _E0, _HIT, _XF, _XC, _YF, _YC, _KC, _KF, _LOG, _KCELL) = (
    r * _LANES for r in range(13))
# _ACTIVE 1 if the lane takes its sub-step (0: the parcel was in the impact layer already);
# _ITER 1 while its drag rate iterates; _FIX 1 if a vectorized pass left it to the exact one;
# _E0 1 if the first drag evaluation's expm1 is the implicit estimate's (same k and h: the same
# number); _HIT 1 if the sub-step ended at the bed; _XF ... _KF the stencil's indices, _LOG 1 in
# the log region, _KCELL the level of the cell holding the parcel
_LANE_ROWS_I = 13
# coupling.implicit_coefficients computes its estimates in the same lane scratch
assert EST_LANES == _LANES and EST_ROWS_F <= _LANE_ROWS_F and EST_ROWS_I <= _LANE_ROWS_I

#: the scalars of a step, as _advance_chunk reads them once from prm and geo
#: (paper: the log region deposits on klog, the level it reads; otherwise on another level)
_Step = namedtuple("_Step", "dt g h_imp tol tol_fp Lx Ly Lz rho nu rho_p Q twoway tke sgs nkb "
                   "paper klog")
#: the chunks' work: their parcels (idx[cstart[c]:cstart[c+1]], coupling.chunk_assign), pool
#: ranges (coupling.chunk_ranges) and pool, results (vmax, nhit per chunk) and lane scratch
#: (lane_f (chunks, _LANE_ROWS_F * _LANES), lane_i (chunks, _LANE_ROWS_I * _LANES))
Work = namedtuple("Work", "cstart idx ranges pool vmax nhit lane_f lane_i")
#: where a chunk deposits: its pool range (slab s, L slabs, offset off; csz entries per
#: component), nk levels, comp ct the TKE sink's
_Out = namedtuple("_Out", "pool s L off csz nk ct")


@ijit
def _wind_seen(F, G, xp, yp, zp, S, nx, ny, nz):
    """The wind a parcel at (xp, yp, zp) sees, and its Stencil (interp.locate): the resolved
    velocity interpolated trilinearly, with the log law in the log region (interp.py); two-way,
    of the air after the implicit exchange: the fluid's plus the change delta interpolated with
    the deposit weights (zero beyond the buffer levels S.nkb). Where both use the same weights
    (above the log region; in it with "paper") the sum is read from U = u + delta."""
    st = locate(xp, yp, zp, G, nx, ny, nz)
    kr = st.kread
    if st.islog and S.paper:  # the log law of the (new) air at the level read, where the drag goes
        if S.twoway and kr < S.nkb:
            us = st.lfac * _bil(F.U, st.ixf, st.fxf, st.jyc, st.fyc, kr, nx, ny)
            vs = st.lfac * _bil(F.V, st.ixc, st.fxc, st.jyf, st.fyf, kr, nx, ny)
        else:
            us = st.lfac * _bil(F.u, st.ixf, st.fxf, st.jyc, st.fyc, kr, nx, ny)
            vs = st.lfac * _bil(F.v, st.ixc, st.fxc, st.jyf, st.fyf, kr, nx, ny)
    elif st.islog:  # blend, cell-drag: the log law of the level read plus the change delta of
        # the level the drag goes to (coupling.py)
        us = st.lfac * _bil(F.u, st.ixf, st.fxf, st.jyc, st.fyc, kr, nx, ny)
        vs = st.lfac * _bil(F.v, st.ixc, st.fxc, st.jyf, st.fyf, kr, nx, ny)
        if S.twoway and S.klog < S.nkb:
            us += _bil(F.du, st.ixf, st.fxf, st.jyc, st.fyc, S.klog, nx, ny)
            vs += _bil(F.dv, st.ixc, st.fxc, st.jyf, st.fyf, S.klog, nx, ny)
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
    """The rest of the step T - t, cut so that the parcel moves at most one cell height dzk at its
    vertical speed |wp| (but not below T / MAX_SUBSTEPS); the last allowed sub-step takes the
    rest."""
    h = T - t
    if nsub < MAX_SUBSTEPS - 1:
        awp = abs(wp) + 1e-30
        if h * awp > dzk:
            h = max(dzk / awp, T / MAX_SUBSTEPS)
            if h > T - t:
                h = T - t
    return h


@ijit
def _response_time(dp, S):
    """T_p = rho_p d^2 / (18 rho nu) (eq. 4)."""
    return S.rho_p * dp * dp / (18.0 * S.rho * S.nu)


@ijit
def _load_lane(lf, li, l, P, p, T, F, G, S, nx, ny, nz):
    """Scalar pass 1 of lane l (parcel p, step T): the parcel into the lane, its stencil and the
    resolved wind it sees (_wind_seen)."""
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
    if S.sgs:
        lf[_SU + l] = P.su[p]
        lf[_SV + l] = P.sv[p]
        lf[_SW + l] = P.sw[p]
    lf[_DZK + l] = G.dz_c[st.kcell]
    if S.tke:
        kt = _tke_level(st, S)
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
                   li[_KF + l], lf[_FZF + l], 1.0, li[_LOG + l] != 0, li[_KCELL + l], 0)


@ijit
def _expm1_arg(x, exact):
    """expm1(x) and whether it is exact to round-off: with ``exact``, elementary.expm1_small
    (libm beyond the Taylor range); else the Taylor polynomial alone (no branch, no call)."""
    if exact:
        return expm1_small(x), True
    return expm1_taylor(x), abs(x) <= EXPM1_TAYLOR_MAX


@ijit
def _expm1_near(k, h, kq, emq, exact):
    """expm1(-k h), from emq = expm1(-kq h) if |(kq - k) h| <= _NEAR (kq <= 0: no previous), and
    whether it is exact to round-off (_expm1_arg)."""
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
    """x^0.687 and whether it is exact to round-off: with ``exact``, elementary.pow_0687 (libm
    beyond its tables); else the table path alone (elementary.pow_0687_table)."""
    if exact:
        return pow_0687(x), True
    return pow_0687_table(x)


@ijit
def _re687_near(rel, dnu, irelq, rpq, exact):
    """(rel dnu)^0.687, from rpq = (relq dnu)^0.687 if |rel / relq - 1| <= _NEAR; irelq = 1 / relq
    (irelq <= 0: none); and whether it is exact to round-off (_pow687)."""
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
def _lane_start(lf, li, l, S, exact):
    """Pass 2 of lane l (vectorized; exact: a lane it left): the parcel's constants, the sub-step
    (_substep_length), the modelled impulse (two-way: c_p (u_s - u~_p) of the implicit estimate
    with its k0, T and weights, coupling.estimate_weights), the seen velocity with its SGS part,
    the slip, a first drag rate if the parcel has none (its kd is then -k0:
    coupling.implicit_coefficients), and the drag iteration's start."""
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
    tp = _response_time(dp, S)
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
    if S.sgs:
        us += lf[_SU + l]
        vs += lf[_SV + l]
        ws += lf[_SW + l]
    Du = us - up
    Dv = vs - vp
    Dw = ws - wp
    dnu = dp / S.nu
    if k <= 0.0:  # drag_rate (coupling.py)
        rp, ok2 = _pow687(math.sqrt(Du * Du + Dv * Dv + Dw * Dw) * dnu, exact)
        k = (1.0 + 0.15 * rp) / tp
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
def _slip_at(k, em, ih, Du, Dv, Dw, g):
    """The slip at which F(k) is evaluated (module doc): E * (step-mean slip) + (1 - E) * (end
    slip) of the relaxation over h with k frozen, em = expm1(-k h), ih = 1 / h, from the slip
    (Du, Dv, Dw) at the start: beta(k) (u_s - u_p) + (1 - beta(k)) g/k e_z. Returns it (ax, ay,
    az), its size and the factors dF/dk needs."""
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
    """F(k) = f(Re_p) / T_p from rp = Re_p^0.687 at the slip of _slip_at, and the next k:
    safeguarded Newton (dF/dk analytic) if ``newton``, else a plain fixed-point update. Returns
    the next k, whether |F(k) - k| was already within the tolerance (S.tol k for a Newton update,
    S.tol_fp k for a plain one; the update is applied all the same) and 1 / |slip|."""
    irel = 1.0 / rel if rel > 0.0 else 0.0
    F = (1.0 + 0.15 * rp) * itp
    G = F - k
    kn = F
    lim = S.tol_fp
    if newton and rel > 0.0:
        # dF/dk = 0.15 * 0.687 Re^0.687 / (rel T_p) d|slip|/dk
        db = E * ((E - phi) * ik + h * E) - h * beta
        daz = (Dw - gk) * db - gk * ik * (1.0 - beta)
        drel = ((ax * Du + ay * Dv) * db + az * daz) * irel
        den = 1.0 - (0.15 * 0.687) * rp * drel * irel * itp
        if den > 0.1:
            kt = k + G / den
            if kt > 0.0:
                kn = kt
                lim = S.tol
    return kn, abs(G) <= lim * k, irel


@ijit
def _drag_rate_update(k, em, h, ih, Du, Dv, Dw, itp, dnu, irelq, rpq, newton, S, first, exact):
    """One update of a drag rate k towards the fixed point k = F(k) (module doc), em =
    expm1(-k h): _slip_at, Re_p^0.687 there (_re687_lane), _newton_update. Returns the next k,
    whether k was within the tolerance, 1 / |slip| and Re_p^0.687 for the next evaluation, and
    whether Re_p^0.687 is exact."""
    ax, ay, az, rel, ik, E, phi, beta, gk = _slip_at(k, em, ih, Du, Dv, Dw, S.g)
    rp, ok = _re687_lane(rel, dnu, irelq, rpq, first, exact)
    kn, done, irel = _newton_update(k, rp, ax, ay, az, rel, ik, E, phi, beta, gk, h, Du, Dv, Dw,
                                    itp, newton, S)
    return kn, done, irel, rp, ok


@ijit
def _expm1_lane(k, h, kq, emq, first, e0, exact):
    """expm1(-k h) for an update of the drag iteration (``first``: its first), and whether it is
    exact: the implicit estimate's (``e0``: the same k and h) on the first update, else
    _expm1_near. Vectorized (not ``exact``), only the path a lane takes as a rule is computed,
    the estimate's on the first update and the series from the last evaluation after it; a lane
    off it is left to the exact pass."""
    if exact:
        if first and e0:
            return emq, True
        return _expm1_near(k, h, kq, emq, True)
    if first:
        return emq, e0
    return _expm1_shift(k, h, kq, emq), kq > 0.0 and abs((kq - k) * h) <= _NEAR


@ijit
def _re687_lane(rel, dnu, irelq, rpq, first, exact):
    """(rel dnu)^0.687 for an update of the drag iteration, and whether it is exact: _re687_near;
    vectorized (not ``exact``), the tables on the first update (no evaluation before it) and the
    series from the last evaluation after it, a lane off that path left to the exact pass."""
    if exact:
        return _re687_near(rel, dnu, irelq, rpq, True)
    if first:
        return pow_0687_table(rel * dnu)
    return _re687_shift(rel, irelq, rpq), irelq > 0.0 and abs(rel * irelq - 1.0) <= _NEAR


@ijit
def _lane_drag_update(lf, li, l, it, S, first, exact):
    """Update number ``it`` (``first``: it == 0) of lane l's drag rate if it still iterates
    (_drag_rate_update), as selects (vectorized; exact: a lane it left): a lane not iterating, or
    one whose update needs the exact pass, keeps its values (the latter is marked _FIX). Returns
    1 if the lane iterates on (those marked included)."""
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
    """The drag rates of lanes 0..nb-1 with _ITER set, iterated in lockstep (the long dependency
    chains of independent parcels overlap in the CPU; the updates run on vector units) until each
    is within the tolerance."""
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
    """A drag rate iterated to its fixed point from k, one parcel alone (as _drag_lanes); returns
    it with the last evaluation's k and expm1(-k h) (for _expm1_near)."""
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


@ijit
def _relax(em, ik, us, vs, wt, up, vp, wp):
    """Drag: the exact relaxation over a sub-step with k (ik = 1/k) and the seen velocity frozen,
    E = 1 + em = exp(-k h), towards (us, vs, wt), wt = ws - g/k: the velocities at the end and
    (1 - E)/k, the displacement factor of the transient."""
    E = 1.0 + em
    ome_k = -em * ik
    un = us + (up - us) * E
    vn = vs + (vp - vs) * E
    wn = wt + (wp - wt) * E
    return un, vn, wn, ome_k


@ijit
def _height(zp, wt, wp, h, ome_k):
    """z after h of the relaxation (_relax)."""
    return zp + wt * h + (wp - wt) * ome_k


@ijit
def _bed_crossing(zp, zn, k, ik, h, us, vs, wt, up, vp, wp, h_imp):
    """A sub-step that ends below the impact layer (zn < h_imp) is cut at the crossing
    (_crossing_time): the cut sub-step and the parcel's velocities there."""
    h = _crossing_time(zp, wt, wp - wt, k, h, h_imp, zn)
    em = expm1_small(-k * h)
    un, vn, wn, ome_k = _relax(em, ik, us, vs, wt, up, vp, wp)
    return h, un, vn, wn, ome_k


@ijit
def _move(xp, yp, zn, wn, us, vs, up, vp, h, ome_k, S):
    """Horizontal position after h of the relaxation, wrapped into the periodic domain; a parcel
    above the lid is reflected. Returns (x, y, z, w)."""
    xn = xp + us * h + (up - us) * ome_k
    yn = yp + vs * h + (vp - vs) * ome_k
    if zn > S.Lz:  # reflect at the lid
        zn = 2.0 * S.Lz - zn
        wn = -wn
    return wrap_periodic(xn, S.Lx), wrap_periodic(yn, S.Ly), zn, wn


@ijit
def _relax_and_move(xp, yp, zp, up, vp, wp, us, vs, ws, k, kq, emq, h, S, exact):
    """A sub-step of h with drag rate k (kq, emq: the iteration's last evaluation): drag (exact
    relaxation, _relax), the height, the bed crossing (exact only: a sub-step ending in the
    impact layer is cut there), the move. Returns the parcel's (x, y, z, u, v, w), the sub-step
    as taken, whether it ended in the impact layer and whether the numbers are exact
    (_expm1_near; without ``exact`` a hit's are not: no cut)."""
    ik = 1.0 / k
    em, ok = _expm1_near(k, h, kq, emq, exact)
    wt = ws - S.g * ik
    un, vn, wn, ome_k = _relax(em, ik, us, vs, wt, up, vp, wp)
    zn = _height(zp, wt, wp, h, ome_k)
    hit = zn < S.h_imp
    if exact and hit:
        h, un, vn, wn, ome_k = _bed_crossing(zp, zn, k, ik, h, us, vs, wt, up, vp, wp, S.h_imp)
        zn = S.h_imp
    xn, yn, zn, wn = _move(xp, yp, zn, wn, us, vs, up, vp, h, ome_k, S)
    return xn, yn, zn, un, vn, wn, h, hit, ok and not hit


@ijit
def _lane_move(lf, li, l, S, exact):
    """Pass 4 of lane l (vectorized; exact: a lane it left, _FIX): _relax_and_move over its
    sub-step; the end state into the lane, _HIT if it ended at the bed."""
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


@ijit
def _reaction(mu_, mv_, mw_, Qm, un, vn, wn, up, vp, wp, h, S):
    """The air's impulse from a sub-step of h: minus the parcel's drag impulse, Q m_p (Delta u -
    g h), plus (first sub-step) the modelled impulse (mu_, mv_, mw_)."""
    return mu_ - Qm * (un - up), mv_ - Qm * (vn - vp), mw_ - Qm * (wn - wp + S.g * h)


@ijit
def _reaction_to_air(O, st, ru, rv, rw, S, nx, ny):
    """Two-way: the air's impulse (ru, rv, rw) (_reaction) deposited with the weights of Stencil
    st (the log region: the horizontal weights on one level, interp.py)."""
    if st.islog:
        kc = S.klog
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
def _tke_level(st, S):
    """The level of the cell whose TKE sink a parcel feeds (coupling.py, eq. A1): the cell holding
    it; in the log region, the level its drag goes to. Its column is (st.ixf, st.jyf), the cell
    holding the parcel (floor(x / dx) is ixf)."""
    return S.klog if st.islog else st.kcell


@ijit
def _tke_rate(e, tlc_k, Qm, k, tp, h, S):
    """The parcel's share of the TKE-sink rate of its cell (_tke_level; e its SGS TKE, tlc_k its
    level's T_L coefficient), weighted by the fraction h / dt of the step; 0 where e <= 0
    (T_L infinite)."""
    tl = tlc_k / math.sqrt(e)
    r = Qm / S.rho * 2.0 * (k * tp) / (tp + tl) * (h / S.dt)
    return r if e > 0.0 else 0.0


@ijit
def _tke_to_air(O, st, rate, S, nx, ny):
    """The TKE-sink rate deposited on the parcel's cell (_tke_level)."""
    kcell = _tke_level(st, S)
    kk = kcell if kcell < O.nk else O.nk - 1
    O.pool[O.off + ((O.ct * O.L + slab_of(st.ixf, O.s, nx)) * ny + st.jyf) * O.nk + kk] += rate


@ijit
def _to_air(O, F, st, mu_, mv_, mw_, qm, un, vn, wn, up, vp, wp, k, tp, h, S, nx, ny):
    """A sub-step's exchange with the air (one parcel alone): the reaction (two-way) and the TKE
    sink."""
    if S.twoway:
        ru, rv, rw = _reaction(mu_, mv_, mw_, qm, un, vn, wn, up, vp, wp, h, S)
        _reaction_to_air(O, st, ru, rv, rw, S, nx, ny)
    if S.tke:
        kt = _tke_level(st, S)
        rate = _tke_rate(F.e[st.ixf, st.jyf, kt], F.tlc[kt], qm, k, tp, h, S)
        _tke_to_air(O, st, rate, S, nx, ny)


@ijit
def _rest_of_step(P, p, t, T, xp, yp, zp, up, vp, wp, k, tp, qm, F, G, O, S, nx, ny, nz):
    """The sub-steps after the first, one parcel at a time (the few parcels that move more than a
    cell height in the step). Returns the parcel's state, whether it hit the bed and its time
    left."""
    itp = 1.0 / tp
    dnu = P.d[p] / S.nu
    nsub = 1
    while True:
        st, us, vs, ws = _wind_seen(F, G, xp, yp, zp, S, nx, ny, nz)
        h = _substep_length(T, t, wp, G.dz_c[st.kcell], nsub)
        if S.sgs:
            us += P.su[p]
            vs += P.sv[p]
            ws += P.sw[p]
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
    """Scalar pass 5 of lane l (parcel p): the sub-step's exchange with the air, the parcel's
    further sub-steps if it needs them, its state stored back. Returns (hit, time left, u, v)."""
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
    """Impact bookkeeping: parcel p reached the impact layer with trem of its step left; it is
    flagged for the bed events (_splash); returns the chunk's hit count."""
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
    """Integrate the parcels of chunk c (W.idx[W.cstart[c]:W.cstart[c+1]], coupling.chunk_assign)
    over dt (plus their time credit), see the module doc. Hits (bed crossings) get flag 1 and
    their time left in trem; W.nhit[c] counts them, W.vmax[c] is the chunk's largest horizontal
    parcel speed.

    Records: P :data:`coupling.Parcels`, F :data:`coupling.Flow`, G :data:`interp.Geometry`, W
    :data:`Work`. Two-way, a parcel adds the modelled impulse c_p (u_s - u~_p) of the implicit
    estimate (from its k0 and step as coupling.implicit_coefficients had them) on its first
    sub-step.

    Deposits in the chunk's pool range (``W.ranges[c]`` = first slab s, L slabs, offset off;
    comps 0-2 = u, v, w faces, comp ``ct`` = TKE sink, each (L, ny, nk); ``ncomp`` comps;
    zeroed here first) minus the drag impulse plus the modelled impulse (same weights as the
    first sub-step's drag impulse: one deposit).

    Serial, in blocks of ``_LANES`` parcels, the first sub-step of the block's parcels in passes
    over the block (see the section comment above _wind_seen): _load_lane (locate, the wind
    seen), _lane_start, _drag_lanes, _lane_move (vectorized, with their exact redos), then
    _finish_lane (deposits, further sub-steps, the parcel stored). Each parcel's arithmetic is
    that of one parcel at a time; only the order of the deposits into the pool differs
    (round-off). The helpers are inlined here by LLVM (``_jit.device``); the prange over chunks
    is in _advance_all. Compiled without reference counting (``jit_borrow``): the lane scratch
    comes from the caller.
    """
    nx = F.u.shape[0]
    ny = F.u.shape[1]
    nz = G.z_c.shape[0]
    tol = prm[_TOL]
    S = _Step(prm[_DT], prm[_G], prm[_HIMP], tol, tol * tol, G.geo[2], G.geo[3], prm[_LZ],
              prm[_RHO], prm[_NU], prm[_RHOP], prm[_Q], prm[_TWOWAY] != 0.0, prm[_TKE] != 0.0,
              prm[_SGS] != 0.0, F.du.shape[2], G.geo[GEO_LOG_LEVEL] == G.geo[GEO_LOG_READ],
              int(G.geo[GEO_LOG_LEVEL]))
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
            if P.z[p] < S.h_imp:  # already inside the impact layer: splash now
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
def _advance_all(dt, nk, ncomp, ct, prm, P, F, G, W):
    """All parcels over dt, chunk-parallel (see _advance_chunk)."""
    for c in prange(W.ranges.shape[0]):
        _advance_chunk(c, dt, nk, ncomp, ct, prm, P, F, G, W)



@jit_borrow
def _collect_events(n, flag, ev):
    """ev[:m] = indices of the parcels with flag 1, in increasing order; returns m."""
    m = 0
    for p in range(n):
        if flag[p] == 1:
            ev[m] = p
            m += 1
    return m


@jit_borrow
def _compact(dead, n_dead, n, x, y, z, u, v, w, d, kd, flag, trem, su, sv, sw, tl, xl, yl):
    """Swap-remove the dead parcels; ``dead`` sorted in decreasing order. Returns the new count."""
    has_sgs = su.shape[0] > 0
    for i in range(n_dead):
        q = dead[i]
        last = n - 1
        if q != last:
            x[q] = x[last]
            y[q] = y[last]
            z[q] = z[last]
            u[q] = u[last]
            v[q] = v[last]
            w[q] = w[last]
            d[q] = d[last]
            kd[q] = kd[last]
            flag[q] = flag[last]
            trem[q] = trem[last]
            tl[q] = tl[last]
            xl[q] = xl[last]
            yl[q] = yl[last]
            if has_sgs:
                su[q] = su[last]
                sv[q] = sv[last]
                sw[q] = sw[last]
        n -= 1
    return n


@jit_borrow
def _cell_order(n, x, y, z, geo, z_f, lut, nx, ny, nz, key, perm, count):
    """Stable counting sort of parcels by cell (x-slab, then y, then level): perm[new] = old.
    Serial and deterministic. Keeps the grid gathers/scatters of neighbouring parcels in cache."""
    nkey = nx * ny * nz
    for c in range(nkey + 1):
        count[c] = 0
    for p in range(n):
        i = wrap_index(int(x[p] / geo[0]), nx)
        j = wrap_index(int(y[p] / geo[1]), ny)
        k = level_of(z[p], z_f, lut, geo[5], nz)
        kk = (i * ny + j) * nz + k
        key[p] = kk
        count[kk + 1] += 1
    for c in range(nkey):
        count[c + 1] += count[c]
    for p in range(n):
        kk = key[p]
        perm[count[kk]] = p
        count[kk] += 1


@pjit
def _gather(n, perm, a, out):
    """out[q] = a[perm[q]] for q < n (the parcels reordered, one field)."""
    for q in prange(n):
        out[q] = a[perm[q]]


@jit
def _release(rng, n0, n_new, x, y, z, u, v, w, d, kd, flag, trem, Lx, Ly, z_lo, z_hi, cum, mu, lnsig):
    """n_new parcels uniformly in [0, Lx) x [0, Ly) x [z_lo, z_hi), at rest, d from the soil."""
    for q in range(n0, n0 + n_new):
        x[q] = rng.random() * Lx
        y[q] = rng.random() * Ly
        z[q] = z_lo + rng.random() * (z_hi - z_lo)
        u[q] = 0.0
        v[q] = 0.0
        w[q] = 0.0
        d[q] = draw_diameter(rng, cum, mu, lnsig)
        kd[q] = 0.0
        flag[q] = 0
        trem[q] = 0.0


@jit_borrow
def _sgs_update(rng, n, dt, x, y, z, su, sv, sw, ef, tlc, geo, z_f, lut, nx, ny, nz):
    """Ornstein-Uhlenbeck SGS velocity per parcel (serial: random draws). See module doc."""
    for p in range(n):
        i = wrap_index(int(x[p] / geo[0]), nx)
        j = wrap_index(int(y[p] / geo[1]), ny)
        k = level_of(z[p], z_f, lut, geo[5], nz)
        e = ef[i, j, k]
        if e <= 0.0:
            su[p] = 0.0
            sv[p] = 0.0
            sw[p] = 0.0
            continue
        tl = tlc[k] / math.sqrt(e)
        R = math.exp(-dt / tl)
        s = math.sqrt(max(0.0, 1.0 - R * R)) * math.sqrt(2.0 * e / 3.0)
        su[p] = R * su[p] + s * rng.normal(0.0, 1.0)
        sv[p] = R * sv[p] + s * rng.normal(0.0, 1.0)
        sw[p] = R * sw[p] + s * rng.normal(0.0, 1.0)


@jit
def _entrain(rng, n, dt, uf, vf, geo, z_c, prm_e, x, y, z, u, v, w, d, kd, flag, trem, cum, mu,
             lnsig):
    """Aerodynamic entrainment (module doc). prm_e: [rho, kappa, z0, tau_t, zeta, Q, h_imp].
    Returns the new parcel count, or -1 - (first cell not done) if capacity ran out (no draws
    are made for that cell)."""
    nx = uf.shape[0]
    ny = uf.shape[1]
    rho = prm_e[0]
    kappa = prm_e[1]
    z0 = prm_e[2]
    tau_t = prm_e[3]
    zeta = prm_e[4]
    Q = prm_e[5]
    h_imp = prm_e[6]
    dx = geo[0]
    dy = geo[1]
    lnz = math.log(z_c[0] / z0)
    cap = x.shape[0]
    for i in range(nx):
        ip = (i + 1) % nx
        for j in range(ny):
            jp = (j + 1) % ny
            uc = 0.5 * (uf[i, j, 0] + uf[ip, j, 0])
            vc = 0.5 * (vf[i, j, 0] + vf[i, jp, 0])
            ustar = kappa * math.sqrt(uc * uc + vc * vc) / lnz
            tau = rho * ustar * ustar
            if tau <= tau_t:
                continue
            mean = zeta * (tau - tau_t) * dx * dy * dt / Q
            nn = int(math.floor(mean))
            if n + nn + 1 > cap:
                return -1
            if rng.random() < mean - nn:
                nn += 1
            for _ in range(nn):
                x[n] = (i + rng.random()) * dx
                y[n] = (j + rng.random()) * dy
                z[n] = h_imp
                u[n] = 0.0
                v[n] = 0.0
                w[n] = ustar
                d[n] = draw_diameter(rng, cum, mu, lnsig)
                kd[n] = 0.0
                flag[n] = 0
                trem[n] = 0.0
                n += 1
    return n


class Saltation:
    """The grain component (ARCHITECTURE.md): ``Saltation(grid, scene)``.

    Public API: ``name``, ``activate(state)``, ``dynamics(state, dt)``, ``max_dt(state)``,
    ``checkpoint()``, ``restore(data)``; ``n`` (live parcels) and the views ``x, y, z, u, v, w, d``
    (length n), ``mass`` (per real grain, kg), ``Q``, ``counters()`` (cumulative), ``last_step``
    (per-step counters), ``fluid_at_parcels(state)``, ``add_parcels(...)`` (tests, tools).
    """

    name = "saltation"
    #: courant number of parcels on the horizontal grid (max_dt)
    parcel_courant = 1.0

    def __init__(self, grid: Grid, scene, capacity: int | None = None):
        case = scene.case
        self.grid = grid
        self.scene = scene
        self.Q = float(scene.Q)
        self.rho = case.air.rho
        self.nu = case.air.nu
        self.g = case.air.g
        self.kappa = case.air.kappa
        self.rho_p = case.soil.rho_p
        self.z0 = case.surface.z0
        self.release_depth = case.particles.release_depth
        self.n_initial = int(scene.n_initial)
        phys = case.physics
        self.two_way = bool(phys.two_way_coupling)
        self.tke_sink = bool(phys.tke_particle_sink)
        self.sgs = bool(phys.sgs_particle_velocity)
        self.entrainment = bool(phys.aerodynamic_entrainment)
        self.near_bed_wind = case.particles.near_bed_wind
        self.geom = GridGeometry(grid, self.z0, self.near_bed_wind)
        self.sp = splash_params(case.splash, case.soil, self.g)
        self.h_imp = float(case.splash.impact_layer)
        self.cum, self.mu, self.lnsig = soil_arrays(case.soil)
        self.inv_mc, self.inv_mw = face_inverse_masses(grid, self.rho)
        self.m_c = 1.0 / self.inv_mc
        self.m_w = np.divide(1.0, self.inv_mw, out=np.zeros_like(self.inv_mw),
                             where=self.inv_mw > 0.0)
        self.inv_vol = np.ascontiguousarray(1.0 / grid.cell_volume)
        self.tlc = lagrangian_time_coefficients(grid, self.kappa, delta=case.closure.delta)
        self.prm = np.array([self.rho, self.nu, self.g, self.rho_p, self.Q, self.h_imp, DRAG_TOL,
                             grid.Lz, 1.0, float(self.two_way), float(self.tke_sink),
                             float(self.sgs)])
        ss = np.random.SeedSequence(case.seed, spawn_key=(RNG_SPAWN_KEY,))
        self.rng = np.random.Generator(np.random.PCG64(ss))
        # one stream per run of impacts (splash_kernels.ejecta_reserve): the bed events of a step
        # go in parallel and still do not depend on the thread count
        self.splash_rngs = tuple(np.random.Generator(np.random.PCG64(np.random.SeedSequence(
            case.seed, spawn_key=(RNG_SPAWN_KEY, SPLASH_STREAM, r)))) for r in range(N_SPLASH_RUNS))
        cap = max(1024, capacity or 2 * self.n_initial)
        self._alloc(cap)
        self.n = 0
        self.activated = False
        self.t_activation = math.nan
        # cumulative counters (parcel events) and energies (J, real grains)
        self._cum = {"n_impacts": 0, "n_rebounds": 0, "n_ejections": 0, "n_depositions": 0,
                     "n_entrained": 0}
        self.E_impact = 0.0
        self.E_splash = 0.0
        #: streamwise and vertical momentum the grains gave the bed [kg m s^-1] (splash_kernels EN_*)
        self.bed_px = 0.0
        self.bed_pz = 0.0
        self.momentum_to_air = np.zeros(3)
        self.momentum_to_bed = 0.0
        #: cumulative impact record since activation, one slab per run of impacts
        #: (splash_kernels.ImpactLog: hist, outc, hop_t, hop_l); see impact_record()
        self.impact_counts = impact_log_arrays(N_SPLASH_RUNS)
        self._log_prm = np.array([0.0, grid.Lx, grid.Ly])
        self.last_step: dict = {}
        self._steps = 0
        self._vmax = 0.0
        self._empty = np.zeros(0)
        self._e_zero = np.zeros((1, 1, 1))
        if self.entrainment:
            A_N, gam = case.threshold.A_N, case.threshold.gamma
            dm = case.soil.mean_diameter
            ut2 = A_N * ((self.rho_p - self.rho) * self.g * dm / self.rho + gam / (self.rho * dm))
            self.prm_e = np.array([self.rho, self.kappa, self.z0, self.rho * ut2, ENTRAINMENT_ZETA,
                                   self.Q, self.h_imp])

    # ---- storage ---------------------------------------------------------------------------
    #: per parcel: position, velocity, diameter, drag rate, time credit, and the time and place
    #: of its launch from the bed (splash_kernels.ImpactLog; NO_LAUNCH if released or entrained)
    _FIELDS = ("x", "y", "z", "u", "v", "w", "d", "kd", "trem", "tl", "xl", "yl")

    def _alloc(self, cap: int) -> None:
        for f in self._FIELDS:
            setattr(self, "_" + f, np.zeros(cap))
        self._flag = np.zeros(cap, dtype=np.int8)
        self._dead = np.zeros(cap, dtype=np.int64)
        self._ev = np.zeros(cap, dtype=np.int64)
        # parcel indices by chunk, unsigned: the kernels index the parcel arrays with them
        # without numba's negative-index wraparound
        self._idx = np.zeros(cap, dtype=np.uint32)
        self._cid = np.zeros(cap, dtype=np.int64)
        if self.sgs:
            self._su, self._sv, self._sw = np.zeros(cap), np.zeros(cap), np.zeros(cap)
        else:
            self._su = self._sv = self._sw = np.zeros(0)

    def _parcels(self) -> Parcels:
        """The parcel arrays as the kernels take them (coupling.Parcels)."""
        return Parcels(self._x, self._y, self._z, self._u, self._v, self._w, self._d, self._kd,
                       self._flag, self._trem, self._su, self._sv, self._sw)

    @property
    def capacity(self) -> int:
        return self._x.shape[0]

    def _grow(self, need: int) -> None:
        cap = self.capacity
        if need <= cap:
            return
        new = max(need, 2 * cap)
        for f in self._FIELDS + ("flag", "dead", "ev", "idx", "cid"):
            old = getattr(self, "_" + f)
            a = np.zeros(new, dtype=old.dtype)
            a[:cap] = old
            setattr(self, "_" + f, a)
        if self.sgs:
            for f in ("su", "sv", "sw"):
                old = getattr(self, "_" + f)
                a = np.zeros(new)
                a[:cap] = old
                setattr(self, "_" + f, a)

    def __getattr__(self, name):
        if name in ("x", "y", "z", "u", "v", "w", "d"):
            return self.__dict__["_" + name][: self.n]
        raise AttributeError(name)

    @property
    def mass(self) -> np.ndarray:
        """Mass of one real grain of each live parcel, m_p = pi d^3 rho_p / 6 [kg]."""
        return math.pi / 6.0 * self.rho_p * self.d ** 3

    def add_parcels(self, x, y, z, u=0.0, v=0.0, w=0.0, d=None) -> None:
        """Append parcels (arrays or scalars broadcast); d defaults to the soil's mu_1."""
        x = np.atleast_1d(np.asarray(x, dtype=np.float64))
        m = x.shape[0]
        self._grow(self.n + m)
        sl = slice(self.n, self.n + m)
        self._x[sl] = np.mod(x, self.grid.Lx)
        self._y[sl] = np.mod(np.broadcast_to(y, (m,)), self.grid.Ly)
        self._z[sl] = np.broadcast_to(z, (m,))
        self._u[sl] = np.broadcast_to(u, (m,))
        self._v[sl] = np.broadcast_to(v, (m,))
        self._w[sl] = np.broadcast_to(w, (m,))
        self._d[sl] = np.broadcast_to(self.mu[0] if d is None else d, (m,))
        self._kd[sl] = 0.0
        self._flag[sl] = 0
        self._trem[sl] = 0.0
        self._tl[sl] = NO_LAUNCH
        if self.sgs:
            self._su[sl] = self._sv[sl] = self._sw[sl] = 0.0
        self.n += m

    # ---- component protocol ------------------------------------------------------------------
    def activate(self, state: FlowState) -> None:
        """Release ``scene.n_initial`` parcels uniformly in the lowest ``release_depth`` at rest.

        Heights are uniform in [impact layer, release_depth): none starts inside the impact layer
        (where it would splash at zero speed before moving).
        """
        m = self.n_initial
        self._grow(self.n + m)
        self._tl[self.n:self.n + m] = NO_LAUNCH
        _release(self.rng, self.n, m, self._x, self._y, self._z, self._u, self._v, self._w,
                 self._d, self._kd, self._flag, self._trem, self.grid.Lx, self.grid.Ly, self.h_imp,
                 self.release_depth, self.cum, self.mu, self.lnsig)
        self.n += m
        self.activated = True
        self.t_activation = float(state.t)
        if self.tke_sink and state.tke_sink is None:
            state.tke_sink = np.zeros(self.grid.shape)

    def max_dt(self, state: FlowState) -> float:
        """Parcels cross at most one horizontal cell per step (they sample the grid):
        dt <= dx / max |u_p| (or dy / max |v_p|); vertical motion is sub-stepped instead."""
        if self.n == 0 or self._vmax <= 0.0:
            return math.inf
        return self.parcel_courant * min(self.grid.dx, self.grid.dy) / self._vmax

    def _levels(self, state: FlowState, dt: float) -> int:
        """Levels the deposit buffers must cover this step: up to where any parcel can get. From
        chunk_assign's parcel maxima (self._pmax: max horizontal speed, top, max speed) and the
        air's max |w| (air_maxima, which also keeps max |u| per level in self._umax)."""
        vh, ztop, vtot = self._pmax
        self._vmax = float(vh)
        wmax = air_maxima(state.u, state.w, self._umax) if state.w.size else 0.0
        # rebounds leave at <= ~2 v_imp (the normal tail is redrawn only below 0), ejecta slower
        reach = ztop + (max(vtot, wmax) * 2.5 + 1.0) * dt
        k = int(np.searchsorted(self.grid.z_f, reach, side="right"))
        return int(min(self.grid.nz, max(2, k + 2)))

    # ---- work buffers (kept across steps: no allocation, no page faults per step) ------------
    def _work_init(self) -> None:
        nx, ny, nz = self.grid.shape
        nc = N_CHUNKS
        self._hist = np.zeros(nx, dtype=np.int64)
        self._slab_stats = np.zeros((nx, 3))
        self._bounds = np.zeros(2 * nc + 1, dtype=np.int64)
        self._cstart = np.zeros(nc + 1, dtype=np.int64)
        self._stats = np.zeros((nc, 3))
        self._margin = np.zeros(nc, dtype=np.int64)
        self._ranges = np.zeros((nc, 3), dtype=np.int64)
        self._vmaxc = np.zeros(nc)
        self._nhit = np.zeros(nc, dtype=np.int64)
        self._lane_f = np.zeros((nc, _LANE_ROWS_F * _LANES))
        self._lane_i = np.zeros((nc, _LANE_ROWS_I * _LANES), dtype=np.int64)
        self._dmax = np.zeros(nx)
        # per-slab scratch of the grid passes (coupling.implicit_corrections, apply_exchange): a
        # column's sums over the chunks, and the slabs' momentum sums
        self._acc = np.zeros((nx, 6, nz))
        self._part = np.zeros((nx, 4))
        self._pmax = np.zeros(3)  # chunk_assign's parcel maxima (_levels)
        self._umax = np.zeros(nz + 1)  # max |u| per level (and max |w|)
        self._pool = np.zeros(0)
        self._grid6 = np.zeros((6, nx * ny * nz)) if self.two_way else np.zeros((6, 1))
        self._cnt = np.zeros(4, dtype=np.int64)
        self._en = np.zeros(N_EN)
        self._tot = np.zeros(3)
        self._tke_out, self._tke_top = None, nz  # the TKE-rate array last filled, its levels

    def _grid_views(self, nk: int):
        """(du, dv, dw, Uc, Vc, Wc), each (nx, ny, nk), views of persistent storage."""
        nx, ny, _ = self.grid.shape
        m = nx * ny * nk
        return tuple(self._grid6[i, :m].reshape(nx, ny, nk) for i in range(6))

    def _layout(self, margin: np.ndarray, per_slab: int) -> None:
        """Chunk ranges for the given margins; grows the pool if needed."""
        size = chunk_ranges(self._bounds, margin, self.grid.nx, per_slab, self._ranges)
        if size > self._pool.shape[0]:
            self._pool = np.zeros(int(size * 1.25) + 1)

    def dynamics(self, state: FlowState, dt: float) -> None:
        """Advance all parcels over dt in the frozen flow; exchange momentum; splash; fill tke_sink."""
        g = self.grid
        nx, ny, nz = g.shape
        geo = self.geom
        if not hasattr(self, "_ranges"):
            self._work_init()
        step = {"n_impacts": 0, "n_rebounds": 0, "n_ejections": 0, "n_depositions": 0,
                "n_entrained": 0}
        if self.entrainment:
            step["n_entrained"] = self._do_entrainment(state, dt)
        if self.sgs and self.n > 0:
            _sgs_update(self.rng, self.n, dt, self._x, self._y, self._z, self._su, self._sv,
                        self._sw, state.e, self.tlc, geo.geo, geo.z_f, geo.lut, nx, ny, nz)
        if self.n > 0 and self._steps % SORT_INTERVAL == 0:
            self._sort()
        self._steps += 1
        n = self.n
        self.prm[_DT] = dt
        two, tke = self.two_way, self.tke_sink
        # chunks of consecutive x-slabs with about equal parcel counts: each chunk's deposit
        # buffers cover only its slabs, widened by the stencil and by how far its parcels can move
        _ASSIGN(n, n, self._x, self._u, self._su, self._flag, self._trem, g.dx, nx, self._hist,
                self._slab_stats, self._bounds, self._cid, self._cstart, self._idx, self._stats,
                self._v, self._w, self._z, self._pmax)
        nk = self._levels(state, dt) if n > 0 else 2
        ef = state.e if (tke or self.sgs) else self._e_zero
        if two:
            du, dv, dw, Uc, Vc, Wc = self._grid_views(nk)
        else:
            du = dv = dw = Uc = Vc = Wc = self._e_zero
        P = self._parcels()
        F = Flow(state.u, state.v, state.w, ef, self.tlc, Uc, Vc, Wc, du, dv, dw)
        if two:
            self._margin[:] = 2  # stencil (+1 for rounding): the parcels do not move in this pass
            self._layout(self._margin, 3 * 2 * ny * nk)
            _IMPLICIT(n, self._cstart, self._idx, P, F, dt, self.prm, geo.record, self._pool,
                      self._ranges, nk, self._lane_f, self._lane_i)
            _CORRECT(nx * ny * nk, self._pool, self._ranges, self.inv_mc, self.inv_mw, state.u,
                     state.v, state.w, du, dv, dw, Uc, Vc, Wc, self._dmax, self._acc)
            dumax = float(self._dmax.max())
        else:
            dumax = 0.0
        # a parcel moves at most max(|u_p|, |u_seen|) (dt + credit) in x within the step
        if n > 0:
            uair = float(self._umax[:nk].max()) + dumax  # the levels parcels can reach
            st = self._stats
            vb = np.maximum(st[:, 0], uair + st[:, 1])
            mg = vb * (dt + st[:, 2]) / g.dx
            mg = np.where(np.isfinite(mg), np.minimum(mg, nx), nx)  # NaN: the whole domain
            self._margin[:] = np.ceil(mg).astype(np.int64) + 2
        ncomp = 3 * int(two) + int(tke)
        self._layout(self._margin, ncomp * ny * nk)
        W = Work(self._cstart, self._idx, self._ranges, self._pool, self._vmaxc, self._nhit,
                 self._lane_f, self._lane_i)
        _ADVANCE(n, dt, nk, ncomp, 3 if two else 0, self.prm, P, F, geo.record, W)
        # bed events (self._splash). Rebounds and ejecta leave the bed at the impact point with the
        # rest of the step as a time credit: they are integrated over dt + credit in the next step,
        # inside its implicit exchange (integrating them now, outside it, would be an explicit
        # exchange: unstable for small grains at high loading).
        n_ev = int(self._nhit.sum())
        self._log_prm[0] = state.t + dt  # the impacts' times are counted back from the step's end
        cnt = self._cnt
        en = self._en
        cnt[:] = 0
        en[:] = 0.0
        n_dead = 0
        rounds = 1 if n_ev else 0
        if n_ev:
            n_dead = self._splash(n, n_ev)
        if n_dead:
            dead = np.sort(self._dead[:n_dead])[::-1].copy()
            self.n = _compact(dead, n_dead, self.n, self._x, self._y, self._z, self._u, self._v,
                              self._w, self._d, self._kd, self._flag, self._trem, self._su,
                              self._sv, self._sw, self._tl, self._xl, self._yl)
        # momentum to the air, TKE sink
        if two or tke:
            if tke:
                if state.tke_sink is None:
                    state.tke_sink = np.zeros(g.shape)
                # levels at and above the last step's nk are zero, unless the array is new to us
                # (a restart): only the levels that may not be are cleared
                top = self._tke_top if state.tke_sink is self._tke_out else nz
                tke_out = state.tke_sink
            else:
                top, tke_out = nk, self._e_zero
            tot = self._tot
            bed = _APPLY(nx * ny * nk, self._pool, self._ranges, nk, two, du, dv, dw,
                         self.inv_mc, self.inv_mw, self.m_c, self.m_w, state.u, state.v, state.w,
                         tot, tke, 3 if two else 0, max(nk, top), self.inv_vol, tke_out,
                         self._acc, self._part)
            if two:
                self.momentum_to_air += tot
                self.momentum_to_bed += bed
            if tke:
                self._tke_out, self._tke_top = state.tke_sink, nk
        self._vmax = max(self._vmax, float(self._vmaxc.max()) if self.n else 0.0)
        step["n_impacts"], step["n_rebounds"], step["n_ejections"], step["n_depositions"] = (
            int(c) for c in cnt)
        for key, val in step.items():
            self._cum[key] += val
        self.E_impact += float(en[EN_IMPACT])
        self.E_splash += float(en[EN_SPLASH])
        self.bed_px += float(en[EN_PX_IN] - en[EN_PX_OUT])
        self.bed_pz += float(en[EN_PZ_IN] + en[EN_PZ_OUT])
        step["E_impact"], step["E_splash"] = float(en[EN_IMPACT]), float(en[EN_SPLASH])
        step["splash_rounds"] = rounds
        self.last_step = step

    def _splash(self, n: int, n_ev: int) -> int:
        """Bed events of the n_ev parcels flagged as hits, in N_SPLASH_RUNS runs of consecutive
        impacts with their own random streams, in parallel (splash_kernels.splash_runs). Each
        run appends its ejecta in a stretch reserved after n (ejecta_reserve); the stretches are
        then closed up in run order. Fills cnt and en and the dead list self._dead; returns the
        number of dead parcels."""
        _collect_events(n, self._flag, self._ev)
        ev = self._ev[:n_ev].copy()  # _grow replaces self._ev
        nr = N_SPLASH_RUNS
        lo = np.zeros(nr + 1, dtype=np.int64)
        res = np.zeros(nr, dtype=np.int64)
        ejecta_reserve(ev, n_ev, self._u, self._v, self._w, self.sp, lo, res)
        base = n + np.concatenate(([0], np.cumsum(res)))  # run r appends in [base[r], base[r+1])
        if base[-1] > self.capacity:
            self._grow(max(2 * self.capacity, int(base[-1])))
        cnt_r = np.zeros((nr, 4), dtype=np.int64)
        en_r = np.zeros((nr, N_EN))
        out = np.zeros((nr, 3), dtype=np.int64)
        log = ImpactLog(self._tl, self._xl, self._yl, *self.impact_counts, self._log_prm)
        _SPLASH(n_ev, self.splash_rngs, ev, lo, base, self._x, self._y, self._z, self._u,
                self._v, self._w, self._d, self._kd, self._flag, self._trem, self._dead, self.sp,
                self.cum, self.mu, self.lnsig, self.Q, cnt_r, en_r, out, log)
        # close up the runs' ejecta stretches, in run order; the dead lists likewise
        dst = n
        dead = []
        for r in range(nr):
            if out[r, 0] != lo[r + 1] - lo[r]:  # ejecta_reserve's bound is the kernel's own
                raise RuntimeError(f"splash run {r} ran out of its reserved ejecta stretch")
            src, m = int(base[r]), int(out[r, 1] - base[r])
            if m and dst != src:
                for f in self._FIELDS:
                    a = getattr(self, "_" + f)
                    a[dst:dst + m] = a[src:src + m]
            dst += m
            dead.append(self._dead[lo[r]:lo[r] + out[r, 2]])
        self._flag[n:dst] = 0
        if self.sgs:  # ejecta start without an SGS velocity
            self._su[n:dst] = self._sv[n:dst] = self._sw[n:dst] = 0.0
        self.n = dst
        self._cnt[:] = cnt_r.sum(axis=0)
        self._en[:] = en_r.sum(axis=0)
        dead = np.concatenate(dead)
        self._dead[:dead.size] = dead
        return int(dead.size)

    def _sort(self) -> None:
        """Reorder the parcels by cell (every SORT_INTERVAL steps): locality for the kernels.
        Each field is gathered into a spare array of the same size, which then takes its place
        (the field's old array becomes the next spare): one pass and one parallel region per
        field, no copy back."""
        g = self.geom
        n = self.n
        # work arrays kept across sorts (no allocation and page faults every SORT_INTERVAL steps)
        if getattr(self, "_sort_key", None) is None or self._sort_key.shape[0] < n:
            self._sort_key = np.empty(self.capacity, dtype=np.int64)
            self._sort_perm = np.empty(self.capacity, dtype=np.int64)
            self._sort_count = np.empty(g.nx * g.ny * g.nz + 1, dtype=np.int64)
        if getattr(self, "_sort_tmp", None) is None or self._sort_tmp.shape[0] != self.capacity:
            self._sort_tmp = np.empty(self.capacity)
        key, perm = self._sort_key, self._sort_perm
        _cell_order(n, self._x, self._y, self._z, g.geo, g.z_f, g.lut, g.nx, g.ny, g.nz, key, perm,
                    self._sort_count)
        names = list(self._FIELDS) + (["su", "sv", "sw"] if self.sgs else [])
        for f in names:
            a = getattr(self, "_" + f)
            _GATHER(n, n, perm, a, self._sort_tmp)
            setattr(self, "_" + f, self._sort_tmp)
            self._sort_tmp = a

    def _do_entrainment(self, state: FlowState, dt: float) -> int:
        n0 = self.n
        while True:
            # worst case per cell is bounded by the stress; grow generously, then retry from the
            # saved RNG state so that no draw is lost or repeated
            saved = self.rng.bit_generator.state
            n = _entrain(self.rng, self.n, dt, state.u, state.v, self.geom.geo, self.geom.z_c,
                         self.prm_e, self._x, self._y, self._z, self._u, self._v, self._w, self._d,
                         self._kd, self._flag, self._trem, self.cum, self.mu, self.lnsig)
            if n >= 0:
                break
            self.rng.bit_generator.state = saved
            self._grow(2 * self.capacity)
        if self.sgs:
            self._su[n0:n] = self._sv[n0:n] = self._sw[n0:n] = 0.0
        self._tl[n0:n] = NO_LAUNCH
        self.n = n
        return n - n0

    # ---- diagnostics support -----------------------------------------------------------------
    def counters(self) -> dict:
        """Cumulative counters since activation (parcel events), energies [J], momentum [kg m/s]:
        ``bed_px``, ``bed_pz`` the streamwise and vertical momentum the grains gave the bed."""
        out = {"n_parcels": int(self.n)}
        out.update({k: int(v) for k, v in self._cum.items()})
        out["E_impact"] = self.E_impact
        out["E_splash"] = self.E_splash
        out["bed_px"] = self.bed_px
        out["bed_pz"] = self.bed_pz
        out["momentum_to_air"] = self.momentum_to_air.copy()
        return out

    def impact_record(self) -> dict:
        """The cumulative impact record since activation (splash_kernels.ImpactLog), summed over
        the runs: ``impact_hist`` (speed bin, angle bin), ``impact_outcomes`` (speed bin,
        [impacts, rebounds, ejecta]), ``hop_time_hist``, ``hop_length_hist`` (counts)."""
        hist, outc, hop_t, hop_l = self.impact_counts
        return {"impact_hist": hist.sum(axis=0), "impact_outcomes": outc.sum(axis=0),
                "hop_time_hist": hop_t.sum(axis=0), "hop_length_hist": hop_l.sum(axis=0)}

    def fluid_at_parcels(self, state: FlowState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Resolved fluid velocity (u_f, v_f, w_f) interpolated at every live parcel."""
        out = np.empty((3, self.n))
        _fluid_at(self.n, self._x, self._y, self._z, state.u, state.v, state.w, self.geom.record,
                  out)
        return out[0], out[1], out[2]

    def grain_momentum(self) -> np.ndarray:
        """Total momentum of the grains, sum Q m_p u_p (3,) [kg m s^-1]."""
        m = self.Q * self.mass
        return np.array([np.sum(m * self.u), np.sum(m * self.v), np.sum(m * self.w)])

    # ---- checkpoint ------------------------------------------------------------------------
    def checkpoint(self) -> dict:
        """Flat dict of arrays/scalars; the RNG state as a JSON string. Bit-for-bit resumable."""
        n = self.n
        data = {f"grain_{f}": getattr(self, "_" + f)[:n].copy() for f in self._FIELDS}
        if self.sgs:
            for f in ("su", "sv", "sw"):
                data[f"grain_{f}"] = getattr(self, "_" + f)[:n].copy()
        data["grain_n"] = n
        data["grain_rng_state"] = json.dumps(self.rng.bit_generator.state)
        data["grain_splash_rng_states"] = json.dumps([g.bit_generator.state
                                                      for g in self.splash_rngs])
        data["grain_activated"] = int(self.activated)
        data["grain_t_activation"] = float(self.t_activation)
        for k, v in self._cum.items():
            data[f"grain_{k}"] = int(v)
        data["grain_E_impact"] = self.E_impact
        data["grain_E_splash"] = self.E_splash
        data["grain_bed_px"] = self.bed_px
        data["grain_bed_pz"] = self.bed_pz
        data["grain_momentum_to_air"] = self.momentum_to_air.copy()
        data["grain_momentum_to_bed"] = self.momentum_to_bed
        data["grain_vmax"] = self._vmax
        data["grain_steps"] = int(self._steps)
        for name, a in zip(("hist", "outc", "hop_t", "hop_l"), self.impact_counts):
            data[f"grain_impact_{name}"] = a.copy()
        return data

    def restore(self, data: dict) -> None:
        n = int(data["grain_n"])
        self._alloc(max(1024, 2 * n, self.capacity))
        for f in self._FIELDS:
            if f"grain_{f}" in data:
                getattr(self, "_" + f)[:n] = np.asarray(data[f"grain_{f}"], dtype=np.float64)
            elif f == "tl":   # a checkpoint without launch records: no hop ends known
                self._tl[:n] = NO_LAUNCH
        if self.sgs and "grain_su" in data:
            for f in ("su", "sv", "sw"):
                getattr(self, "_" + f)[:n] = np.asarray(data[f"grain_{f}"], dtype=np.float64)
        self._flag[:n] = 0
        self.n = n
        st = data["grain_rng_state"]
        self.rng.bit_generator.state = json.loads(st if isinstance(st, str) else str(st))
        if "grain_splash_rng_states" in data:
            st = data["grain_splash_rng_states"]
            states = json.loads(st if isinstance(st, str) else str(st))
            for g, state in zip(self.splash_rngs, states):
                g.bit_generator.state = state
        self.activated = bool(int(data["grain_activated"]))
        self.t_activation = float(data["grain_t_activation"])
        for k in self._cum:
            self._cum[k] = int(data.get(f"grain_{k}", 0))
        self.E_impact = float(data["grain_E_impact"])
        self.E_splash = float(data["grain_E_splash"])
        self.bed_px = float(data.get("grain_bed_px", 0.0))
        self.bed_pz = float(data.get("grain_bed_pz", 0.0))
        self.momentum_to_air = np.array(data["grain_momentum_to_air"], dtype=np.float64).reshape(3)
        self.momentum_to_bed = float(data["grain_momentum_to_bed"])
        self._vmax = float(data["grain_vmax"])
        self._steps = int(data.get("grain_steps", 0))
        for name, a in zip(("hist", "outc", "hop_t", "hop_l"), self.impact_counts):
            if f"grain_impact_{name}" in data:
                a[...] = np.asarray(data[f"grain_impact_{name}"], dtype=np.int64).reshape(a.shape)


@jit_borrow
def _fluid_at_range(lo, hi, x, y, z, uf, vf, wf, G, out):
    nx = uf.shape[0]
    ny = uf.shape[1]
    nz = uf.shape[2]
    for p in range(lo, hi):
        st = locate(x[p], y[p], z[p], G, nx, ny, nz)
        a, b, c = interp_fluid(uf, vf, wf, st, nx, ny)
        out[0, p] = a
        out[1, p] = b
        out[2, p] = c


@pjit
def _fluid_at(n, x, y, z, uf, vf, wf, G, out):
    nb = 64
    for b in prange(nb):
        _fluid_at_range((b * n) // nb, ((b + 1) * n) // nb, x, y, z, uf, vf, wf, G, out)
