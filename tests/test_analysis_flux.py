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
    assert flux.pooled_mean_std([col])[1] == pytest.approx(0.05, rel=0.03)


def test_pooled_mean_std_equals_the_one_pass_value():
    rng = np.random.default_rng(3)
    a = 5.0 + 0.01 * rng.standard_normal((37, 6, 5))
    m, s = flux.pooled_mean_std(a[i:i + 8] for i in range(0, 37, 8))
    assert m == pytest.approx(a.mean(), rel=1e-12)
    assert s == pytest.approx(a.std(), rel=1e-9)
    assert math.isnan(flux.pooled_mean_std([])[1])


# ------------------------------------------------------------------------------------------
# tau_p at the bed, independent of the first level's thickness
# ------------------------------------------------------------------------------------------
def cubic_faces(Lz, nz, dz0):
    """Faces cubic in the level index, first level dz0 (the solver's law)."""
    a, c = np.linalg.solve(np.array([[1.0, 1.0], [nz, nz ** 3]]), [dz0, Lz])
    k = np.arange(nz + 1.0)
    zw = a * k + c * k ** 3
    zw[0], zw[-1] = 0.0, Lz
    return zw


#: the paper's grid (first level 1 cm) and the reduced study's (2 cm)
GRIDS = {"1 cm": cubic_faces(12.0, 100, 0.01), "2 cm": cubic_faces(6.0, 48, 0.02)}


def layer_means(zw, antiderivative):
    return np.diff(antiderivative(zw)) / np.diff(zw)


@pytest.mark.parametrize("H", [0.02, 0.035, 0.08])
def test_bed_value_of_an_exponential_is_the_same_on_1_and_2_cm_first_levels(H):
    tau0 = 0.6                                   # Pa
    z_m = H * math.log(0.5 / 1e-3)               # tau_p(0) = 0.5 rho u*^2
    got = {}
    for name, zw in GRIDS.items():
        tau = layer_means(zw, lambda z: -tau0 * H * np.exp(-z / H))    # eq. 10's layer means
        bed = flux.bed_value(zw, tau, flux.BED_FIT_FRACTION * z_m)
        assert bed.value == pytest.approx(tau0, rel=1e-9), name
        assert bed.height == pytest.approx(H, rel=1e-9), name
        assert bed.n_layers >= 2
        # the paper's reading, the mean over its 0-1 cm cell, from the fit on either grid
        assert bed.layer_mean(0.01) == pytest.approx(tau0 * H * (1 - math.exp(-0.01 / H)) / 0.01,
                                                     rel=1e-9)
        got[name] = (bed.value, tau[0])
    # the lowest layer's own reading depends on the grid: what the bed value replaces
    assert got["2 cm"][1] / got["1 cm"][1] < 0.95


def test_bed_value_of_a_steeper_near_bed_profile_agrees_between_grids():
    """Two exponentials (a 1 cm near-bed part under a 5 cm one): the fit cannot see the thin
    part, but reads the same on both grids (within 3 %) where the lowest layers differ by 20 %."""
    H1, H2, w1 = 0.01, 0.05, 0.6
    F = lambda z: -w1 * H1 * np.exp(-z / H1) - (1 - w1) * H2 * np.exp(-z / H2)  # noqa: E731
    z_m = 0.265                                   # where 0.5 x the profile falls to 1e-3
    vals, first = [], []
    for zw in GRIDS.values():
        tau = layer_means(zw, F)
        vals.append(flux.bed_value(zw, tau, flux.BED_FIT_FRACTION * z_m).value)
        first.append(tau[0])
    assert vals[1] == pytest.approx(vals[0], rel=0.03)
    assert abs(first[1] / first[0] - 1) > 0.15
    assert 0.7 < vals[0] < 1.0                    # the true bed value is 1


def test_bed_value_degenerate_profiles():
    zw = GRIDS["2 cm"]
    assert math.isnan(flux.bed_value(zw, np.zeros(zw.size - 1)).value)          # no grains
    one = np.zeros(zw.size - 1)
    one[0] = 0.3
    assert math.isnan(flux.bed_value(zw, one).value)                            # one layer
    flat = np.full(zw.size - 1, 0.3)                                            # no decay
    bed = flux.bed_value(zw, flat, 0.1)
    assert bed.value == pytest.approx(0.3) and abs(bed.height) > 1e3
    # a profile growing with height: a negative e-folding height, still exact
    grow = layer_means(zw, lambda z: 0.05 * 0.3 * np.exp(z / 0.05))
    bed = flux.bed_value(zw, grow)
    assert bed.value == pytest.approx(0.3, rel=1e-9) and bed.height == pytest.approx(-0.05, rel=1e-9)


def test_budget_bed_fraction():
    u2 = 0.54 ** 2
    # the air carries 60 % of the total stress at the bed: the grains 40 %
    assert flux.budget_bed_fraction(-0.6 * u2, -u2) == pytest.approx(0.4)
    assert math.isnan(flux.budget_bed_fraction(-0.6 * u2, 0.0))
    assert math.isnan(flux.budget_bed_fraction(math.nan, -u2))
