"""Size distribution by height band and of the bed (analysis/sizes.py)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from saltstudy.analysis import sizes as sz


def test_band_mass_fractions_weight_counts_by_d_cubed():
    d = np.array([1e-4, 2e-4])
    z = np.array([0.005, 0.015, 0.03, 0.3])
    hist = np.array([[8.0, 1.0], [8.0, 1.0], [0.0, 3.0], [0.0, 0.0]])
    f = sz.band_mass_fractions(hist, z, d, np.array([0.0, 0.02, 0.05, 0.5]))
    assert np.allclose(f[0], [0.5, 0.5])           # 8 x 1 = 1 x 8 in mass
    assert np.allclose(f[1], [0.0, 1.0])
    assert np.all(np.isnan(f[2]))                  # a band without grains


def _eq5_bins(mu, sigma, edges):
    """Trapezoid integral of dM/dln d (eq. 5, one mode) over each bin, renormalised."""
    s = math.log(sigma)
    num = []
    for a, b in zip(edges[:-1], edges[1:]):
        x = np.linspace(math.log(a), math.log(b), 2001)
        dens = np.exp(-(x - math.log(mu)) ** 2 / (2 * s * s)) / (math.sqrt(2 * math.pi) * s)
        num.append(np.trapezoid(dens, x))
    return np.array(num) / np.sum(num)


def test_bed_fractions_match_numerical_integral_of_eq5():
    mu, sigma = 2e-4, 1.2
    edges = np.geomspace(mu / sigma ** 3, mu * sigma ** 3, 25)
    soil = {"modes": [{"mass_fraction": 1.0, "mu": mu, "sigma": sigma}], "rho_p": 2650.0}
    f, _ = sz.bed_mass_fractions(soil, edges)
    assert f.sum() == pytest.approx(1.0)
    assert np.allclose(f, _eq5_bins(mu, sigma, edges), atol=1e-6)
    assert int(np.argmax(f)) in (11, 12)           # the median sits in the middle bins


def test_bed_fractions_from_case_soil_and_band_edges():
    soil = {"modes": [{"mass_fraction": 1.0, "mu": 2e-4, "sigma": 1.2}], "rho_p": 2650.0}
    edges = np.geomspace(1e-4, 4e-4, 11)
    f, src = sz.bed_mass_fractions(soil, edges)
    assert f.sum() == pytest.approx(1.0)
    assert np.allclose(f, _eq5_bins(2e-4, 1.2, edges), atol=1e-6)
    assert src
    f, _ = sz.bed_mass_fractions(None, edges)
    assert np.all(np.isnan(f))
    e = sz.band_edges_for(0.3)
    assert e[0] == 0.0 and e[-1] == 0.3 and np.all(np.diff(e) > 0)
