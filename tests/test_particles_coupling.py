"""Two-way momentum exchange (paper eq. 2) and TKE sink (eq. A1)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from test_particles_helpers import G_INDEX, component, scene, synthetic_flow
from saltstudy.solver.grid import Grid
from saltstudy.solver.grains.particles import Saltation
from saltstudy.solver.state import FlowState


def _air_momentum(st):
    g = st.grid
    vol = g.dx * g.dy * g.dz_c
    rho = 1.2
    return np.array([rho * np.sum(st.u * vol), rho * np.sum(st.v * vol)])


def test_exchange_conserves_horizontal_momentum():
    """Closed periodic box, no gravity, frozen flow otherwise: air + grain horizontal momentum is
    conserved to round-off by the exchange, including parcels in the log-law layer (which see level
    1 and deposit on level 0). (Vertical momentum also goes partly to the bed face: by design.)"""
    sc = scene(7)  # 90 um, Q = 28000 * 20: a heavy loading
    s, st = component(sc, gravity=False)
    synthetic_flow(st, 0.57, 1e-5, amp=0.5)
    st.w[...] = 0.0  # no vertical motion: no parcel reaches the bed (splash is not an exchange)
    rng = np.random.default_rng(3)
    n = 4000
    g = s.grid
    z = np.concatenate([rng.uniform(6e-4, g.z_c[0], n // 4), rng.uniform(g.z_c[0], 0.5, 3 * n // 4)])
    s.add_parcels(rng.uniform(0, g.Lx, n), rng.uniform(0, g.Ly, n), z,
                  u=rng.normal(0, 2, n), v=rng.normal(0, 1, n), w=0.0,
                  d=rng.uniform(60e-6, 120e-6, n))
    p0 = _air_momentum(st) + s.grain_momentum()[:2]
    bound = max(np.abs(st.u).max(), np.abs(s.u).max())
    scale = np.abs(_air_momentum(st)).sum() + np.abs(s.Q * s.mass * s.u).sum()
    for _ in range(40):
        s.dynamics(st, 0.01)
    assert s.counters()["n_impacts"] == 0
    p1 = _air_momentum(st) + s.grain_momentum()[:2]
    assert np.all(np.abs(p1 - p0) <= 1e-12 * scale), (p1 - p0) / scale
    # the exchange did something
    assert abs(s.counters()["momentum_to_air"][0]) > 1e-3 * scale
    assert np.abs(st.u).max() <= 1.05 * bound  # and stable: no new extremes


def test_heavily_loaded_cells_relax_monotonically():
    """Grain mass 100x the air mass in every cell above the first: air and grains relax to the
    common velocity without overshoot, even with dt >> T_p. Each grain reads and loads its own
    cell (the first cell's grains read and load the second level: tests/test_particles_nearbed.py);
    the first level's air is untouched."""
    sc = scene(7, physics={"tke_particle_sink": False})
    grid = Grid.uniform(4, 4, 4, 0.4, 0.4, 0.4)
    st = FlowState.zeros(grid)
    s = Saltation(grid, sc)
    s.prm[G_INDEX] = 0.0
    U0 = 4.0
    st.u[...] = U0
    # one parcel at every cell centre above the first cell: every u face there gets the same load
    xc, yc, zc = np.meshgrid(grid.x_c, grid.y_c, grid.z_c[1:], indexing="ij")
    d = 90e-6
    m_air = 1.2 * grid.dx * grid.dy * grid.dz_c[0]
    m_p = math.pi / 6 * 2650 * d ** 3
    s.Q = 100 * m_air / m_p
    s.prm[4] = s.Q
    s.add_parcels(xc.ravel(), yc.ravel(), zc.ravel(), d=d)
    V = (m_air * U0) / (m_air + 100 * m_air)                 # common velocity
    tp = 2650 * d * d / (18 * 1.2 * 1.5e-5)
    ua, up = [U0], [0.0]
    for _ in range(30):
        s.dynamics(st, 2 * tp)
        assert np.all(st.u[:, :, 0] == U0)
        ua.append(st.u[:, :, 1:].mean())
        up.append(s.u.mean())
        assert np.ptp(st.u[:, :, 1:]) < 1e-10 and np.ptp(s.u) < 1e-10  # stays homogeneous
    ua, up = np.array(ua), np.array(up)
    assert np.all(np.diff(ua) <= 1e-12) and np.all(np.diff(up) >= -1e-12)   # monotone
    assert ua.min() >= V - 1e-12 and up.max() <= V + 1e-12                    # no overshoot
    assert abs(ua[-1] - V) < 1e-6 and abs(up[-1] - V) < 1e-6
    # momentum of the pair conserved
    tot = m_air * ua * grid.nx * grid.ny * (grid.nz - 1) + s.Q * m_p * up * s.n
    assert np.all(np.abs(tot - tot[0]) < 1e-12 * tot[0])


def test_one_way_switch_leaves_air_untouched():
    sc = scene(2, physics={"two_way_coupling": False, "tke_particle_sink": False})
    s, st = component(sc)
    synthetic_flow(st, 0.54, 1e-5)
    u0 = st.u.copy()
    s.activate(st)
    for _ in range(5):
        s.dynamics(st, 0.01)
    assert np.array_equal(st.u, u0) and st.tke_sink is None


def test_tke_sink_rate_matches_eq_A1():
    """One parcel in a cell of known e: the rate equals (Q/V)(m_p/rho) 2 f/(T_p + T_L)."""
    sc = scene(2, physics={"two_way_coupling": False})
    s, st = component(sc, gravity=False)
    st.e[...] = 0.2
    g = s.grid
    k = 3
    d = 200e-6
    s.add_parcels([0.55], [0.45], [g.z_c[k]], d=d)  # at rest in still air: f = 1
    s.dynamics(st, 1e-3)
    i, j = int(0.55 / g.dx), int(0.45 / g.dy)
    tp = 2650 * d * d / (18 * 1.2 * 1.5e-5)
    tl = s.tlc[k] / math.sqrt(0.2)
    m_p = math.pi / 6 * 2650 * d ** 3
    expect = s.Q / (g.dx * g.dy * g.dz_c[k]) * m_p / 1.2 * 2 * 1.0 / (tp + tl)
    assert abs(st.tke_sink[i, j, k] - expect) / expect < 1e-9
    assert np.count_nonzero(st.tke_sink) == 1


def test_tke_rates_clear_the_levels_a_step_no_longer_reaches_and_a_restored_array():
    """tke_rates writes only the levels parcels may reach (and those the last step reached):
    when the parcels sink, the higher rates are cleared; an array the component has not filled
    before (a restart's) is cleared in full."""
    sc = scene(2, physics={"two_way_coupling": False})
    s, st = component(sc, gravity=False)
    st.e[...] = 0.2
    g = s.grid
    s.add_parcels([0.55], [0.45], [g.z_c[10]], d=200e-6)
    s.dynamics(st, 1e-3)
    assert np.count_nonzero(st.tke_sink[:, :, 10]) == 1
    s._z[0] = g.z_c[1]  # the parcel now low: its old level must not keep its rate
    s.dynamics(st, 1e-3)
    assert np.count_nonzero(st.tke_sink) == 1 and np.count_nonzero(st.tke_sink[:, :, 1]) == 1
    st.tke_sink = np.full(g.shape, 7.0)  # as restored from a checkpoint
    s.dynamics(st, 1e-3)
    assert np.count_nonzero(st.tke_sink) == 1 and np.count_nonzero(st.tke_sink[:, :, 1]) == 1


def test_exchange_conserves_momentum_with_fast_parcels_across_the_periodic_boundary():
    """Parcels several cells per step fast, in both directions, near x = 0 and x = Lx (the
    chunks' deposit buffers cover only their x-slabs plus the distance a parcel can travel):
    the exchange still conserves horizontal momentum to round-off, whatever the parcel order."""
    sc = scene(7)
    s, st = component(sc, gravity=False)
    synthetic_flow(st, 0.57, 1e-5, amp=0.5)
    st.w[...] = 0.0
    g = s.grid
    rng = np.random.default_rng(8)
    n = 3000
    x = np.concatenate([rng.uniform(0, 2 * g.dx, n // 2), rng.uniform(g.Lx - 2 * g.dx, g.Lx, n // 2)])
    dt = 0.01
    s.add_parcels(x, rng.uniform(0, g.Ly, n), rng.uniform(g.z_c[0], 0.3, n),
                  u=rng.choice([-1.0, 1.0], n) * rng.uniform(1, 4, n) * g.dx / dt,
                  v=rng.normal(0, 1, n), w=0.0, d=rng.uniform(60e-6, 120e-6, n))
    p0 = _air_momentum(st) + s.grain_momentum()[:2]
    scale = np.abs(_air_momentum(st)).sum() + np.abs(s.Q * s.mass * s.u).sum()
    for _ in range(5):
        s.dynamics(st, dt)
    assert s.counters()["n_impacts"] == 0
    p1 = _air_momentum(st) + s.grain_momentum()[:2]
    assert np.all(np.abs(p1 - p0) <= 1e-12 * scale), (p1 - p0) / scale
    assert np.all(np.isfinite(st.u)) and np.all((s.x >= 0) & (s.x < g.Lx))


def test_chunk_assign_partitions_live_parcels_into_slab_runs():
    """chunk_assign against a plain numpy reference: every live parcel (flag 0) in exactly one
    chunk, in increasing index order, inside its chunk's slabs; the chunks' slab runs tile the
    domain with about n / N_CHUNKS parcels each; the per-chunk maxima are those of its parcels,
    and the parcel maxima those of the live parcels."""
    from saltstudy.solver.grains.coupling import N_CHUNKS, chunk_assign

    rng = np.random.default_rng(7)
    n, nx, dx = 5000, 40, 0.25
    # clustered in x (uneven slabs), a few parcels dead or pending
    x = np.concatenate([rng.uniform(0, nx * dx, n // 2), rng.normal(3.0, 0.4, n - n // 2)])
    x = np.mod(x, nx * dx)
    u = rng.normal(2.0, 1.5, n)
    trem = np.where(rng.random(n) < 0.1, rng.uniform(0, 1e-3, n), 0.0)
    flag = np.where(rng.random(n) < 0.05, rng.choice([-1, 1], n), 0).astype(np.int8)
    hist = np.zeros(nx, dtype=np.int64)
    slab_stats = np.zeros((nx, 2))
    bounds = np.zeros(2 * N_CHUNKS + 1, dtype=np.int64)
    cid = np.zeros(n, dtype=np.int64)
    cstart = np.zeros(N_CHUNKS + 1, dtype=np.int64)
    idx = np.full(n, -1, dtype=np.int64)
    stats = np.zeros((N_CHUNKS, 2))
    v = rng.normal(0.0, 1.0, n)
    w = rng.normal(0.0, 1.0, n)
    z = rng.uniform(0.0, 0.5, n)
    pmax = np.zeros(3)
    chunk_assign(n, x, u, flag, trem, dx, nx, hist, slab_stats, bounds, cid, cstart, idx, stats,
                 v, w, z, pmax)

    live = np.flatnonzero(flag == 0)
    slab = np.floor(x / dx).astype(int) % nx
    assert bounds[0] == 0 and bounds[N_CHUNKS] == nx
    assert np.all(np.diff(bounds[:N_CHUNKS + 1]) >= 0)
    assert cstart[0] == 0 and cstart[N_CHUNKS] == live.size
    filed = idx[:live.size]
    np.testing.assert_array_equal(np.sort(filed), live)
    per_slab = np.bincount(slab[live], minlength=nx)
    for c in range(N_CHUNKS):
        lo, hi = bounds[c], bounds[c + 1]
        mine = idx[cstart[c]:cstart[c + 1]]
        assert np.all(np.diff(mine) > 0)
        assert np.all((slab[mine] >= lo) & (slab[mine] < hi))
        # balanced up to one slab's worth of parcels
        assert abs(mine.size - live.size / N_CHUNKS) <= per_slab.max()
        if mine.size:
            assert stats[c, 0] == np.abs(u[mine]).max()
            assert stats[c, 1] == trem[mine].max()
    # the live parcels' maxima for the step's levels and speed limit (Saltation._levels)
    assert pmax[0] == np.maximum(np.abs(u[live]), np.abs(v[live])).max()
    assert pmax[1] == z[live].max()
    assert pmax[2] == pytest.approx(np.sqrt((u[live] ** 2 + v[live] ** 2 + w[live] ** 2).max()),
                                    rel=1e-15)


def test_implicit_estimate_in_lanes_matches_one_parcel_at_a_time():
    """implicit_coefficients computes its estimates in blocks of lanes (expm1 and the weights
    vectorized, an exact redo for the lanes beyond expm1's polynomial): its (A, B) on the faces
    and the first drag rates it stores equal those of the estimate one parcel at a time
    (implicit_estimate and the deposits of coupling.py's module doc) to round-off. Parcels with
    and without a drag rate, in and above the log region, k T within and beyond the
    polynomial's range, time credits, a partial last block."""
    from saltstudy.solver.grains import coupling
    from saltstudy.solver.grains.coupling import (Flow, drag_rate, implicit_estimate, interp_fluid,
                                                  locate, parcel_weight, pool_add_tri2)

    sc = scene(2)
    s, st = component(sc)
    synthetic_flow(st, 0.54, sc.case.surface.z0)
    g = st.grid
    rng = np.random.default_rng(3)
    n = 3 * coupling.EST_LANES + 17
    s.add_parcels(rng.uniform(0, g.Lx, n), rng.uniform(0, g.Ly, n), rng.uniform(6e-4, 0.3, n),
                  u=rng.uniform(0, 4, n), v=rng.normal(0, 0.3, n), w=rng.normal(0, 1, n),
                  d=np.where(rng.random(n) < 0.5, 2e-4, 5e-5))
    # no drag rate yet (released, splashed), or one with k dt from 0.005 to 15
    s._kd[:n] = np.where(rng.random(n) < 0.3, 0.0, np.exp(rng.uniform(0, 8, n)))
    s._trem[:n] = np.where(rng.random(n) < 0.2, rng.uniform(0, 4e-3, n), 0.0)
    dt = 0.004
    assert np.any(s._kd[:n] * dt > coupling.EXPM1_TAYLOR_MAX)
    s._work_init()
    nx, ny, nz = g.shape
    coupling.chunk_assign(n, s._x, s._u, s._flag, s._trem, g.dx, nx, s._hist,
                          s._slab_stats, s._bounds, s._cid, s._cstart, s._idx, s._stats, s._v,
                          s._w, s._z, s._pmax)
    nk = s._levels(st, dt)
    du, dv, dw, Uc, Vc, Wc = s._grid_views(nk)
    P = s._parcels()
    F = Flow(st.u, st.v, st.w, st.e, s.tlc, Uc, Vc, Wc, du, dv, dw)
    s._margin[:] = 2
    s._layout(s._margin, 3 * 2 * ny * nk)
    s.prm[8] = dt
    kd0 = s._kd.copy()
    coupling.implicit_coefficients(s._cstart, s._idx, P, F, dt, s.prm, s.geom.record, s._pool,
                                   s._ranges, nk, s._lane_f, s._lane_i)
    lanes, kd_lanes = s._pool.copy(), s._kd.copy()

    # one parcel at a time, as the estimate's formulas read
    s._kd[:] = kd0
    pool = np.zeros_like(s._pool)
    G = s.geom.record
    rho, nu, grav, rho_p, Q = s.prm[:5]
    for c in range(coupling.N_CHUNKS):
        sl, L, off = s._ranges[c]
        csz = L * ny * nk * 2
        for q in range(s._cstart[c], s._cstart[c + 1]):
            p = int(s._idx[q])
            stc = locate(s._x[p], s._y[p], s._z[p], G, nx, ny, nz)
            dp, k = s._d[p], s._kd[p]
            if k <= 0.0:
                ur, vr, wr = interp_fluid(st.u, st.v, st.w, stc, nx, ny)
                rel = math.sqrt((ur - s._u[p]) ** 2 + (vr - s._v[p]) ** 2 + (wr - s._w[p]) ** 2)
                k = drag_rate(rel, dp / nu, rho_p * dp * dp / (18.0 * rho * nu))
                s._kd[p] = -k
            T = dt + s._trem[p]
            _, cp, wt = implicit_estimate(k, T, parcel_weight(Q, rho_p, dp), s._w[p], grav)
            ah = cp * stc.lfac   # the log law's factor in the log region, 1 above it
            pool_add_tri2(pool, off, sl, nx, ny, nk, ah, cp * s._u[p], stc.ixf, stc.fxf,
                          stc.jyc, stc.fyc, stc.kc, stc.fzc)
            pool_add_tri2(pool, off + csz, sl, nx, ny, nk, ah, cp * s._v[p], stc.ixc,
                          stc.fxc, stc.jyf, stc.fyf, stc.kc, stc.fzc)
            pool_add_tri2(pool, off + 2 * csz, sl, nx, ny, nk, cp, cp * wt, stc.ixc, stc.fxc,
                          stc.jyc, stc.fyc, stc.kf, stc.fzf)
    # (helpers compiled on their own, not inlined: LLVM may contract their arithmetic otherwise)
    np.testing.assert_allclose(kd_lanes, s._kd, rtol=1e-14, atol=0)
    assert np.any(kd_lanes[:n] < 0) and np.any(kd_lanes[:n] > 0)
    scale = np.abs(pool).max()
    assert scale > 0.0
    np.testing.assert_allclose(lanes, pool, rtol=1e-13, atol=1e-15 * scale)
