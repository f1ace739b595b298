"""Splash scheme (paper eqs. 5-9): sampled statistics, energy budget, bed crossing."""
from __future__ import annotations

import math

import numpy as np
import pytest

from test_particles_helpers import component, scene, terminal_velocity
from saltstudy._jit import jit
from saltstudy.config import load_case
from saltstudy.physics.soil import draw_diameter, soil_arrays
from saltstudy.physics.splash import draw_ejectum, draw_impact, splash_constants


def _params(case):
    return splash_constants(case.splash, case.soil, case.air.g), *soil_arrays(case.soil)


@jit
def sample_impacts(rng, v_imp, d_imp, n_imp, sp, cum, mu, lnsig):
    """``n_imp`` impacts at speed ``v_imp`` by the bed events' draws: (n_rebounds, sum of v_reb,
    n_ejecta, sum of v_ej, sum over the impacts of the splash kinetic energy over the impact
    energy of a grain of diameter ``d_imp`` (<= 0: drawn from the soil for each impact))."""
    nreb = 0
    svr = 0.0
    nej_tot = 0
    sve = 0.0
    ratio = 0.0
    for _ in range(n_imp):
        di = d_imp if d_imp > 0.0 else draw_diameter(rng, cum, mu, lnsig)
        e_out = 0.0
        reb, vr, av, ah, nej = draw_impact(rng, v_imp, v_imp, sp)
        if reb:
            nreb += 1
            svr += vr
            e_out += di ** 3 * vr * vr
        for _k in range(nej):
            dq, ve, av, ah = draw_ejectum(rng, v_imp, sp, cum, mu, lnsig)
            nej_tot += 1
            sve += ve
            e_out += dq ** 3 * ve * ve
        ratio += e_out / (di ** 3 * v_imp * v_imp)
    return nreb, svr, nej_tot, sve, ratio


def _truncated_normal_mean(m, s):
    """Mean of N(m, s^2) conditioned on >= 0."""
    a = -m / s
    phi = math.exp(-0.5 * a * a) / math.sqrt(2 * math.pi)
    Phi = 0.5 * math.erfc(-a / math.sqrt(2))
    return m + s * phi / (1 - Phi)


@pytest.mark.parametrize("v_imp", [0.5, 2.0, 4.0])
def test_sampled_splash_matches_eqs_6_to_9(v_imp):
    case = load_case(2)
    sp, cum, mu, lns = _params(case)
    n = 100_000
    rng = np.random.Generator(np.random.PCG64(12345))
    nreb, svr, nej, sve, _ = sample_impacts(rng, v_imp, 2e-4, n, sp, cum, mu, lns)
    p = 0.95 * (1 - math.exp(-2.0 * v_imp))                                   # eq. 6
    assert abs(nreb / n - p) < 4 * math.sqrt(p * (1 - p) / n)
    m_reb = _truncated_normal_mean(0.6 * v_imp, 0.25 * v_imp)                # eq. 7
    assert abs(svr / nreb - m_reb) < 4 * 0.25 * v_imp / math.sqrt(nreb)
    nbar = 0.03 * v_imp / math.sqrt(case.air.g * case.soil.mean_diameter)    # eq. 8
    # stochastic rounding: variance of N_ej is frac (1 - frac) per impact
    fr = nbar - math.floor(nbar)
    assert abs(nej / n - nbar) < 4 * math.sqrt(max(fr * (1 - fr), 1e-12) / n) + 1e-12
    if nej > 1000:
        assert abs(sve / nej - 0.08 * v_imp) < 4 * 0.08 * v_imp / math.sqrt(nej)  # eq. 9


@pytest.mark.parametrize("number", list(range(1, 11)))
def test_mean_splash_energy_below_impact_energy(number):
    """Paper sec. 2.3: on average rebound + ejecta energy <= impact energy (impactor and ejecta
    diameters from the soil), for impact speeds 0.5-5 m/s."""
    case = load_case(number)
    sp, cum, mu, lns = _params(case)
    rng = np.random.Generator(np.random.PCG64(7))
    for v in np.linspace(0.5, 5.0, 10):
        n = 20_000
        *_, ratio = sample_impacts(rng, float(v), -1.0, n, sp, cum, mu, lns)
        assert ratio / n < 1.0, (number, v, ratio / n)


def test_small_grain_soil_energy_budget():
    """A 20 um soil ejects many grains per impact (eq. 8 ~ 1/sqrt(d)); still within budget to 5 m/s."""
    case = load_case(7, overrides={"soil": {"modes": [{"mu": 20e-6}]}})
    sp, cum, mu, lns = _params(case)
    rng = np.random.Generator(np.random.PCG64(8))
    *_, ratio = sample_impacts(rng, 5.0, -1.0, 20_000, sp, cum, mu, lns)
    assert ratio / 20_000 < 1.0


def test_bed_crossing_located_exactly():
    """A grain at its terminal velocity hits the impact layer at the analytic time and speed."""
    sc = scene(2, physics={"two_way_coupling": False, "tke_particle_sink": False})
    s, st = component(sc)
    air = sc.case.air
    d = 200e-6
    wt = terminal_velocity(d, 2650.0, air.rho, air.nu, air.g)
    z0 = 0.05
    s.add_parcels([1.0], [0.5], [z0], w=-wt, d=d)
    s._kd[0] = (1 + 0.15 * (wt * d / air.nu) ** 0.687) / (2650 * d * d / (18 * air.rho * air.nu))
    t_hit = (z0 - 5e-4) / wt
    dt = 0.004
    steps = int(t_hit / dt)
    for _ in range(steps):
        s.dynamics(st, dt)
    assert s.counters()["n_impacts"] == 0
    assert abs(s.z[0] - (z0 - steps * dt * wt)) < 1e-9
    s.dynamics(st, dt)
    c = s.counters()
    assert c["n_impacts"] == 1
    m = math.pi / 6 * 2650 * d ** 3
    assert abs(c["E_impact"] - s.Q * 0.5 * m * wt * wt) / c["E_impact"] < 1e-8
    assert c["n_rebounds"] + c["n_depositions"] == 1
    assert s.n == c["n_rebounds"] + c["n_ejections"]
    assert np.all(s.z >= 5e-4 - 1e-15)


def test_splash_runs_keep_the_books_of_a_step_with_many_impacts():
    """A step where hundreds of grains hit the bed at once (so every run of impacts has some):
    each counts once, parcels = before + ejections - depositions, every ejectum and rebound is
    a live grain on the impact layer with an upward launch and a soil diameter, and nothing of
    the closed-up stretches is left behind (no duplicates, no stale slots)."""
    from saltstudy.solver.grains.particles import N_SPLASH_RUNS

    sc = scene(2, physics={"two_way_coupling": False, "tke_particle_sink": False})
    s, st = component(sc)
    rng = np.random.default_rng(11)
    m = 600
    s.add_parcels(rng.uniform(0, 2.4, m), rng.uniform(0, 1.6, m), rng.uniform(6e-4, 2e-3, m),
                  u=rng.uniform(2, 5, m), v=rng.normal(0, 0.5, m), w=-rng.uniform(1.0, 3.0, m),
                  d=2e-4)
    s.add_parcels([1.0], [0.5], [0.2], d=2e-4)  # one that does not reach the bed
    n0 = s.n
    s.dynamics(st, 0.004)
    c = s.last_step
    assert c["n_impacts"] == m
    assert c["n_impacts"] > 10 * N_SPLASH_RUNS
    assert c["n_rebounds"] + c["n_depositions"] == m
    assert c["n_ejections"] > 0
    assert s.n == n0 + c["n_ejections"] - c["n_depositions"]
    h_imp = sc.case.splash.impact_layer
    on_bed = s.z == h_imp
    assert on_bed.sum() == c["n_rebounds"] + c["n_ejections"]
    assert np.all(s.w[on_bed] > 0.0)
    assert np.all(np.isfinite(s.x[:s.n])) and np.all(s.d > 0.0)
    assert np.all(s._flag[:s.n] == 0)
    # every grain is distinct (a slot copied twice would repeat its whole state)
    state = np.stack([s.x, s.y, s.z, s.u, s.v, s.w, s.d], axis=1)
    assert np.unique(state, axis=0).shape[0] == s.n
    assert np.any((s.x == 1.0) & (s.y == 0.5) & (s.z < 0.2))


def test_impact_record_gives_the_replacement_number_of_eqs_6_and_8():
    """A synthetic set of impacts at three speeds (one step, every grain at the bed): the record
    counts each impact in its speed and angle bin, and per speed bin the rebounds and ejecta per
    impact (the replacement number) match P_reb + N_ej of eqs. 6 and 8 within the binomial
    noise; the totals equal the step's counters."""
    from saltstudy.solver.grains.splash_kernels import IMPACT_ANGLE_BIN, IMPACT_SPEED_BIN

    sc = scene(2, physics={"two_way_coupling": False, "tke_particle_sink": False})
    s, st = component(sc, gravity=False)
    rng = np.random.default_rng(5)
    speeds, angle = (0.55, 1.55, 3.05), 13.0       # bin centres of 0.1 m/s and 2 deg bins
    m = 4000
    for v in speeds:
        a = math.radians(angle)
        s.add_parcels(rng.uniform(0, 2.4, m), rng.uniform(0, 1.6, m), np.full(m, 5.5e-4),
                      u=v * math.cos(a), w=-v * math.sin(a), d=2e-4)
    s.dynamics(st, 1e-3)
    rec, c = s.impact_record(), s.last_step
    assert rec["impact_outcomes"][:, 0].sum() == c["n_impacts"] == 3 * m
    assert rec["impact_outcomes"][:, 1].sum() == c["n_rebounds"]
    assert rec["impact_outcomes"][:, 2].sum() == c["n_ejections"]
    assert rec["impact_hist"].sum() == 3 * m
    ia = int(angle / IMPACT_ANGLE_BIN)
    g, dmean = sc.case.air.g, sc.case.soil.mean_diameter
    for v in speeds:
        iv = int(v / IMPACT_SPEED_BIN)
        # the grains slow a little in the 1e-3 s before they cross the layer: one bin
        row = rec["impact_outcomes"][iv]
        assert row[0] == m and rec["impact_hist"][iv, ia] == m
        p = 0.95 * (1 - math.exp(-2.0 * v))
        nbar = 0.03 * v / math.sqrt(g * dmean)
        sd = math.sqrt((p * (1 - p) + 0.25) / m)
        assert row[1] / m + row[2] / m == pytest.approx(p + nbar, abs=4 * sd)
    assert rec["hop_time_hist"].sum() == 0    # these grains were not launched by a splash


def test_impact_record_measures_the_hops_a_splash_launched():
    """Grains launched by a rebound or an ejection and landing again: their hops are counted
    once each, with flight times and lengths of a short hop; the record survives a checkpoint."""
    from saltstudy.solver.grains.splash_kernels import HOP_LENGTH_BIN, HOP_TIME_BIN

    sc = scene(2, physics={"two_way_coupling": False, "tke_particle_sink": False})
    s, st = component(sc)
    rng = np.random.default_rng(2)
    m = 2000
    s.add_parcels(rng.uniform(0, 2.4, m), rng.uniform(0, 1.6, m), np.full(m, 6e-4), u=2.0,
                  w=-1.0, d=2e-4)
    for _ in range(150):                      # 0.3 s in still air: every launched grain lands
        s.dynamics(st, 2e-3)
        st.t += 2e-3                          # (Model.step advances the clock)
    rec = s.impact_record()
    out = rec["impact_outcomes"].sum(axis=0)
    launched_and_landed = out[0] - m          # impacts by grains a splash launched
    assert launched_and_landed > 0
    assert rec["hop_time_hist"].sum() == rec["hop_length_hist"].sum() == launched_and_landed
    t = (np.arange(rec["hop_time_hist"].size) + 0.5) * HOP_TIME_BIN
    mean_t = float(np.sum(t * rec["hop_time_hist"]) / rec["hop_time_hist"].sum())
    # rebounds leave at ~0.6 x 1 m/s and 30 deg, ejecta slower: flights of order 2 w / g
    assert 0.005 < mean_t < 0.1
    L = (np.arange(rec["hop_length_hist"].size) + 0.5) * HOP_LENGTH_BIN
    assert float(np.sum(L * rec["hop_length_hist"]) / rec["hop_length_hist"].sum()) < 0.05
    s2, _ = component(sc)
    s2.restore(s.checkpoint())
    for k, v in s2.impact_record().items():
        assert np.array_equal(v, rec[k]), k


def test_a_parcel_placed_inside_the_impact_layer_splashes_in_its_first_step():
    """A parcel below the impact layer's top (add_parcels at 0.2 mm) is met by the bed at once,
    at its velocity, with the whole step as its credit: one impact, the books kept, and whatever
    leaves the bed starts on the layer's top."""
    sc = scene(2, physics={"two_way_coupling": False, "tke_particle_sink": False})
    s, st = component(sc, gravity=False)
    s.add_parcels([1.0], [0.5], [2e-4], u=1.5, w=-0.5, d=2e-4)
    s.add_parcels([1.2], [0.5], [0.2], d=2e-4)       # one above, untouched by the bed
    s.dynamics(st, 1e-3)
    c = s.last_step
    assert c["n_impacts"] == 1 and c["n_rebounds"] + c["n_depositions"] == 1
    assert s.n == 2 + c["n_ejections"] - c["n_depositions"]
    assert np.all((s.z == sc.case.splash.impact_layer) | (s.z > 0.19))

