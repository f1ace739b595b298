"""R_cu (eq. 12), its upper-layer mean and the lagged correlation (analysis/correlation.py)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from saltstudy.analysis import correlation as co


def test_field_with_known_correlation_gives_it_back():
    rng = np.random.default_rng(4)
    nt, nx, ny = 6, 64, 48
    r_true = np.array([-0.3, 0.0, 0.2, 0.5, 0.9])
    C = 1e5 * (1 + 0.3 * rng.standard_normal((nt, nx, ny)))
    c = (C - C.mean()) / C.std()
    noise = rng.standard_normal((nt, nx, ny, r_true.size))
    u = 5.0 + np.arange(r_true.size) + 0.7 * (r_true * c[..., None]
                                              + np.sqrt(1 - r_true ** 2) * noise)
    R = co.correlation_profile(C, u.astype(np.float32))
    se = 1 / math.sqrt(nt * nx * ny)
    assert np.all(np.abs(R - r_true) < 5 * se), R
    # matches numpy's Pearson coefficient over all (t, x, y)
    for k in range(r_true.size):
        assert R[k] == pytest.approx(np.corrcoef(C.ravel(), u[..., k].ravel())[0, 1], abs=1e-6)


def test_constant_fields_give_nan():
    C = np.ones((2, 4, 4))
    u = np.random.default_rng(0).standard_normal((2, 4, 4, 3))
    assert np.all(np.isnan(co.correlation_profile(C, u)))
    assert np.all(np.isnan(co.correlation_profile(np.zeros((0, 4, 4)), np.zeros((0, 4, 4, 3)))))


def test_upper_mean():
    z = np.array([0.01, 0.05, 0.1, 0.15, 0.2, 0.3])
    R = np.array([-0.2, 0.1, 0.3, 0.4, 0.5, 0.9])
    assert co.upper_mean(z, R, 0.2) == pytest.approx(np.mean([0.4, 0.5]))
    assert math.isnan(co.upper_mean(z, R, math.nan))


def test_lagged_correlation_peaks_at_the_delay():
    rng = np.random.default_rng(2)
    nt, nx, ny, delay = 120, 16, 12, 7
    u = rng.standard_normal((nt + delay, nx, ny, 2))
    C = u[:nt, :, :, 0] * 1.0                 # C(t) = u(t - delay) at plane 0
    u = u[delay:]
    R = co.lagged_correlation(C, u, 10)
    assert int(np.argmax(R[:, 0])) == delay
    assert R[delay, 0] == pytest.approx(1.0, abs=0.08)
    assert np.all(np.abs(R[:, 1]) < 0.1)      # plane 1 independent


def test_white_noise_in_c_is_taken_out_of_r_cu():
    # C = smooth signal (correlated with u) + white noise of known variance: removing that
    # variance restores the correlation of the signal; leaving it in lowers it by sqrt(1 - f)
    rng = np.random.default_rng(9)
    nt, nx, ny = 8, 64, 48
    x = np.arange(nx)[None, :, None]
    sig = np.cos(2 * np.pi * (x + rng.uniform(0, nx, (nt, 1, 1))) / 16.0) * np.ones((1, 1, ny))
    u = 6.0 + sig[..., None] * 0.5 + 0.5 * rng.standard_normal((nt, nx, ny, 1))
    r_clean = co.correlation_profile(sig, u)[0]
    s2 = 0.5                                   # noise variance = signal variance: f = 0.5
    C = sig + math.sqrt(s2) * rng.standard_normal(sig.shape)
    r_raw = co.correlation_profile(C, u)[0]
    r_fix = co.correlation_profile(C, u, noise=s2)[0]
    assert r_raw == pytest.approx(r_clean * math.sqrt(0.5), abs=0.02)
    assert r_fix == pytest.approx(r_clean, abs=0.03)
    lag = co.lagged_correlation(C, u, 0, noise=s2)[0, 0]
    assert lag == pytest.approx(r_clean, abs=0.03)
