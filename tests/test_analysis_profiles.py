"""Log-law fit, fit range and stress u* (analysis/profiles.py) on profiles with known answers."""
from __future__ import annotations

import math

import numpy as np
import pytest

from saltstudy.analysis import profiles as pr

KAPPA = 0.4


def stretched(nz=48, Lz=6.0, dz0=0.01):
    k = np.arange(nz + 1.0)
    c = (Lz - dz0 * nz) / (nz ** 3 - nz)
    zw = (dz0 - c) * k + c * k ** 3
    return 0.5 * (zw[1:] + zw[:-1]), zw


@pytest.mark.parametrize("u_star,z0", [(0.41, 1e-5), (1.1, 3e-3), (0.54, 2e-4)])
def test_log_profile_gives_back_u_star_and_z0(u_star, z0):
    z, _ = stretched()
    u = u_star / KAPPA * np.log(z / z0)
    fit = pr.log_law_fit(z, u, 0.3, 2.25, KAPPA)
    assert fit.u_star == pytest.approx(u_star, rel=1e-10)
    assert fit.z0 == pytest.approx(z0, rel=1e-8)
    assert fit.r2 == pytest.approx(1.0)
    assert fit.n_points == int(np.sum((z >= 0.3) & (z <= 2.25)))


def test_fit_ignores_the_levels_outside_its_range():
    z, _ = stretched()
    u = 0.5 / KAPPA * np.log(z / 1e-4)
    u_bent = np.where(z < 0.3, 0.5 * u, u)        # a saltation layer below 0.3 m
    u_bent = np.where(z > 2.25, u_bent + 3.0, u_bent)  # lid effects above
    fit = pr.log_law_fit(z, u_bent, 0.3, 2.25, KAPPA)
    assert fit.u_star == pytest.approx(0.5, rel=1e-10)
    bad = pr.log_law_fit(z, u_bent, 0.01, 5.0, KAPPA)
    assert abs(bad.u_star - 0.5) > 0.01


def test_fit_range_definition():
    assert pr.fit_range(math.nan, 6.0, 1.5) == (0.3, 2.25)
    assert pr.fit_range(0.1, 6.0, 1.5) == (0.3, 2.25)
    assert pr.fit_range(0.55, 12.0, 3.0) == (0.55, 4.5)


def test_too_few_points_or_decreasing_profile_give_nan():
    z = np.array([0.1, 0.4, 0.6, 3.0])
    u = 0.5 / KAPPA * np.log(z / 1e-4)
    fit = pr.log_law_fit(z, u, 0.3, 1.0, KAPPA)
    assert fit.n_points == 2 and math.isnan(fit.u_star) and math.isnan(fit.z0)
    z, _ = stretched()
    fit = pr.log_law_fit(z, -np.log(z), 0.3, 2.0, KAPPA)
    assert math.isnan(fit.u_star)
    fit = pr.log_law_fit(z, np.full(z.size, np.nan), 0.3, 2.0, KAPPA)
    assert math.isnan(fit.u_star)


def test_faces_to_centres_and_stress_u_star():
    _, zw = stretched()
    uw_w = -0.3 ** 2 * (1 - zw / zw[-1])          # linear stress
    c = pr.faces_to_centres(uw_w)
    assert c.shape == (zw.size - 1,)
    assert np.allclose(c, -0.09 * (1 - 0.5 * (zw[1:] + zw[:-1]) / zw[-1]))
    assert pr.stress_u_star(zw, uw_w, 2.0) == pytest.approx(math.sqrt(0.09 * (1 - 2.0 / 6.0)))
    assert math.isnan(pr.stress_u_star(zw, uw_w, 7.0))
