"""The layer's momentum balance at the bed: the impact record's momentum, mu_b two ways, and the
readings of the text on the bed (normal impact speed)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from test_particles_helpers import component, scene
from saltstudy.analysis.balance import bed_exchange, budget_friction
from saltstudy.solver.grains.splash_kernels import EN_PX_IN, EN_PX_OUT, EN_PZ_IN, EN_PZ_OUT


def _impacts_on_the_layer(s, rng, m, speed, angle_deg, d=2e-4):
    """m parcels sitting on the impact layer with the given impact velocity, flagged as hits."""
    a = math.radians(angle_deg)
    h = s.h_imp
    s.add_parcels(rng.uniform(0, 2.4, m), rng.uniform(0, 1.6, m), np.full(m, h),
                  u=speed * math.cos(a), v=0.0, w=-speed * math.sin(a), d=d)
    s._flag[:s.n] = 1
    s._trem[:s.n] = 0.0
    s._work_init()                      # the step's counters (Saltation.dynamics makes them)
    return s.n


def test_bed_momentum_record_is_the_parcels_momentum_change():
    """Splashing a synthetic set of impacts: the record's streamwise and vertical momentum equal,
    to round-off, the impactors' momentum in and the launched grains' momentum out, as summed
    from the parcel arrays before and after."""
    sc = scene(2, physics={"two_way_coupling": False, "tke_particle_sink": False})
    s, _ = component(sc)
    rng = np.random.default_rng(3)
    n = _impacts_on_the_layer(s, rng, 3000, 1.2, 15.0)
    m_in = s.Q * s.mass.copy()
    px_in = float(np.sum(m_in * s.u))
    pz_in = float(np.sum(m_in * np.abs(s.w)))
    s._cnt[:] = 0
    s._en[:] = 0.0
    s._splash(n, n)
    live = s._flag[:s.n] == 0            # rebounds (in place) and ejecta (appended)
    q = s.Q * math.pi / 6.0 * s.rho_p * s._d[:s.n][live] ** 3
    px_out = float(np.sum(q * s._u[:s.n][live]))
    pz_out = float(np.sum(q * s._w[:s.n][live]))
    assert live.sum() > 1000 and np.all(s._w[:s.n][live] > 0)
    en = s._en
    assert en[EN_PX_IN] == pytest.approx(px_in, rel=1e-12)
    assert en[EN_PZ_IN] == pytest.approx(pz_in, rel=1e-12)
    assert en[EN_PX_OUT] == pytest.approx(px_out, rel=1e-12)
    assert en[EN_PZ_OUT] == pytest.approx(pz_out, rel=1e-12)
    # the bed takes streamwise momentum and gives vertical momentum: mu_b of order one
    mu_b = (en[EN_PX_IN] - en[EN_PX_OUT]) / (en[EN_PZ_IN] + en[EN_PZ_OUT])
    assert 0.3 < mu_b < 3.0


def test_bed_momentum_is_counted_by_the_component_and_survives_a_checkpoint():
    """One step with impacts: counters() carries the record's in - out and in + out; restored from
    a checkpoint, the component has the same totals."""
    sc = scene(2, physics={"two_way_coupling": False, "tke_particle_sink": False})
    s, st = component(sc, gravity=False)
    rng = np.random.default_rng(4)
    s.add_parcels(rng.uniform(0, 2.4, 500), rng.uniform(0, 1.6, 500), np.full(500, 5.2e-4),
                  u=2.0, w=-0.8, d=2e-4)
    s.dynamics(st, 1e-3)
    c = s.counters()
    assert c["bed_px"] > 0 and c["bed_pz"] > 0
    s2, _ = component(sc)
    s2.restore(s.checkpoint())
    assert s2.counters()["bed_px"] == c["bed_px"] and s2.counters()["bed_pz"] == c["bed_pz"]


def test_normal_impact_speed_reading_takes_w_in_eqs_6_and_8():
    """splash.impact_speed = "normal": impacts at 2 m/s and 10 degrees rebound with
    P_reb(|w|) = 0.95 (1 - exp(-2 |w|)) and eject a |w| / sqrt(g <d>) on average (eqs. 6, 8 of the
    normal speed), and the rebounds still leave at 0.6 x the speed (eq. 7)."""
    sc = scene(2, physics={"two_way_coupling": False, "tke_particle_sink": False},
               splash={"impact_speed": "normal"})
    s, _ = component(sc)
    rng = np.random.default_rng(6)
    m, v, ang = 20000, 2.0, 10.0
    n = _impacts_on_the_layer(s, rng, m, v, ang)
    s._cnt[:] = 0
    s._splash(n, n)
    w = v * math.sin(math.radians(ang))
    p = 0.95 * (1 - math.exp(-2.0 * w))
    nbar = 0.03 * w / math.sqrt(sc.case.air.g * sc.case.soil.mean_diameter)
    reb, ej = int(s._cnt[1]), int(s._cnt[2])
    assert reb / m == pytest.approx(p, abs=4 * math.sqrt(p * (1 - p) / m))
    assert ej / m == pytest.approx(nbar, abs=4 * math.sqrt(0.25 / m))
    # the magnitude reading would rebound 93 % of these
    assert reb / m < 0.6
    rebounds = np.nonzero(s._flag[:m] == 0)[0]
    speed = np.sqrt(s._u[rebounds] ** 2 + s._v[rebounds] ** 2 + s._w[rebounds] ** 2)
    assert speed.mean() == pytest.approx(0.6056 * v, rel=0.03)      # eq. 7, truncated normal




def test_bed_exchange_of_linear_records():
    """Cumulative records growing linearly: the stress, vertical impulse and mu_b are their rates
    over the area, the block scatter zero; outside the record, NaN."""
    t = np.linspace(0.0, 40.0, 401)
    a, b, area = 0.6, 0.8, 75.0
    r = bed_exchange(t, a * t, b * t, 10.0, 40.0, area)
    assert r["tau_g_bed_impacts"] == pytest.approx(a / area, rel=1e-12)
    assert r["bed_vertical_impulse"] == pytest.approx(b / area, rel=1e-12)
    assert r["mu_b"] == pytest.approx(a / b, rel=1e-12)
    assert r["mu_b_se"] == pytest.approx(0.0, abs=1e-12)
    assert math.isnan(bed_exchange(t, None, b * t, 10.0, 40.0, area)["mu_b"])
    wobbly = bed_exchange(t, a * t + 0.01 * np.sin(t), b * t, 10.0, 40.0, area)
    assert wobbly["mu_b_se"] > 0


def test_budget_friction_of_known_stresses():
    """tau_total = 0.3 m2/s2, the bed's u'w' = -0.05, M = 30 g/m2: the grains carry
    rho (0.3 - 0.05) to the bed, the bed keeps 1/6 of the stress, mu_b = tau_g / (M g)."""
    rho, g = 1.2, 9.81
    uw = np.array([-0.04, -0.05, -0.06])
    M = np.array([0.03, 0.03, 0.03])
    r = budget_friction(rho, g, 0.3, uw, M)
    assert r["bed_fluid_stress_fraction"] == pytest.approx(0.05 / 0.3, rel=1e-12)
    assert r["tau_g_bed_budget"] == pytest.approx(rho * 0.25, rel=1e-12)
    assert r["mu_b_budget"] == pytest.approx(rho * 0.25 / (0.03 * g), rel=1e-12)
    assert r["mu_b_budget_se"] > 0
    assert math.isnan(budget_friction(rho, g, 0.0, uw, M)["mu_b_budget"])


def test_column_momentum_rate_of_a_decelerating_column():
    """Profiles u(z, t) = U(z) - a t: the column below z_top loses a z_top per second; the budget
    takes that out of the grains' stress (a decelerating column feeds the bed more than the stress
    at z_top)."""
    from saltstudy.analysis.balance import column_momentum_rate

    z_w = np.linspace(0.0, 3.0, 31)
    zc = 0.5 * (z_w[1:] + z_w[:-1])
    t = np.linspace(12.0, 42.0, 13)
    a = 0.02
    u = np.log(zc / 1e-5)[None, :] - a * t[:, None]
    rate = column_momentum_rate(t, u, z_w, 2.05)
    assert rate == pytest.approx(-a * 2.05, rel=1e-9)
    r = budget_friction(1.2, 9.81, 0.3, np.full(13, -0.05), np.full(13, 0.03), rate)
    assert r["tau_g_bed_budget"] == pytest.approx(1.2 * (0.25 + a * 2.05), rel=1e-12)
    assert math.isnan(column_momentum_rate(t[:2], u[:2], z_w, 2.0))
