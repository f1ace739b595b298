"""Multimodal lognormal mass-size distribution (paper eq. 5) and its sampler."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from saltstudy.config import Soil, SoilMode
from saltstudy.physics.soil import bin_mass_fractions, mass_cdf, sample_diameters

from physics_expectations import (count_median, diameter_bins, mass_density_dlnd, mass_median,
                                  mass_weighted_moment, number_density_dlnd)

ONE = Soil(modes=(SoilMode(mu=200e-6, sigma=1.2),))
TWO_SYM = Soil(modes=(SoilMode(mass_fraction=0.5, mu=100e-6, sigma=1.3),
                      SoilMode(mass_fraction=0.5, mu=400e-6, sigma=1.3)))
TWO = Soil(modes=(SoilMode(mass_fraction=0.3, mu=90e-6, sigma=1.2),
                  SoilMode(mass_fraction=0.7, mu=300e-6, sigma=1.5)))
N = 100_000


def _lnd_grid(soil, n=20001):
    return np.exp(np.linspace(math.log(1e-6), math.log(1e-2), n))


@pytest.mark.parametrize("soil", [ONE, TWO_SYM, TWO])
def test_densities_integrate_to_one(soil):
    d = _lnd_grid(soil)
    x = np.log(d)
    assert np.trapezoid(mass_density_dlnd(d, soil), x) == pytest.approx(1.0, abs=1e-9)
    assert np.trapezoid(number_density_dlnd(d, soil), x) == pytest.approx(1.0, abs=1e-9)


def test_eq5_peak_value_single_mode():
    # at d = mu, eq. (5) gives 1 / (sqrt(2 pi) ln sigma)
    assert mass_density_dlnd(200e-6, ONE) == pytest.approx(1 / (math.sqrt(2 * math.pi) * math.log(1.2)))


@pytest.mark.parametrize("soil", [ONE, TWO])
def test_number_density_is_mass_density_over_d_cubed(soil):
    d = np.geomspace(30e-6, 2e-3, 50)
    ratio = number_density_dlnd(d, soil) * d ** 3 / mass_density_dlnd(d, soil)
    np.testing.assert_allclose(ratio, ratio[0], rtol=1e-9)


def test_number_median_is_count_median():
    d = _lnd_grid(ONE)
    cdf = np.concatenate([[0], np.cumsum(0.5 * (number_density_dlnd(d[1:], ONE)
                                                + number_density_dlnd(d[:-1], ONE)) * np.diff(np.log(d)))])
    d_med = math.exp(np.interp(0.5, cdf, np.log(d)))
    assert d_med == pytest.approx(count_median(ONE), rel=1e-5)
    assert count_median(ONE) == pytest.approx(200e-6 * math.exp(-3 * math.log(1.2) ** 2))


def test_mass_median_exact_cases():
    assert mass_median(ONE) == 200e-6
    assert mass_median(TWO_SYM) == pytest.approx(200e-6, rel=1e-10)    # symmetric in ln d
    assert mass_cdf(mass_median(TWO), TWO) == pytest.approx(0.5, abs=1e-10)


@pytest.mark.parametrize("soil", [ONE, TWO_SYM, TWO])
def test_sampler_reproduces_mass_median(soil):
    rng = np.random.default_rng(12345)
    d = sample_diameters(soil, rng, N)
    m = mass_median(soil)
    # sample median in ln d has standard error 1 / (2 f(m) sqrt(N)), f = dM/dln d at the median
    se = 1.0 / (2.0 * mass_density_dlnd(m, soil) * math.sqrt(N))
    assert abs(math.log(np.median(d)) - math.log(m)) < 4 * se


@pytest.mark.parametrize("soil", [ONE, TWO])
def test_sampler_follows_mass_cdf(soil):
    rng = np.random.default_rng(7)
    d = sample_diameters(soil, rng, N)
    for q in (80e-6, 150e-6, 250e-6, 500e-6):
        p = mass_cdf(q, soil)
        se = math.sqrt(max(p * (1 - p), 1e-12) / N)
        assert abs(np.mean(d < q) - p) < 4 * se + 1e-12


def test_mass_weighted_moment_matches_samples():
    rng = np.random.default_rng(3)
    d = sample_diameters(TWO, rng, N) ** 3
    assert abs(d.mean() - mass_weighted_moment(TWO, 3.0)) < 4 * d.std() / math.sqrt(N)
    assert mass_weighted_moment(ONE, 1.0) == pytest.approx(200e-6 * math.exp(0.5 * math.log(1.2) ** 2))


def test_diameter_bins_cover_four_sigma_log_spaced():
    e = diameter_bins(TWO, 30)
    assert e.size == 31
    r = e[1:] / e[:-1]
    np.testing.assert_allclose(r, r[0], rtol=1e-10)
    assert e[0] == pytest.approx(90e-6 / 1.2 ** 4)
    assert e[-1] == pytest.approx(300e-6 * 1.5 ** 4)
    with pytest.raises(ValueError):
        diameter_bins(ONE, 0)


@pytest.mark.parametrize("soil", [ONE, TWO])
def test_bin_mass_fractions(soil):
    e = diameter_bins(soil, 40)
    f = bin_mass_fractions(soil, e)
    assert f.shape == (40,) and np.all(f >= 0)
    if soil is ONE:
        assert f.sum() == pytest.approx(math.erf(4 / math.sqrt(2)), rel=1e-12)   # 1 - 6.3e-5
    # each bin equals the integral of eq. (5) over it
    k = 17
    d = np.geomspace(e[k], e[k + 1], 2001)
    assert f[k] == pytest.approx(np.trapezoid(mass_density_dlnd(d, soil), np.log(d)), rel=1e-6)
    with pytest.raises(ValueError):
        bin_mass_fractions(soil, [2e-4, 1e-4])


@settings(deadline=None, max_examples=40)
@given(mu=st.floats(50e-6, 1e-3), sigma=st.floats(1.05, 3.0), frac=st.floats(0.05, 0.95),
       ratio=st.floats(1.0, 10.0))
def test_mass_median_between_modes(mu, sigma, frac, ratio):
    soil = Soil(modes=(SoilMode(mass_fraction=frac, mu=mu, sigma=sigma),
                       SoilMode(mass_fraction=1 - frac, mu=min(mu * ratio, 9e-3), sigma=sigma)))
    m = mass_median(soil)
    assert mass_cdf(m, soil) == pytest.approx(0.5, abs=1e-9)
    assert soil.modes[0].mu * (1 - 1e-9) <= m <= soil.modes[1].mu * (1 + 1e-9)
