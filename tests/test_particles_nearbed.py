"""The wind a grain sees in the first grid cell and where its drag goes: the paper's [12].

In the whole first cell (z < z_f[1]) the log law from the second level, the drag (momentum and
TKE sink) back to the second level; trilinear above (solver/grains/interp.py).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from test_particles_helpers import component, scene, synthetic_flow
from saltstudy.solver.grid import Grid
from saltstudy.solver.grains.particles import Saltation
from saltstudy.solver.state import FlowState

KAPPA = 0.4
RHO = 1.2


def _scene(case: int = 2, **physics):
    return scene(case, physics=physics) if physics else scene(case)


def _air_momentum(st):
    g = st.grid
    vol = g.dx * g.dy * g.dz_c
    return np.array([RHO * np.sum(st.u * vol), RHO * np.sum(st.v * vol)])


def test_coupling_conserves_horizontal_momentum_in_the_first_cell():
    """(a) Grains in the first cell (and some above it), heavy loading, two-way: the air's
    momentum change plus the grains' is zero to round-off, and the exchange did something; the
    grains load the level they read, so the loaded air and the grains relax together (no new
    extremes)."""
    s, st = component(_scene(7), gravity=False)
    synthetic_flow(st, 0.57, 1e-5, amp=0.5)
    st.w[...] = 0.0  # no vertical motion: no grain reaches the bed (splash is no exchange)
    g = s.grid
    rng = np.random.default_rng(11)
    n = 4000
    z = np.concatenate([rng.uniform(6e-4, g.z_f[1], 3 * n // 4),
                        rng.uniform(g.z_f[1], 0.3, n // 4)])
    s.add_parcels(rng.uniform(0, g.Lx, n), rng.uniform(0, g.Ly, n), z,
                  u=rng.normal(0, 2, n), v=rng.normal(0, 1, n), w=0.0,
                  d=rng.uniform(60e-6, 120e-6, n))
    p0 = _air_momentum(st) + s.grain_momentum()[:2]
    scale = np.abs(_air_momentum(st)).sum() + np.abs(s.Q * s.mass * s.u).sum()
    bound = max(np.abs(st.u).max(), np.abs(s.u).max())
    for _ in range(30):
        s.dynamics(st, 0.01)
    assert s.counters()["n_impacts"] == 0
    assert np.all(s.z < 0.3 + 1e-12)
    p1 = _air_momentum(st) + s.grain_momentum()[:2]
    assert np.all(np.abs(p1 - p0) <= 1e-12 * scale), (p1 - p0) / scale
    assert abs(s.counters()["momentum_to_air"][0]) > 1e-3 * scale
    assert np.abs(st.u).max() <= 1.05 * bound  # stable: no new extremes


def test_wind_seen_in_the_first_cell_of_a_log_law_wind():
    """(b) A horizontally uniform wind u(z) = u*/kappa ln(z/z0) on the staggered grid: grains at
    several heights in the first cell see the log law itself (to round-off), both in the
    interpolation the diagnostics use and in the step (10 um grains, dt >> T_p: they end the step
    at the wind they see)."""
    sc = _scene(two_way_coupling=False, tke_particle_sink=False)
    s, st = component(sc, gravity=False)
    g = s.grid
    z0, us = sc.case.surface.z0, 0.54
    st.u[...] = us / KAPPA * np.log(g.z_c / z0)
    st.w[...] = 0.0
    assert g.z_c[0] < g.z_f[1] < g.z_c[1]
    zs = np.array([0.06, 0.2, 0.45, 0.55, 0.8, 0.99]) * g.z_f[1]
    n = zs.size
    s.add_parcels(np.full(n, 0.3), np.full(n, 0.2), zs, d=10e-6)
    law = us / KAPPA * np.log(zs / z0)
    seen, vseen, wseen = s.fluid_at_parcels(st)
    s.dynamics(st, 1.0)  # k_p dt ~ 1200: exp(-k_p dt) = 0, the grain at the seen wind
    order = np.argsort(s.z)
    assert np.array_equal(s.z[order], zs)  # no vertical motion (w = 0, no gravity)
    stepped = s.u[order]
    assert np.all(vseen == 0.0) and np.all(wseen == 0.0)
    np.testing.assert_allclose(seen, law, rtol=1e-14, atol=0)
    np.testing.assert_allclose(stepped, law, rtol=1e-14, atol=0)


def test_wind_is_discontinuous_at_the_first_cell_top_by_the_documented_amount():
    """Across z_f[1] the wind goes from the log law to the linear value between the first two
    levels: in an exact log profile the latter is lower by (interp.py's doc) 2-3 %."""
    sc = _scene(two_way_coupling=False, tke_particle_sink=False)
    s, st = component(sc)
    g = s.grid
    z0 = sc.case.surface.z0
    st.u[...] = 0.54 / KAPPA * np.log(g.z_c / z0)
    eps = 1e-9
    s.add_parcels([0.3, 0.3], [0.2, 0.2], [g.z_f[1] * (1 - eps), g.z_f[1] * (1 + eps)])
    u = s.fluid_at_parcels(st)[0]
    jump = u[1] / u[0] - 1
    f = (g.z_f[1] - g.z_c[0]) / (g.z_c[1] - g.z_c[0])
    L = np.log(np.array([g.z_c[0], g.z_f[1], g.z_c[1]]) / z0)
    assert jump == pytest.approx(((1 - f) * L[0] + f * L[2]) / L[1] - 1, abs=1e-7)
    assert -0.03 < jump < -0.015


@pytest.mark.parametrize("frac", [0.3, 0.8])
def test_drag_of_a_grain_in_the_first_cell_goes_to_the_level_it_reads(frac):
    """(c) One grain at rest in a uniform wind, at frac * z_f[1] (below / above z_c[0] = z_f[1]/2):
    the air's momentum change is on level 1 only (the level the log law reads) and minus the
    grain's, to round-off; the TKE sink is in the level-1 cell."""
    s, st = component(_scene(), gravity=False)
    g = s.grid
    st.u[...] = 5.0
    st.e[...] = 0.2
    st.tke_sink = np.zeros(g.shape)
    assert g.z_c[0] == pytest.approx(0.5 * g.z_f[1])
    s.add_parcels([0.55], [0.45], [frac * g.z_f[1]], d=200e-6)
    u0 = st.u.copy()
    s.dynamics(st, 1e-3)
    du = st.u - u0
    changed = set(np.flatnonzero(np.any(du != 0.0, axis=(0, 1))).tolist())
    assert changed == {1}
    air = np.sum(du * RHO * g.dx * g.dy * g.dz_c)
    grain = s.Q * s.mass[0] * s.u[0]
    assert grain > 0 and abs(air + grain) <= 1e-12 * grain
    i, j = int(0.55 / g.dx), int(0.45 / g.dy)
    k = 1
    assert np.flatnonzero(st.tke_sink).tolist() == [np.ravel_multi_index((i, j, k), g.shape)]
    tp = 2650 * (200e-6) ** 2 / (18 * RHO * 1.5e-5)
    tl = s.tlc[k] / math.sqrt(0.2)
    f = s._kd[0] * tp  # f(Re_p) of the step's drag rate
    expect = s.Q / g.cell_volume[k] * s.mass[0] / RHO * 2 * f / (tp + tl)
    assert st.tke_sink[i, j, k] == pytest.approx(expect, rel=1e-9)


def test_heavily_loaded_first_cell_relaxes_monotonically():
    """Grain mass 100x the air's in every first-cell column: the level-1 air and the
    grains relax, without overshoot, to the common state in which the grains move at the log law
    of the level-1 air, u_p = l U_1, with momentum conserved (the implicit exchange's weights are
    l w_pf, coupling.py)."""
    sc = _scene(7, tke_particle_sink=False)
    grid = Grid.uniform(4, 4, 4, 0.4, 0.4, 0.4)
    st = FlowState.zeros(grid)
    s = Saltation(grid, sc)
    s.prm[2] = 0.0  # no gravity
    U0 = 4.0
    st.u[...] = U0
    xc, yc = np.meshgrid(grid.x_c, grid.y_c, indexing="ij")
    z = 0.5 * grid.z_f[1]
    d = 90e-6
    m_air = RHO * grid.dx * grid.dy * grid.dz_c[1]
    m_p = math.pi / 6 * 2650 * d ** 3
    s.Q = 100 * m_air / m_p
    s.prm[4] = s.Q
    s.add_parcels(xc.ravel(), yc.ravel(), z, d=d)
    lf = math.log(z / sc.case.surface.z0) / math.log(grid.z_c[1] / sc.case.surface.z0)
    V = m_air * U0 / (m_air + 100 * m_air * lf)  # level-1 air at equilibrium; grains at lf V
    tp = 2650 * d * d / (18 * RHO * 1.5e-5)
    ua, up = [U0], [0.0]
    for _ in range(30):
        s.dynamics(st, 2 * tp)
        assert np.all(st.u[:, :, [0, 2, 3]] == U0)  # only level 1 is touched
        ua.append(st.u[:, :, 1].mean())
        up.append(s.u.mean())
        assert np.ptp(st.u[:, :, 1]) < 1e-10 and np.ptp(s.u) < 1e-10
    ua, up = np.array(ua), np.array(up)
    assert np.all(np.diff(ua) <= 1e-12) and np.all(np.diff(up) >= -1e-12)
    assert ua.min() >= V - 1e-12 and up.max() <= lf * V + 1e-12
    assert abs(ua[-1] - V) < 1e-6 and abs(up[-1] - lf * V) < 1e-6
    tot = m_air * ua * grid.nx * grid.ny + s.Q * m_p * up * s.n
    assert np.all(np.abs(tot - tot[0]) < 1e-12 * tot[0])
