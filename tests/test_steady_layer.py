"""The 1-D steady layer of the splash law (instruments/steady_layer.py): its flight, splash and
wind against exact results, and the steady state it reaches."""
from __future__ import annotations

import math

import numpy as np
import pytest

from saltstudy.config import Splash, load_case
from saltstudy.instruments.steady_layer import (LayerParams, fly_grains, log_wind,
                                                solve_steady_layer, splash_generation,
                                                wind_from_stress)


def test_a_heavy_grain_in_still_air_flies_a_parabola():
    """Drag negligible (rho_p huge), no wind: launched at (u0, w0) from the layer's top it lands
    there after 2 w0 / g, at -w0, u0 t downstream; its mass-time is m t."""
    g, h = 9.81, 5e-4
    zn = np.exp(np.linspace(math.log(1e-5), math.log(3.0), 50))
    un = np.zeros(zn.size)
    lz0, idl = math.log(zn[0]), 1.0 / (math.log(zn[1]) - math.log(zn[0]))
    u0, w0, d, rho_p = np.array([1.0]), np.array([0.5]), np.array([2e-4]), 1e9
    nb = zn.size - 1
    drag, mt, fl = np.zeros(nb), np.zeros(nb), np.zeros(nb)
    out = np.zeros((1, 6))
    fly_grains(u0, np.zeros(1), w0, d, un, lz0, idl, 0.0, 3.0, 0.4, 1.2, 1.5e-5, rho_p, g, h,
               1e-5, 5.0, drag, mt, fl, out)
    t = 2 * 0.5 / g
    m = math.pi / 6 * rho_p * 2e-4 ** 3
    assert out[0, 5] == 1.0
    assert out[0, 0] == pytest.approx(t, rel=1e-3)
    assert out[0, 3] == pytest.approx(-0.5, rel=1e-3) and out[0, 1] == pytest.approx(1.0, rel=1e-4)
    assert out[0, 4] == pytest.approx(t, rel=1e-3)
    assert mt.sum() == pytest.approx(m * t, rel=1e-2)


def test_constant_stress_gives_the_log_law():
    zn = np.exp(np.linspace(math.log(1e-5), math.log(3.0), 400))
    u = wind_from_stress(zn, np.full(zn.size, 1.2 * 0.5 ** 2), 1.2, 0.4)
    assert np.allclose(u, log_wind(zn, 0.5, 0.4, 1e-5), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("impact_speed", ["magnitude", "normal"])
def test_splash_generation_draws_eqs_6_and_8_and_keeps_the_books(impact_speed):
    """Impacts at 2 m/s and 10 deg: rebounds with P_reb of the speed eq. 6 takes, ejecta per
    impact eq. 8's mean; the bed's momentum per impact is the impactor's minus the launches'."""
    p = LayerParams(splash=Splash(impact_speed=impact_speed), n_impacts=100)
    rng = np.random.default_rng(1)
    n, v, a = 40000, 2.0, math.radians(10.0)
    ui, vi, wi = np.full(n, v * math.cos(a)), np.zeros(n), np.full(n, -v * math.sin(a))
    di = np.full(n, 2e-4)
    u, vv, w, d, parent, px, pz = splash_generation(rng, p, ui, vi, wi, di)
    vl = v if impact_speed == "magnitude" else v * math.sin(a)
    prob = 0.95 * (1 - math.exp(-2.0 * vl))
    nbar = 0.03 * vl / math.sqrt(9.81 * 2e-4)
    n_reb = int(np.sum(d == 2e-4))       # ejecta diameters come from the soil, never exactly mu
    assert n_reb / n == pytest.approx(prob, abs=4 * math.sqrt(prob * (1 - prob) / n))
    assert (u.size - n_reb) / n == pytest.approx(nbar, abs=4 * math.sqrt(0.25 / n))
    m_i = math.pi / 6 * 2650 * 2e-4 ** 3
    m_o = math.pi / 6 * 2650 * d ** 3
    assert px.sum() == pytest.approx(m_i * ui.sum() - np.sum(m_o * u), rel=1e-12)
    assert pz.sum() == pytest.approx(m_i * np.abs(wi).sum() + np.sum(m_o * w), rel=1e-12)
    assert np.all(w > 0)


def test_the_steady_layer_replaces_itself_and_balances_its_momentum():
    """A small steady layer of case 2's splash at u*s = 0.54 m/s: each generation replaces
    itself, its impacts sit above the splash law's fixed point (P_reb + N_ej = 1 at 0.55 m/s),
    the bed keeps a small share of the stress, and mu_b from the budget and from the impacts
    agree (the air carries little of the weight)."""
    p = LayerParams.from_case(load_case(2), n_impacts=600)
    r = solve_steady_layer(p, seed=3, generations=70, average=30)
    assert r.growth == pytest.approx(1.0, abs=0.06)
    assert 0.55 < r.impact_speed_mean < 1.2
    assert r.bed_fluid_fraction < 0.2
    assert r.mu_b == pytest.approx(r.mu_b_impacts, rel=0.15)
    assert 0.5 < r.mu_b < 1.2
    # what the grains gain from the air in flight is what they give the bed at impact
    assert r.tau_g_bed == pytest.approx(r.tau_g_impacts, rel=0.05)
    assert r.tau_g_bed <= 1.05 * p.rho * p.u_star ** 2


def test_layer_params_reject_bad_input():
    with pytest.raises(ValueError, match="impact_speed"):
        LayerParams(splash=Splash(impact_speed="fast"))
    with pytest.raises(ValueError, match="u_star"):
        LayerParams(u_star=-1.0)
    with pytest.raises(ValueError, match="bed_fluid_fraction"):
        solve_steady_layer(LayerParams(n_impacts=100), bed_fluid_fraction=1.5)
