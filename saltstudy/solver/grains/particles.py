"""The saltation component: Lagrangian parcels of sand grains (paper sections 2.1-2.4).

Each parcel stands for ``Q = scene.Q`` real grains of one diameter, in a struct of arrays that
grows by doubling (the first ``n`` alive): position, velocity, ``d``, the drag-rate warm start
``kd``, a ``flag`` and the time credit ``trem``. Periodic in x and y. Equation of motion (eqs. 3-4)::

    du_p/dt = k_p (u_s - u_p) + g,    k_p = f(Re_p) / T_p,   T_p = rho_p d^2 / (18 rho nu),
    f(Re_p) = 1 + 0.15 Re_p^0.687 (Clift et al. 1978),        g = (0, 0, -g)

integrated exactly over a (sub)step h with k_p and u_s frozen (physics.drag.relaxation): a grain
with T_p << h is stable. k_p is evaluated at the slip ``E (mean slip) + (1 - E) (end slip)``,
E = exp(-k_p h): second order for k_p h << 1, no overshoot of the terminal velocity for
k_p h >> 1; found by safeguarded Newton (drag.py) from the last step's, to ``DRAG_TOL``.

A sub-step moves a parcel one local cell height at most (``MAX_SUBSTEPS`` per step). A parcel
crossing the impact layer (0.5 mm) stops there and splashes (splash_kernels.py); rebound and
ejecta leave with the rest of the step as a credit, integrated in the next step inside its
implicit exchange (at once, their exchange would be explicit: unstable for small grains at high
loading). One placed inside the layer splashes at once; one reaching the lid is reflected.

Parcels go in a fixed number of chunks (coupling.py), impacts in a fixed number of runs with their
own random streams: results do not depend on the thread count. The kernels a step calls are one
record (``StepKernels``) that a benchmark may replace.
"""
import json
import math
import time
from collections import namedtuple

import numba
import numpy as np

from ...physics.soil import soil_arrays
from ...physics.splash import splash_constants
from ..grid import Grid
from ..state import FlowState
from .advance import advance_all
from .coupling import (
    EST_LANES, EST_ROWS_F, EST_ROWS_I, N_CHUNKS, Flow, Parcels, air_maxima, apply_exchange,
    chunk_assign, chunk_ranges, face_inverse_masses, implicit_coefficients, implicit_corrections,
    lagrangian_time_coefficients)
from .interp import GridGeometry
from .layout import _DT, _LANE_ROWS_F, _LANE_ROWS_I, _LANES, DRAG_TOL, Work
from .population import cell_order, collect_events, compact, fluid_at, gather, release
from .splash_kernels import (
    EN_IMPACT, EN_PX_IN, EN_PX_OUT, EN_PZ_IN, EN_PZ_OUT, EN_SPLASH, IMPACT_RECORD, N_EN, NO_LAUNCH,
    ImpactLog, ejecta_reserve, impact_log_arrays, splash_runs)

#: the grains' main random stream: SeedSequence(case.seed, spawn_key=(RNG_SPAWN_KEY,)), distinct
#: from any stream the flow derives from the same seed
RNG_SPAWN_KEY = 0x5A17
#: the impacts of a step go in this many runs (fixed: thread-count free), each with its stream
#: SeedSequence(case.seed, spawn_key=(RNG_SPAWN_KEY, SPLASH_STREAM, run))
N_SPLASH_RUNS = 4
SPLASH_STREAM = 1
#: parcels are reordered by cell every this many steps (cache locality of gathers and scatters)
SORT_INTERVAL = 10
#: the impact record's arrays (splash_kernels.ImpactLog), by checkpoint name
_LOG_NAMES = ("hist", "outc", "hop_t", "hop_l")

#: The kernels a step calls, by name: the parallel ones (``PARALLEL``) each through its own
#: ``Threads``. Any callables with the same arguments will do (a benchmark wraps each in a timer).
StepKernels = namedtuple("StepKernels", "chunk_assign implicit_coefficients implicit_corrections "
                         "advance_all ejecta_reserve splash_runs apply_exchange air_maxima "
                         "collect_events compact cell_order gather")
#: the solver's own kernels
KERNELS = StepKernels(chunk_assign, implicit_coefficients, implicit_corrections, advance_all,
                      ejecta_reserve, splash_runs, apply_exchange, air_maxima, collect_events,
                      compact, cell_order, gather)
#: the kernels of StepKernels that open a parallel region (work: parcels, impacts or grid columns)
PARALLEL = ("chunk_assign", "implicit_coefficients", "implicit_corrections", "advance_all",
            "splash_runs", "apply_exchange", "gather")


class Threads:
    """A parallel kernel run on the numba threads or on one, whichever took less time per unit of
    work recently (same results): a parallel region can wait milliseconds for its workers on a
    shared machine (docs/BENCHMARKS.md). Every EXPLORE-th call tries the other; first untimed."""

    EXPLORE = 32

    def __init__(self, kernel):
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
            return self.kernel(*args)
        t0 = time.perf_counter()
        if i == 1:
            numba.set_num_threads(1)
            try:
                out = self.kernel(*args)
            finally:
                numba.set_num_threads(nt)
        else:
            out = self.kernel(*args)
        c = (time.perf_counter() - t0) / max(work, 1)
        if self.seen:
            self.cost[i] = c if self.cost[i] == 0.0 else 0.5 * (self.cost[i] + c)
        self.seen = True
        return out


# coupling.implicit_coefficients computes its estimates in the same lane scratch
assert EST_LANES == _LANES and EST_ROWS_F <= _LANE_ROWS_F and EST_ROWS_I <= _LANE_ROWS_I


class Saltation:
    """The grain component (docs/ARCHITECTURE.md, "Solver API"): ``Saltation(grid, scene)``."""

    name = "saltation"
    #: courant number of parcels on the horizontal grid (max_dt)
    parcel_courant = 1.0

    def __init__(self, grid: Grid, scene, capacity: int | None = None,
                 kernels: StepKernels = KERNELS):
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
        self.kernels = kernels
        self.geom = GridGeometry(grid, self.z0)
        self.sp = splash_constants(case.splash, case.soil, self.g)
        self.h_imp = float(case.splash.impact_layer)
        self.cum, self.mu, self.lnsig = soil_arrays(case.soil)
        self.inv_mc, self.inv_mw = face_inverse_masses(grid, self.rho)
        self.m_c = 1.0 / self.inv_mc
        self.m_w = np.divide(1.0, self.inv_mw, out=np.zeros_like(self.inv_mw),
                             where=self.inv_mw > 0.0)
        self.inv_vol = np.ascontiguousarray(1.0 / grid.cell_volume)
        self.tlc = lagrangian_time_coefficients(grid, self.kappa, delta=case.closure.delta)
        self.prm = np.array([self.rho, self.nu, self.g, self.rho_p, self.Q, self.h_imp, DRAG_TOL,
                             grid.Lz, 1.0, float(self.two_way), float(self.tke_sink)])
        ss = np.random.SeedSequence(case.seed, spawn_key=(RNG_SPAWN_KEY,))
        self.rng = np.random.Generator(np.random.PCG64(ss))
        self.splash_rngs = tuple(np.random.Generator(np.random.PCG64(np.random.SeedSequence(
            case.seed, spawn_key=(RNG_SPAWN_KEY, SPLASH_STREAM, r)))) for r in range(N_SPLASH_RUNS))
        cap = max(1024, capacity or 2 * self.n_initial)
        self._alloc(cap)
        self.n = 0
        self.activated = False
        self.t_activation = math.nan
        # cumulative counters (parcel events) and energies (J, real grains)
        self._cum = {"n_impacts": 0, "n_rebounds": 0, "n_ejections": 0, "n_depositions": 0}
        self.E_impact = 0.0
        self.E_splash = 0.0
        #: streamwise and vertical momentum the grains gave the bed [kg m s^-1] (splash_kernels EN_*)
        self.bed_px = 0.0
        self.bed_pz = 0.0
        self.momentum_to_air = np.zeros(3)
        #: cumulative impact record (splash_kernels.ImpactLog), one slab per run of impacts
        self.impact_counts = impact_log_arrays(N_SPLASH_RUNS)
        self._log_prm = np.array([0.0, grid.Lx, grid.Ly])
        self.last_step: dict = {}
        self._steps = 0
        self._vmax = 0.0
        self._e_zero = np.zeros((1, 1, 1))

    @property
    def kernels(self) -> StepKernels:
        """The kernels the step calls; setting it gives each parallel one a ``Threads``."""
        return self._kernels

    @kernels.setter
    def kernels(self, kernels: StepKernels) -> None:
        self._kernels = kernels
        self._run = kernels._replace(**{f: Threads(getattr(kernels, f)) for f in PARALLEL})

    # ---- storage ---------------------------------------------------------------------------
    #: per parcel: position, velocity, diameter, drag rate, time credit, and the time and place
    #: of its launch from the bed (splash_kernels.ImpactLog; NO_LAUNCH if released)
    _FIELDS = ("x", "y", "z", "u", "v", "w", "d", "kd", "trem", "tl", "xl", "yl")

    def _alloc(self, cap: int) -> None:
        for f in self._FIELDS:
            setattr(self, "_" + f, np.zeros(cap))
        self._flag = np.zeros(cap, dtype=np.int8)
        self._dead = np.zeros(cap, dtype=np.int64)
        self._ev = np.zeros(cap, dtype=np.int64)
        # parcel indices by chunk, unsigned: no negative-index wraparound in the kernels
        self._idx = np.zeros(cap, dtype=np.uint32)
        self._cid = np.zeros(cap, dtype=np.int64)

    def _parcels(self) -> Parcels:
        """The parcel arrays as the kernels take them (coupling.Parcels)."""
        return Parcels(self._x, self._y, self._z, self._u, self._v, self._w, self._d, self._kd,
                       self._flag, self._trem)

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
        d = self.mu[0] if d is None else d
        for f, val in (("z", z), ("u", u), ("v", v), ("w", w), ("d", d)):
            getattr(self, "_" + f)[sl] = np.broadcast_to(val, (m,))
        self._kd[sl] = 0.0
        self._flag[sl] = 0
        self._trem[sl] = 0.0
        self._tl[sl] = NO_LAUNCH
        self.n += m

    # ---- component protocol ------------------------------------------------------------------
    def activate(self, state: FlowState) -> None:
        """Release ``scene.n_initial`` parcels at rest in [impact layer, release_depth)."""
        m = self.n_initial
        self._grow(self.n + m)
        self._tl[self.n:self.n + m] = NO_LAUNCH
        release(self.rng, self.n, m, self._x, self._y, self._z, self._u, self._v, self._w,
                 self._d, self._kd, self._flag, self._trem, self.grid.Lx, self.grid.Ly, self.h_imp,
                 self.release_depth, self.cum, self.mu, self.lnsig)
        self.n += m
        self.activated = True
        self.t_activation = float(state.t)
        if self.tke_sink and state.tke_sink is None:
            state.tke_sink = np.zeros(self.grid.shape)

    def max_dt(self, state: FlowState) -> float:
        """min(dx, dy) / max horizontal |u_p|: a parcel crosses one cell per step at most."""
        if self.n == 0 or self._vmax <= 0.0:
            return math.inf
        return self.parcel_courant * min(self.grid.dx, self.grid.dy) / self._vmax

    def _levels(self, state: FlowState, dt: float) -> int:
        """Levels the deposit buffers cover this step: up to where any parcel can get."""
        vh, ztop, vtot = self._pmax
        self._vmax = float(vh)
        wmax = self._run.air_maxima(state.u, state.w, self._umax) if state.w.size else 0.0
        # rebounds leave at <= ~2 v_imp (the normal tail is redrawn only below 0), ejecta slower
        reach = ztop + (max(vtot, wmax) * 2.5 + 1.0) * dt
        k = int(np.searchsorted(self.grid.z_f, reach, side="right"))
        return int(min(self.grid.nz, max(2, k + 2)))

    # ---- work buffers (kept across steps: no allocation, no page faults per step) ------------
    def _work_init(self) -> None:
        nx, ny, nz = self.grid.shape
        nc = N_CHUNKS
        self._hist = np.zeros(nx, dtype=np.int64)
        self._slab_stats = np.zeros((nx, 2))
        self._bounds = np.zeros(2 * nc + 1, dtype=np.int64)
        self._cstart = np.zeros(nc + 1, dtype=np.int64)
        self._stats = np.zeros((nc, 2))
        self._margin = np.zeros(nc, dtype=np.int64)
        self._ranges = np.zeros((nc, 3), dtype=np.int64)
        self._vmaxc = np.zeros(nc)
        self._nhit = np.zeros(nc, dtype=np.int64)
        self._lane_f = np.zeros((nc, _LANE_ROWS_F * _LANES))
        self._lane_i = np.zeros((nc, _LANE_ROWS_I * _LANES), dtype=np.int64)
        self._dmax = np.zeros(nx)
        # per-slab scratch of coupling.implicit_corrections and apply_exchange
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
        K = self._run
        if self.n > 0 and self._steps % SORT_INTERVAL == 0:
            self._sort()
        self._steps += 1
        n = self.n
        self.prm[_DT] = dt
        two, tke = self.two_way, self.tke_sink
        # chunks of consecutive x-slabs with about equal parcel counts: each chunk's deposit
        # buffers cover only its slabs, widened by the stencil and by how far its parcels can move
        K.chunk_assign(n, n, self._x, self._u, self._flag, self._trem, g.dx, nx, self._hist,
                       self._slab_stats, self._bounds, self._cid, self._cstart, self._idx,
                       self._stats, self._v, self._w, self._z, self._pmax)
        nk = self._levels(state, dt) if n > 0 else 2
        ef = state.e if tke else self._e_zero
        if two:
            du, dv, dw, Uc, Vc, Wc = self._grid_views(nk)
        else:
            du = dv = dw = Uc = Vc = Wc = self._e_zero
        P = self._parcels()
        F = Flow(state.u, state.v, state.w, ef, self.tlc, Uc, Vc, Wc, du, dv, dw)
        if two:
            self._margin[:] = 2  # stencil (+1 for rounding): the parcels do not move in this pass
            self._layout(self._margin, 3 * 2 * ny * nk)
            K.implicit_coefficients(n, self._cstart, self._idx, P, F, dt, self.prm, geo.record,
                                    self._pool, self._ranges, nk, self._lane_f, self._lane_i)
            K.implicit_corrections(nx * ny * nk, self._pool, self._ranges, self.inv_mc,
                                   self.inv_mw, state.u, state.v, state.w, du, dv, dw, Uc, Vc, Wc,
                                   self._dmax, self._acc)
            dumax = float(self._dmax.max())
        else:
            dumax = 0.0
        # a parcel moves at most max(|u_p|, |u_seen|) (dt + credit) in x within the step
        if n > 0:
            uair = float(self._umax[:nk].max()) + dumax  # the levels parcels can reach
            st = self._stats
            vb = np.maximum(st[:, 0], uair)
            mg = vb * (dt + st[:, 1]) / g.dx
            mg = np.where(np.isfinite(mg), np.minimum(mg, nx), nx)  # NaN: the whole domain
            self._margin[:] = np.ceil(mg).astype(np.int64) + 2
        ncomp = 3 * int(two) + int(tke)
        self._layout(self._margin, ncomp * ny * nk)
        W = Work(self._cstart, self._idx, self._ranges, self._pool, self._vmaxc, self._nhit,
                 self._lane_f, self._lane_i)
        K.advance_all(n, dt, nk, ncomp, 3 if two else 0, self.prm, P, F, geo.record, W)
        # bed events: rebounds and ejecta carry the rest of the step as a credit (module doc)
        n_ev = int(self._nhit.sum())
        self._log_prm[0] = state.t + dt  # the impacts' times are counted back from the step's end
        cnt = self._cnt
        en = self._en
        cnt[:] = 0
        en[:] = 0.0
        n_dead = self._splash(n, n_ev) if n_ev else 0
        if n_dead:
            dead = np.sort(self._dead[:n_dead])[::-1].copy()
            self.n = K.compact(dead, n_dead, self.n, self._x, self._y, self._z, self._u, self._v,
                               self._w, self._d, self._kd, self._flag, self._trem, self._tl,
                               self._xl, self._yl)
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
            K.apply_exchange(nx * ny * nk, self._pool, self._ranges, nk, two, du, dv, dw,
                             self.inv_mc, self.inv_mw, self.m_c, self.m_w, state.u, state.v,
                             state.w, tot, tke, 3 if two else 0, max(nk, top), self.inv_vol,
                             tke_out, self._acc, self._part)
            if two:
                self.momentum_to_air += tot
            if tke:
                self._tke_out, self._tke_top = state.tke_sink, nk
        self._vmax = max(self._vmax, float(self._vmaxc.max()) if self.n else 0.0)
        step = dict(zip(self._cum, (int(c) for c in cnt)))  # impacts, rebounds, ejections, ...
        for key, val in step.items():
            self._cum[key] += val
        self.E_impact += float(en[EN_IMPACT])
        self.E_splash += float(en[EN_SPLASH])
        self.bed_px += float(en[EN_PX_IN] - en[EN_PX_OUT])
        self.bed_pz += float(en[EN_PZ_IN] + en[EN_PZ_OUT])
        step["E_impact"], step["E_splash"] = float(en[EN_IMPACT]), float(en[EN_SPLASH])
        self.last_step = step

    def _splash(self, n: int, n_ev: int) -> int:
        """The bed events of the n_ev hits in parallel runs; returns the number of dead."""
        K = self._run
        K.collect_events(n, self._flag, self._ev)
        ev = self._ev[:n_ev].copy()  # _grow replaces self._ev
        nr = N_SPLASH_RUNS
        lo = np.zeros(nr + 1, dtype=np.int64)
        res = np.zeros(nr, dtype=np.int64)
        K.ejecta_reserve(ev, n_ev, self._u, self._v, self._w, self.sp, lo, res)
        base = n + np.concatenate(([0], np.cumsum(res)))  # run r appends in [base[r], base[r+1])
        if base[-1] > self.capacity:
            self._grow(max(2 * self.capacity, int(base[-1])))
        cnt_r = np.zeros((nr, 4), dtype=np.int64)
        en_r = np.zeros((nr, N_EN))
        out = np.zeros((nr, 3), dtype=np.int64)
        log = ImpactLog(self._tl, self._xl, self._yl, *self.impact_counts, self._log_prm)
        K.splash_runs(n_ev, self.splash_rngs, ev, lo, base, self._x, self._y, self._z, self._u,
                      self._v, self._w, self._d, self._kd, self._flag, self._trem, self._dead,
                      self.sp, self.cum, self.mu, self.lnsig, self.Q, cnt_r, en_r, out, log)
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
        self.n = dst
        self._cnt[:] = cnt_r.sum(axis=0)
        self._en[:] = en_r.sum(axis=0)
        dead = np.concatenate(dead)
        self._dead[:dead.size] = dead
        return int(dead.size)

    def _sort(self) -> None:
        """Reorder the parcels by cell (locality), each field gathered into a spare array."""
        g = self.geom
        n = self.n
        if getattr(self, "_sort_key", None) is None or self._sort_key.shape[0] < n:
            self._sort_key = np.empty(self.capacity, dtype=np.int64)
            self._sort_perm = np.empty(self.capacity, dtype=np.int64)
            self._sort_count = np.empty(g.nx * g.ny * g.nz + 1, dtype=np.int64)
        if getattr(self, "_sort_tmp", None) is None or self._sort_tmp.shape[0] != self.capacity:
            self._sort_tmp = np.empty(self.capacity)
        key, perm = self._sort_key, self._sort_perm
        K = self._run
        K.cell_order(n, self._x, self._y, self._z, g.geo, g.z_f, g.lut, g.nx, g.ny, g.nz, key, perm,
                     self._sort_count)
        for f in self._FIELDS:
            a = getattr(self, "_" + f)
            K.gather(n, n, perm, a, self._sort_tmp)
            setattr(self, "_" + f, self._sort_tmp)
            self._sort_tmp = a

    # ---- diagnostics support -----------------------------------------------------------------
    def counters(self) -> dict:
        """Cumulative counters since activation, energies [J], bed momentum [kg m s^-1]."""
        out = {"n_parcels": int(self.n), **{k: int(v) for k, v in self._cum.items()}}
        out.update({k: getattr(self, k) for k in ("E_impact", "E_splash", "bed_px", "bed_pz")})
        out["momentum_to_air"] = self.momentum_to_air.copy()
        return out

    def impact_record(self) -> dict:
        """The impact record since activation, summed over the runs (parcel counts)."""
        return {k: a.sum(axis=0) for k, a in zip(IMPACT_RECORD, self.impact_counts)}

    def fluid_at_parcels(self, state: FlowState) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Resolved fluid velocity (u_f, v_f, w_f) interpolated at every live parcel."""
        out = np.empty((3, self.n))
        fluid_at(self.n, self._x, self._y, self._z, state.u, state.v, state.w, self.geom.record,
                  out)
        return out[0], out[1], out[2]

    def grain_momentum(self) -> np.ndarray:
        """Total momentum of the grains, sum Q m_p u_p (3,) [kg m s^-1]."""
        m = self.Q * self.mass
        return np.array([np.sum(m * self.u), np.sum(m * self.v), np.sum(m * self.w)])

    # ---- checkpoint ------------------------------------------------------------------------
    #: scalars saved as grain_<key>: (key, attribute, type)
    _SCALARS = (("E_impact", "E_impact", float), ("E_splash", "E_splash", float),
                ("bed_px", "bed_px", float), ("bed_pz", "bed_pz", float),
                ("vmax", "_vmax", float), ("steps", "_steps", int),
                ("t_activation", "t_activation", float))

    def checkpoint(self) -> dict:
        """Flat dict of arrays and scalars, the RNG states as JSON: bit-for-bit resumable."""
        n = self.n
        data = {f"grain_{f}": getattr(self, "_" + f)[:n].copy() for f in self._FIELDS}
        data.update({f"grain_{k}": int(v) for k, v in self._cum.items()})
        data.update({f"grain_{key}": typ(getattr(self, attr)) for key, attr, typ in self._SCALARS})
        data.update({f"grain_impact_{name}": a.copy()
                     for name, a in zip(_LOG_NAMES, self.impact_counts)})
        data["grain_n"] = n
        data["grain_activated"] = int(self.activated)
        data["grain_momentum_to_air"] = self.momentum_to_air.copy()
        data["grain_rng_state"] = json.dumps(self.rng.bit_generator.state)
        data["grain_splash_rng_states"] = json.dumps([g.bit_generator.state
                                                      for g in self.splash_rngs])
        return data

    def restore(self, data: dict) -> None:
        n = int(data["grain_n"])
        self._alloc(max(1024, 2 * n, self.capacity))
        for f in self._FIELDS:
            getattr(self, "_" + f)[:n] = np.asarray(data[f"grain_{f}"], dtype=np.float64)
        self._flag[:n] = 0
        self.n = n
        self.rng.bit_generator.state = json.loads(str(data["grain_rng_state"]))
        for g, st in zip(self.splash_rngs, json.loads(str(data["grain_splash_rng_states"]))):
            g.bit_generator.state = st
        self.activated = bool(int(data["grain_activated"]))
        for k in self._cum:
            self._cum[k] = int(data[f"grain_{k}"])
        for key, attr, typ in self._SCALARS:
            setattr(self, attr, typ(data[f"grain_{key}"]))
        self.momentum_to_air = np.array(data["grain_momentum_to_air"], dtype=np.float64).reshape(3)
        for name, a in zip(_LOG_NAMES, self.impact_counts):
            a[...] = np.asarray(data[f"grain_impact_{name}"], dtype=np.int64).reshape(a.shape)
