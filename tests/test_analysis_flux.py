"""tau_p (eq. 10), z_m, G (eq. 11), G_tot, sigma_G (analysis/flux.py) with known answers."""
from __future__ import annotations

import math

import numpy as np
import pytest

from saltstudy.analysis import flux

RHO = 1.2


def faces(nz=40, Lz=3.0, dz0=0.005):
    k = np.arange(nz + 1.0)
    c = (Lz - dz0 * nz) / (nz ** 3 - nz)
    zw = (dz0 - c) * k + c * k ** 3
    return zw


def test_tau_p_from_layer_sums_equals_direct_covariance_of_grains():
    """Random grains in 3 layers over 4 samples: eq. 10 with time-space mean deviations."""
    rng = np.random.default_rng(0)
    Lx, Ly, dz = 2.0, 1.5, np.array([0.01, 0.02, 0.04])
    n_t, Q = 4, 7.0
    sums = {k: np.zeros((n_t, 3)) for k in ("pm", "pmu", "pmw", "pmuw")}
    grains = [[] for _ in range(3)]
    for t in range(n_t):
        for k in range(3):
            n = rng.integers(50, 200)
            m = rng.uniform(1e-8, 5e-8, n)
            w = rng.normal(0.1 * (t - 1.5), 0.5, n)
            u = 3.0 - 0.8 * w + rng.normal(0, 0.3, n)      # rising grains are slow
            sums["pm"][t, k] = Q * m.sum()
            sums["pmu"][t, k] = Q * (m * u).sum()
            sums["pmw"][t, k] = Q * (m * w).sum()
            sums["pmuw"][t, k] = Q * (m * u * w).sum()
            grains[k].append((m, u, w))
    tau = flux.tau_p_profile(sums["pm"], sums["pmu"], sums["pmw"], sums["pmuw"], dz, Lx, Ly)
    for k in range(3):
        m = np.concatenate([g[0] for g in grains[k]])
        u = np.concatenate([g[1] for g in grains[k]])
        w = np.concatenate([g[2] for g in grains[k]])
        U, W = np.sum(m * u) / m.sum(), np.sum(m * w) / m.sum()
        direct = -Q * np.sum(m * (u - U) * (w - W)) / (n_t * Lx * Ly * dz[k])
        assert tau[k] == pytest.approx(direct, rel=1e-10)
        assert tau[k] > 0           # downward momentum flux is positive


def test_exponential_tau_gives_z_m():
    zw = faces()
    z = 0.5 * (zw[1:] + zw[:-1])
    u_star, H = 0.5, 0.04
    tau0 = 0.3 * RHO * u_star ** 2
    tau = tau0 * np.exp(-z / H)
    expected = H * math.log(0.3 / 1e-3)
    assert flux.z_m_from_tau(z, tau, RHO, u_star) == pytest.approx(expected, rel=1e-10)
    # without grains, or with tau below the threshold at the bed: NaN
    assert math.isnan(flux.z_m_from_tau(z, 0 * z, RHO, u_star))
    assert math.isnan(flux.z_m_from_tau(z, 1e-4 * tau, RHO, u_star))
    assert math.isnan(flux.z_m_from_tau(z, tau, RHO, math.nan))


def test_exponential_G_gives_back_its_integral_flux_height_and_decay_height():
    zw = faces()
    z = 0.5 * (zw[1:] + zw[:-1])
    dz = np.diff(zw)
    G0, H = 0.8, 0.05
    # layer means of G0 exp(-z/H): exact integrals over each layer
    G = G0 * H * (np.exp(-zw[:-1] / H) - np.exp(-zw[1:] / H)) / dz
    total = G0 * H * (1 - math.exp(-zw[-1] / H))
    assert flux.total_flux(G, dz) == pytest.approx(total, rel=1e-12)
    z995 = -H * math.log(1 - 0.995 * (1 - math.exp(-zw[-1] / H)))
    k = np.searchsorted(zw, z995)
    assert abs(flux.flux_height(zw, G) - z995) < 0.1 * (zw[k] - zw[k - 1])
    assert flux.decay_height(z, G0 * np.exp(-z / H), 0.3) == pytest.approx(H, rel=1e-10)
    # the layer means of an exponential are exponential too (with a layer-dependent factor
    # close to one where layers are thin)
    assert flux.decay_height(z, G, 0.3) == pytest.approx(H, rel=0.05)
    assert math.isnan(flux.flux_height(zw, 0 * G))
    assert math.isnan(flux.decay_height(z, 0 * G, 0.3))


def test_mass_flux_profile_from_sums():
    pmu = np.array([[2.0, 1.0], [4.0, 3.0]])
    G = flux.mass_flux_profile(pmu, np.array([0.01, 0.02]), 2.0, 1.0)
    assert np.allclose(G, [3.0 / (2.0 * 0.01), 2.0 / (2.0 * 0.02)])


def test_sigma_G_of_series_and_of_local_flux():
    t = np.arange(0, 20.0, 0.01)
    G = 0.1 + 0.02 * np.sin(2 * np.pi * t / 0.5)
    G[t < 5] = 5.0                       # overshoot outside the window must not count
    mean, sd = flux.sigma_series(t, G, 5.0, 15.0 - 0.01)
    assert mean == pytest.approx(0.1, rel=1e-6)
    assert sd == pytest.approx(0.02 / math.sqrt(2), rel=1e-3)
    assert math.isnan(flux.sigma_series(t, G, 30.0, 40.0)[1])
    rng = np.random.default_rng(1)
    col = 0.1 + 0.05 * rng.standard_normal((50, 16, 12))
    assert flux.sigma_local(col) == pytest.approx(0.05, rel=0.03)


def test_pooled_mean_std_equals_the_one_pass_value():
    rng = np.random.default_rng(3)
    a = 5.0 + 0.01 * rng.standard_normal((37, 6, 5))
    m, s = flux.pooled_mean_std(a[i:i + 8] for i in range(0, 37, 8))
    assert m == pytest.approx(a.mean(), rel=1e-12)
    assert s == pytest.approx(a.std(), rel=1e-9)
    assert s == pytest.approx(flux.sigma_local(a), rel=1e-9)
    assert math.isnan(flux.pooled_mean_std([])[1])
