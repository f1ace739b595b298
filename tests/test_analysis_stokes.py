"""eps_tot (eq. 13), T_eps, T_p and St (analysis/stokes.py) with known answers."""
from __future__ import annotations

import math

import numpy as np
import pytest

from saltstudy.analysis import stokes as sk

RHO, RHO_P, NU = 1.2, 2650.0, 1.5e-5


def test_drag_dissipation_from_grain_sums_equals_known_value():
    """Grains of one layer with known fluid/grain velocity statistics and drag rate."""
    rng = np.random.default_rng(0)
    n, Q, Lx, Ly, dz = 20000, 10.0, 2.0, 1.0, 0.02
    m = rng.uniform(1e-8, 2e-8, n)
    gamma = 40.0                                  # f(Re)/T_p [s-1], the same for all grains
    U_f, U_p = 4.0, 2.5
    a = rng.standard_normal((n, 3)) * [0.5, 0.3, 0.2]     # fluid fluctuations at the grains
    b = 0.4 * a + rng.standard_normal((n, 3)) * 0.1       # grains follow 40 % of them
    uf = a + [U_f, 0, 0]
    up = b + [U_p, 0, 0]
    P_m = Q * m.sum()
    P_uf = Q * np.sum(m * uf[:, 0])
    P_u = Q * np.sum(m * up[:, 0])
    P_ufup = Q * np.sum(m * np.sum(uf * up, axis=1))
    pdrag = Q * np.sum(m * gamma)
    cov = sk.fluid_grain_covariance(np.array([P_m]), np.array([P_ufup]), np.array([P_uf]),
                                    np.array([P_u]))
    w = m / m.sum()
    af = a - np.sum(w[:, None] * a, axis=0)
    bf = b - np.sum(w[:, None] * b, axis=0)
    direct = np.sum(w * np.sum(af * bf, axis=1))
    # streamwise means removed exactly; lateral and vertical means ~0 by construction
    assert cov[0] == pytest.approx(direct, abs=2e-3)
    assert cov[0] == pytest.approx(0.4 * (0.25 + 0.09 + 0.04), rel=0.03)
    beta = sk.drag_rate(np.array([pdrag]), RHO, np.array([dz]), Lx, Ly)
    assert beta[0] == pytest.approx(Q * m.sum() * gamma / (RHO * Lx * Ly * dz))
    tke = np.array([0.6])
    eps = sk.eps_drag(beta, tke, cov)
    assert eps[0] == pytest.approx(beta[0] * (2 * 0.6 - cov[0]))
    assert sk.eps_drag(np.array([0.0]), tke, np.array([np.nan]))[0] == 0.0


def test_sgs_term_removes_the_mean_shear_part():
    z = np.linspace(0.05, 2.0, 30)
    u = 0.5 / 0.4 * np.log(z / 1e-4)
    uw_sgs = -0.1 * np.exp(-z)
    fluct = 0.02 / z
    transfer = fluct - uw_sgs * np.gradient(u, z)      # -<tau S> = mean part + fluctuating part
    assert np.allclose(sk.eps_sgs_fluct(transfer, uw_sgs, u, z), fluct)


def test_T_p_from_size_histogram_and_St():
    d = np.array([1e-4, 2e-4, 4e-4])
    hist = np.array([[0.0, 5.0, 0.0],                 # one size
                     [8.0, 1.0, 0.0],                 # equal mass in 100 and 200 um
                     [0.0, 0.0, 0.0]])                # no grains
    dm = sk.mass_mean_diameter(hist, d)
    assert dm[0] == pytest.approx(2e-4)
    assert dm[1] == pytest.approx(1.5e-4)
    assert math.isnan(dm[2])
    T_p = sk.response_time(dm, RHO_P, RHO, NU)
    assert T_p[0] == pytest.approx(RHO_P * 4e-8 / (18 * RHO * NU))
    T_eps = sk.eddy_time(np.array([0.5, 0.5, 0.5]), np.array([0.25, -1.0, 0.1]))
    assert T_eps[0] == pytest.approx(2.0) and math.isnan(T_eps[1])
    St = sk.stokes_number(T_p, T_eps)
    assert St[0] == pytest.approx(T_p[0] / 2.0)
    assert math.isnan(St[1]) and math.isnan(St[2])
