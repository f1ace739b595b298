"""Streamer statistics on synthetic C_p fields with known answers (analysis/streamers.py)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from saltstudy.analysis import streamers as st

CORE = math.sqrt(math.log(1.0 / st.CORE_LEVEL))   # exp(-l^2/(4 s^2)) = 0.4 at l = 2 s CORE


def shot_noise_planes(nt, nx, ny, dx, dy, sx, sy, rate, rng):
    """Gaussian streaks (sigma sx, sy) at Poisson-random positions: by Campbell's theorem the
    autocorrelation is exactly exp(-lx^2/(4 sx^2) - ly^2/(4 sy^2)) in expectation."""
    Lx, Ly = nx * dx, ny * dy
    x = (np.arange(nx) + 0.5) * dx
    y = (np.arange(ny) + 0.5) * dy
    out = np.zeros((nt, nx, ny))
    for t in range(nt):
        n = rng.poisson(rate * Lx * Ly)
        for x0, y0 in zip(rng.uniform(0, Lx, n), rng.uniform(0, Ly, n)):
            gx = np.exp(-0.5 * (((x - x0 + Lx / 2) % Lx - Lx / 2) / sx) ** 2)
            gy = np.exp(-0.5 * (((y - y0 + Ly / 2) % Ly - Ly / 2) / sy) ** 2)
            out[t] += np.outer(gx, gy)
    return out


def lattice_streak_planes(nt, nx, ny, dx, dy, spacing, sy, rng, jitter=0.0):
    """Long streaks on a spanwise lattice of the given spacing, random phase per plane, random
    smooth amplitude along x: every x row shows the lateral spacing."""
    Lx, Ly = nx * dx, ny * dy
    x = (np.arange(nx) + 0.5) * dx
    y = (np.arange(ny) + 0.5) * dy
    n_slots = int(round(Ly / spacing))
    out = np.zeros((nt, nx, ny))
    for t in range(nt):
        phase = rng.uniform(0, spacing)
        for j in range(n_slots):
            y0 = phase + j * spacing + jitter * rng.standard_normal()
            amp = 1.0 + 0.5 * np.sin(2 * np.pi * x / Lx * rng.integers(1, 4) + rng.uniform(0, 6.3))
            gy = np.exp(-0.5 * (((y - y0 + Ly / 2) % Ly - Ly / 2) / sy) ** 2)
            out[t] += np.outer(amp, gy)
    return out


def test_core_length_of_a_cosine_is_exact():
    # one cosine along y: R(ly) = cos(2 pi ly / L) exactly; 0.4 at ly = L acos(0.4)/(2 pi)
    nx, ny, dy = 8, 64, 0.05
    y = np.arange(ny) * dy
    planes = np.broadcast_to(np.cos(2 * np.pi * y / (ny * dy)), (3, nx, ny)).copy()
    ac = st.autocorrelation_2d(planes)
    lam = st.core_length(ac[nx // 2, :], dy)
    expected = 2 * ny * dy * math.acos(0.4) / (2 * math.pi)
    assert abs(lam - expected) < 0.1 * dy  # linear interpolation of a smooth cosine


def test_lambda_x_lambda_y_of_gaussian_streaks_within_one_grid_spacing():
    rng = np.random.default_rng(3)
    nx, ny, dx, dy = 128, 64, 0.1, 0.1
    sx, sy = 0.7, 0.12
    planes = shot_noise_planes(60, nx, ny, dx, dy, sx, sy, rate=0.15, rng=rng)
    ac = st.autocorrelation_2d(planes)
    assert ac[nx // 2, ny // 2] == pytest.approx(1.0)
    lam_x = st.core_length(ac[:, ny // 2], dx)
    lam_y = st.core_length(ac[nx // 2, :], dy)
    assert abs(lam_x - 4 * sx * CORE) <= dx, (lam_x, 4 * sx * CORE)
    assert abs(lam_y - 4 * sy * CORE) <= dy, (lam_y, 4 * sy * CORE)
    # a length this clearly different must not pass (the test can fail)
    assert abs(lam_x - 4 * 1.3 * sx * CORE) > dx


def test_core_length_nan_when_the_core_spans_the_domain():
    nx, ny = 16, 16
    planes = np.zeros((2, nx, ny))
    planes[:, :, :8] = 1.0          # uniform along x: correlation 1 at every x lag
    ac = st.autocorrelation_2d(planes)
    assert math.isnan(st.core_length(ac[:, ny // 2], 0.1))
    assert math.isfinite(st.core_length(ac[nx // 2, :], 0.1))


def test_delta_y_of_streaks_on_a_lattice():
    rng = np.random.default_rng(5)
    nx, ny, dx, dy = 64, 96, 0.15, 0.1
    spacing = 0.8                      # Ly = 9.6 m: 12 streaks, ky = 1.25 m-1 is mode 12
    planes = lattice_streak_planes(40, nx, ny, dx, dy, spacing, sy=0.1, rng=rng, jitter=0.05)
    ky, S, se = st.spanwise_spectrum(planes, dy)
    ky_peak = st.spectral_peak(ky, S, se)
    assert abs(1.0 / ky_peak - spacing) <= dy, 1.0 / ky_peak
    # Parseval: the one-sided density integrates to the mean plane variance
    var = np.mean([(p - p.mean()).var() for p in planes])
    assert np.sum(S) * (ky[1] - ky[0]) == pytest.approx(var, rel=1e-10)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_no_peak_for_monotonic_or_white_spectra(seed):
    rng = np.random.default_rng(seed)
    nx, ny, dy = 64, 64, 0.1
    white = rng.standard_normal((40, nx, ny))
    ky, S, se = st.spanwise_spectrum(white, dy)
    assert math.isnan(st.spectral_peak(ky, S, se))
    # red noise: white noise smoothed along y (monotonically decaying spectrum)
    k = np.fft.rfftfreq(ny, dy)
    red = np.fft.irfft(np.fft.rfft(white, axis=2) * np.exp(-(k / 1.5) ** 2), n=ny, axis=2)
    ky, S, se = st.spanwise_spectrum(red, dy)
    assert math.isnan(st.spectral_peak(ky, S, se))


def test_peak_criterion_on_given_spectra():
    ky = np.arange(33) / 9.6
    base = 1.0 / (1.0 + (ky / 0.5) ** 2)
    bump = np.exp(-0.5 * ((ky - 1.25) / 0.15) ** 2)
    # a bump that doubles the local level of a decaying spectrum is a peak (16 % above its
    # valley) ...
    S = base + 1.0 * bump * base[12]
    exact = np.zeros_like(S)                 # a spectrum without sampling error
    assert 1 / st.spectral_peak(ky, S, exact) == pytest.approx(0.8, abs=0.05)
    # without any error estimate the stricter fallback margin (20 %) applies
    assert math.isnan(st.spectral_peak(ky, S))
    assert 1 / st.spectral_peak(ky, base + 2.0 * bump * base[12]) == pytest.approx(0.8, abs=0.05)
    # ... a 3 % wiggle is not a peak, nor is a monotonic decay, nor a maximum at the domain mode
    assert math.isnan(st.spectral_peak(ky, base + 0.03 * bump * base[12], exact))
    assert math.isnan(st.spectral_peak(ky, base, exact))
    dom = base.copy()
    dom[1] = 5.0
    assert math.isnan(st.spectral_peak(ky, dom, exact))
    # noise level matters: the same bump is rejected when its standard error is large
    se = np.full(ky.size, 0.2 * base[12])
    assert math.isnan(st.spectral_peak(ky, S, se))


def test_peaks_shorter_than_four_cells_are_not_resolved():
    ny, dy = 64, 0.1
    ky = np.arange(ny // 2 + 1) / (ny * dy)
    base = 1.0 / (1.0 + (ky / 0.5) ** 2)
    exact = np.zeros_like(base)
    for cells, found in ((3.0, False), (4.5, True)):
        k0 = 1.0 / (cells * dy)
        S = base * (1.0 + 2.0 * np.exp(-0.5 * ((ky - k0) / 0.2) ** 2))
        got = st.spectral_peak(ky, S, exact)
        assert math.isfinite(got) is found, (cells, got)
        if found:
            assert 1.0 / got == pytest.approx(cells * dy, abs=dy)
        # with the limit lowered, the 3-cell peak is found
        assert math.isfinite(st.spectral_peak(ky, S, exact, min_cells=2.0))


def moving_pattern(nt, nx, ny, dx, dy, dt, speed, a, rng):
    """Smooth random field advected at ``speed`` (exact Fourier shift) and renewed as AR(1):
    C_t = a shift(C_{t-1}) + sqrt(1-a^2) new. The moving-frame correlation at lag k is a^k."""
    kx = np.fft.fftfreq(nx, dx)[:, None]
    ky = np.fft.rfftfreq(ny, dy)[None, :]
    filt = np.exp(-((kx / 1.0) ** 2 + (ky / 2.0) ** 2))

    def new():
        return np.fft.irfft2(np.fft.rfft2(rng.standard_normal((nx, ny))) * filt, s=(nx, ny))

    shift = np.exp(-2j * np.pi * kx * speed * dt)
    c = new()
    c /= c.std()
    out = []
    for _ in range(nt):
        out.append(c)
        moved = np.fft.irfft2(np.fft.rfft2(c) * shift, s=(nx, ny))
        fresh = new()
        fresh *= moved.std() / fresh.std()
        c = a * moved + math.sqrt(1 - a * a) * fresh
    return np.array(out)


@pytest.mark.parametrize("speed", [3.0, 2.37])
def test_propagating_pattern_gives_its_speed_and_lifetime(speed):
    rng = np.random.default_rng(11)
    dt, dx, dy = 0.1, 0.1, 0.1
    a = math.exp(-dt / 0.6)                      # lifetime (1/e) 0.6 s
    planes = moving_pattern(400, 96, 48, dx, dy, dt, speed, a, rng)
    res = st.space_time_correlation(planes, dt, dx, dy, max_lag_s=2.0)
    c, life = st.speed_and_lifetime(res)
    assert c == pytest.approx(speed, rel=0.03)
    assert life == pytest.approx(0.6, rel=0.1)
    assert res.peak[0] == pytest.approx(1.0)


def test_frozen_pattern_has_no_finite_lifetime_but_a_speed():
    rng = np.random.default_rng(2)
    planes = moving_pattern(30, 64, 32, 0.1, 0.1, 0.1, 1.0, 1.0, rng)
    res = st.space_time_correlation(planes, 0.1, 0.1, 0.1, max_lag_s=1.0)
    c, life = st.speed_and_lifetime(res)
    assert math.isnan(life)
    assert c == pytest.approx(1.0, rel=0.02)


def test_degenerate_planes_give_nan():
    empty = np.zeros((5, 8, 8))
    ac = st.autocorrelation_2d(empty)
    assert np.all(np.isnan(ac))
    assert math.isnan(st.core_length(ac[:, 4], 0.1))
    ky, S, se = st.spanwise_spectrum(empty, 0.1)
    assert math.isnan(st.spectral_peak(ky, S, se))
    c, life = st.speed_and_lifetime(st.space_time_correlation(empty, 0.1, 0.1, 0.1))
    assert math.isnan(c) and math.isnan(life)
    one = np.random.default_rng(0).standard_normal((1, 8, 8))
    c, life = st.speed_and_lifetime(st.space_time_correlation(one, 0.1, 0.1, 0.1))
    assert math.isnan(c) and math.isnan(life)


def _parcel_planes(intensity, mean_count, rng):
    """Parcel counts drawn independently per cell (Poisson) around ``intensity`` scaled to a mean
    of ``mean_count`` parcels per cell: the parcel-count noise of C_p, with Q/(dx dy) = 1."""
    lam = intensity / intensity.mean(axis=(1, 2), keepdims=True) * mean_count
    return rng.poisson(lam).astype(np.float64)


def test_white_noise_of_independent_parcels_is_their_poisson_variance():
    rng = np.random.default_rng(11)
    nx, ny = 96, 64
    x = np.arange(nx)[:, None]
    smooth = 1.0 + 0.5 * np.cos(2 * np.pi * x / nx) * np.ones((1, ny))
    planes = _parcel_planes(np.broadcast_to(smooth, (12, nx, ny)), 6.0, rng)
    dev, _ = st.deviation_planes(planes)
    noise = st.white_noise_variance(dev)
    # Poisson: variance = mean count (Q / cell area = 1 here); ~1500 corner modes per plane
    assert noise == pytest.approx(planes.mean(axis=(1, 2)), rel=0.1)
    assert noise.mean() == pytest.approx(6.0, rel=0.03)
    # a smooth field alone has no white part
    assert st.white_noise_variance(st.deviation_planes(np.broadcast_to(smooth, (2, nx, ny)))[0]) \
        == pytest.approx(0.0, abs=1e-20)


def test_removing_the_parcel_noise_recovers_the_pattern_lengths():
    rng = np.random.default_rng(4)
    nx, ny, dx, dy = 128, 64, 0.1, 0.1
    sx, sy = 0.7, 0.25
    pattern = 0.3 + shot_noise_planes(16, nx, ny, dx, dy, sx, sy, rate=0.15, rng=rng)
    ac_true = st.autocorrelation_2d(pattern)
    lx_true = st.core_length(ac_true[:, ny // 2], dx)
    ly_true = st.core_length(ac_true[nx // 2, :], dy)
    planes = _parcel_planes(pattern, 5.0, rng)
    raw = st.autocorrelation_2d(planes)
    noise = st.white_noise_variance(st.deviation_planes(planes)[0])
    den = st.autocorrelation_2d(planes, noise=noise)
    lx_raw, ly_raw = st.core_length(raw[:, ny // 2], dx), st.core_length(raw[nx // 2, :], dy)
    lx_den, ly_den = st.core_length(den[:, ny // 2], dx), st.core_length(den[nx // 2, :], dy)
    assert abs(lx_den - lx_true) <= 2 * dx and abs(ly_den - ly_true) <= dy, (lx_den, lx_true, ly_den, ly_true)
    # the noise shortens the raw lengths by more than that (so the check can fail)
    assert lx_true - lx_raw > 2 * dx and ly_true - ly_raw > dy, (lx_raw, ly_raw)
    # removing half the noise lands in between
    half = st.autocorrelation_2d(planes, noise=0.5 * noise)
    assert lx_raw < st.core_length(half[:, ny // 2], dx) < lx_den


def test_removing_the_noise_floor_flattens_a_white_spectrum_to_zero():
    rng = np.random.default_rng(8)
    planes = _parcel_planes(np.ones((20, 64, 48)), 8.0, rng)
    ky, S_raw, _ = st.spanwise_spectrum(planes, 0.1)
    noise = st.white_noise_variance(st.deviation_planes(planes)[0])
    _, S_den, se = st.spanwise_spectrum(planes, 0.1, noise=noise)
    # raw: flat at the Poisson floor 2 s^2 dy (one-sided) = 1.6
    assert np.mean(S_raw[1:-1]) == pytest.approx(2 * 8.0 * 0.1, rel=0.03)
    assert abs(np.mean(S_den[1:-1])) < 0.02 * np.mean(S_raw[1:-1])
