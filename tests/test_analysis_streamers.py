"""Streamer statistics on synthetic C_p fields with known answers (analysis/streamers.py):
streaks of known width and spacing (2.5-6 cells), seen through Poisson parcel counts at the
paper's density (20 parcels per column) and at the reduced run's (20/16)."""
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


# ------------------------------------------------------------------------------------------
# parcel-count noise: Poisson counts per column at the paper's density and at the run's
# ------------------------------------------------------------------------------------------
#: parcels per column of the paper (case 2: 6e5 parcels over 200 x 150 columns)
PAPER_PARCELS = 20.0
#: the reduced study's parcels are this many times heavier
RUN_Q_MULTIPLIER = 16.0
DENSITIES = [pytest.param(PAPER_PARCELS, 1.0, id="paper-20-per-column"),
             pytest.param(PAPER_PARCELS / RUN_Q_MULTIPLIER, RUN_Q_MULTIPLIER,
                          id="run-1.25-per-column")]
D = 0.1                                  # cell size [m]: the paper's
AREA = D * D


def parcel_planes(intensity, mean_count, weight, rng):
    """C_p [m-2] of whole parcels of ``weight`` grains: Poisson counts per column about
    ``intensity`` (mean 1) times ``mean_count``."""
    counts = rng.poisson(np.clip(intensity, 0.0, None) * mean_count)
    return counts * (weight / AREA)


def streak_intensity(nt, nx, ny, sx, sy, rng, per_plane=40):
    """Shot-noise streaks (Gaussian, sigma sx, sy in cells) over an equal background, scaled by
    the expected mean to a mean of 1 (so Campbell's autocorrelation stays exact)."""
    pattern = shot_noise_planes(nt, nx, ny, D, D, sx * D, sy * D,
                                rate=per_plane / (nx * ny * AREA), rng=rng)
    mean_streaks = per_plane * 2 * math.pi * sx * sy / (nx * ny)
    return (mean_streaks + pattern) / (2 * mean_streaks)


def lambdas(planes, noise=None):
    nx, ny = planes.shape[1:]
    ac = st.autocorrelation_2d(planes, noise=noise)
    return st.core_length(ac[:, ny // 2], D), st.core_length(ac[nx // 2, :], D)


def test_poisson_noise_of_parcel_counts_is_their_mean_count():
    rng = np.random.default_rng(11)
    nx, ny, w = 96, 64, 7.0
    x = np.arange(nx)[:, None]
    smooth = np.broadcast_to(1.0 + 0.5 * np.cos(2 * np.pi * x / nx) * np.ones((1, ny)), (12, nx, ny))
    planes = parcel_planes(smooth, 6.0, w, rng)
    # counts come back from C_p and the parcel weight
    assert st.parcels_per_cell(planes, w, AREA) == pytest.approx(planes.mean(axis=(1, 2)) * AREA / w)
    assert st.parcels_per_cell(planes, w, AREA).mean() == pytest.approx(6.0, rel=0.02)
    noise = st.poisson_noise_variance(planes, w, AREA)
    # count variance = mean count, times (w / A)^2 in C_p units
    assert noise == pytest.approx(st.parcels_per_cell(planes, w, AREA) * (w / AREA) ** 2)
    # the measured white level of the counts is that variance (~1500 small-scale modes a plane)
    measured = st.small_scale_power(st.deviation_planes(planes)[0])
    assert measured.mean() == pytest.approx(noise.mean(), rel=0.03)
    # a smooth field alone has no small-scale power
    assert st.small_scale_power(st.deviation_planes(smooth)[0]) == pytest.approx(0.0, abs=1e-20)
    assert np.all(np.isnan(st.poisson_noise_variance(planes, 0.0, AREA)))


@pytest.mark.parametrize("parcels, weight", DENSITIES)
@pytest.mark.parametrize("width_cells", [2.5, 3.0, 4.0, 6.0])
def test_noise_free_lambda_of_streaks_2p5_to_6_cells_wide(width_cells, parcels, weight):
    """Streaks whose core (autocorrelation > 0.4) is 2.5-6 cells wide and 11.5 cells long, seen
    through Poisson parcel counts: with the Poisson variance removed, lambda_y within 0.3 cell
    and lambda_x within 0.5 cell of the pattern's own (the linear interpolation between lags 1
    and 2 of a 2.5-cell Gaussian core reads 0.16 cell long)."""
    rng = np.random.default_rng(int(10 * width_cells) + int(weight))
    nx, ny = 96, 64
    sx, sy = 3.0, width_cells / (4 * CORE)
    planes = parcel_planes(streak_intensity(60, nx, ny, sx, sy, rng), parcels, weight, rng)
    noise = st.poisson_noise_variance(planes, weight, AREA)
    lam_x, lam_y = lambdas(planes, noise)
    assert abs(lam_y - width_cells * D) <= 0.3 * D, (lam_y / D, width_cells)
    assert abs(lam_x - 4 * sx * CORE * D) <= 0.5 * D, (lam_x / D, 4 * sx * CORE)
    if weight > 1:   # at ~1 parcel per column the noise alone would narrow the core by > 0.5 cell
        _, raw_y = lambdas(planes)
        assert width_cells * D - raw_y > 0.5 * D, (raw_y / D, width_cells)


@pytest.mark.parametrize("width_cells", [2.5, 4.0, 6.0])
def test_paper_noise_level_makes_the_parcel_weight_a_cost_knob(width_cells):
    """The same streaks sampled by the paper's parcels (20 per column, nothing removed) and by
    16x heavier ones with the difference of their Poisson variances removed give the same
    lambda (within 0.3 cell); the heavy parcels' raw lambda does not."""
    rng = np.random.default_rng(int(100 * width_cells))
    nx, ny = 96, 64
    intensity = streak_intensity(60, nx, ny, 3.0, width_cells / (4 * CORE), rng)
    paper = parcel_planes(intensity, PAPER_PARCELS, 1.0, rng)
    run = parcel_planes(intensity, PAPER_PARCELS / RUN_Q_MULTIPLIER, RUN_Q_MULTIPLIER, rng)
    # what analyse removes: the run's Poisson variance less the paper's (Q = 1 on the paper's
    # columns); for the paper's own parcels that is nothing
    removed = (st.poisson_noise_variance(run, RUN_Q_MULTIPLIER, AREA)
               - st.poisson_noise_variance(run, 1.0, st.PAPER_CELL_AREA))
    assert st.PAPER_CELL_AREA == pytest.approx(AREA)
    lx_paper, ly_paper = lambdas(paper)
    lx_run, ly_run = lambdas(run, removed)
    assert abs(ly_run - ly_paper) <= 0.3 * D, (ly_run / D, ly_paper / D)
    assert abs(lx_run - lx_paper) <= 0.5 * D, (lx_run / D, lx_paper / D)
    _, ly_raw = lambdas(run)
    assert ly_paper - ly_raw > 0.5 * D, (ly_raw / D, ly_paper / D)
    # and the paper's own noise narrows the core a little, not more than the tolerance
    _, ly_free = lambdas(paper, st.poisson_noise_variance(paper, 1.0, AREA))
    assert 0.0 <= ly_free - ly_paper <= 0.3 * D, (ly_free / D, ly_paper / D)


def test_removing_the_noise_floor_flattens_a_white_spectrum_to_zero():
    rng = np.random.default_rng(8)
    planes = parcel_planes(np.ones((20, 64, 48)), 8.0, 1.0, rng)
    ky, S_raw, _ = st.spanwise_spectrum(planes, D)
    noise = st.poisson_noise_variance(planes, 1.0, AREA)
    _, S_den, _ = st.spanwise_spectrum(planes, D, noise=noise)
    # raw: flat at the Poisson floor 2 s^2 dy (one-sided), s^2 = 8 / A^2
    assert np.mean(S_raw[1:-1]) == pytest.approx(2 * 8.0 / AREA ** 2 * D, rel=0.03)
    assert abs(np.mean(S_den)) < 0.02 * np.mean(S_raw[1:-1])


# ------------------------------------------------------------------------------------------
# delta_y: a spectral peak judged against the spectrum's sampling noise
# ------------------------------------------------------------------------------------------
def lattice_intensity(nt, nx, ny, spacing_cells, rng, contrast=1.0):
    """Streaks on a spanwise lattice ``spacing_cells`` apart (sigma 0.3 spacing, jittered by
    0.1 spacing), over a background: mean 1, spatial standard deviation about ``contrast``/2."""
    f = lattice_streak_planes(nt, nx, ny, D, D, spacing_cells * D, 0.3 * spacing_cells * D, rng,
                              jitter=0.1 * spacing_cells * D)
    f /= f.mean(axis=(1, 2), keepdims=True)
    return 1.0 + contrast * (f - 1.0) / 2.0


def peak_ky(planes):
    ky, S, _, blocks = st.spanwise_spectrum_blocks(planes, D)
    return ky, st.spectral_peak(ky, S, blocks)


@pytest.mark.parametrize("parcels, weight", DENSITIES)
@pytest.mark.parametrize("spacing_cells", [2.5, 3.0, 4.0, 5.0, 6.0])
def test_delta_y_of_streaks_2p5_to_6_cells_apart_with_parcel_noise(spacing_cells, parcels, weight):
    """A lattice of streaks 2.5-6 cells apart through Poisson parcel counts: the peak is found
    within half a spectral mode of 1/spacing (no lower limit but the grid's)."""
    rng = np.random.default_rng(int(10 * spacing_cells) + int(weight))
    nx, ny = 64, 60                          # 60 cells: whole numbers of streaks for every spacing
    planes = parcel_planes(lattice_intensity(60, nx, ny, spacing_cells, rng), parcels, weight, rng)
    ky, k_peak = peak_ky(planes)
    assert math.isfinite(k_peak), spacing_cells
    assert abs(k_peak - 1.0 / (spacing_cells * D)) <= 0.5 * (ky[1] - ky[0]), (1 / k_peak / D)


def test_streaks_three_cells_apart_are_found_at_the_run_density():
    """Three cells apart (below 4 cells), weak contrast, 1.25 parcels per
    column: the spectrum's own noise decides, and the peak stands out of it."""
    rng = np.random.default_rng(3)
    nx, ny = 64, 48
    planes = parcel_planes(lattice_intensity(300, nx, ny, 3.0, rng, contrast=0.5),
                           PAPER_PARCELS / RUN_Q_MULTIPLIER, RUN_Q_MULTIPLIER, rng)
    _, k_peak = peak_ky(planes)
    assert 1.0 / k_peak == pytest.approx(3 * D, abs=0.05 * D)


@pytest.mark.parametrize("parcels, weight", DENSITIES)
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_pure_poisson_noise_has_no_spectral_peak(seed, parcels, weight):
    rng = np.random.default_rng(seed)
    planes = parcel_planes(np.ones((300, 64, 48)), parcels, weight, rng)
    assert math.isnan(peak_ky(planes)[1])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_no_peak_for_a_decaying_spectrum_under_parcel_noise(seed):
    # a smooth pattern with a monotonically decaying spanwise spectrum, counted in parcels
    rng = np.random.default_rng(seed)
    nt, nx, ny = 200, 64, 48
    kx = np.fft.fftfreq(nx)[:, None]
    ky = np.fft.rfftfreq(ny)[None, :]
    filt = np.exp(-(kx / 0.05) ** 2 - (ky / 0.15) ** 2)
    red = np.fft.irfft2(np.fft.rfft2(rng.standard_normal((nt, nx, ny))) * filt, s=(nx, ny))
    red /= red.std()
    for parcels, weight in ((PAPER_PARCELS, 1.0), (PAPER_PARCELS / RUN_Q_MULTIPLIER, RUN_Q_MULTIPLIER)):
        planes = parcel_planes(np.exp(0.5 * red), parcels, weight, rng)
        assert math.isnan(peak_ky(planes)[1])


def test_peak_criterion_on_given_block_spectra():
    rng = np.random.default_rng(0)
    ky = np.arange(33) / 9.6
    flat = np.ones(ky.size)
    decaying = 1.0 / (1.0 + (ky / 0.5) ** 2)
    bump = np.exp(-0.5 * ((ky - 1.25) / 0.15) ** 2)      # centred on mode 12 (0.8 m)
    nb, rel = 8, 0.1                                     # blocks scatter by 10 %
    scatter = 1.0 + rel * rng.standard_normal((nb, ky.size))

    def peak(base, height_in_se, scatter=scatter):
        se12 = rel * base[12] / math.sqrt(nb)            # standard error of the mean at mode 12
        blocks = (base + height_in_se * se12 * bump)[None, :] * scatter
        return st.spectral_peak(ky, blocks.mean(axis=0), blocks)

    # on a flat spectrum the threshold is 4 sqrt(2) ~ 5.7 standard errors of one mode
    assert 1 / peak(flat, 12.0) == pytest.approx(0.8, abs=0.05)
    assert math.isnan(peak(flat, 2.0))              # within the sampling noise: not a peak
    assert math.isnan(peak(flat, 0.0))
    # on a decaying spectrum the bump must also rise above the higher valley on its left
    assert 1 / peak(decaying, 40.0) == pytest.approx(0.8, abs=0.05)
    assert math.isnan(peak(decaying, 0.0))          # a monotonic decay
    # the same bump is a peak or not by its blocks' scatter alone
    assert math.isnan(peak(flat, 12.0, 1.0 + 5 * rel * rng.standard_normal((nb, ky.size))))
    # a maximum at the domain mode is not a spacing
    dom = decaying.copy()
    dom[1] = 5.0
    assert math.isnan(st.spectral_peak(ky, dom, dom[None, :] * scatter))


def test_peak_without_an_error_estimate_needs_the_fallback_margin():
    ky = np.arange(33) / 9.6
    bump = np.exp(-0.5 * ((ky - 1.25) / 0.15) ** 2)
    for h, found in ((0.1, False), (0.5, True)):    # 10 % and 50 % above a flat base
        S = 1.0 + h * bump
        assert math.isfinite(st.spectral_peak(ky, S)) is found
        # fewer than MIN_BLOCKS blocks: the same
        assert math.isfinite(st.spectral_peak(ky, S, np.tile(S, (st.MIN_BLOCKS - 1, 1)))) is found


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
    ky, S, _, blocks = st.spanwise_spectrum_blocks(empty, 0.1)
    assert math.isnan(st.spectral_peak(ky, S, blocks))
    c, life = st.speed_and_lifetime(st.space_time_correlation(empty, 0.1, 0.1, 0.1))
    assert math.isnan(c) and math.isnan(life)
    one = np.random.default_rng(0).standard_normal((1, 8, 8))
    c, life = st.speed_and_lifetime(st.space_time_correlation(one, 0.1, 0.1, 0.1))
    assert math.isnan(c) and math.isnan(life)


@pytest.mark.parametrize("width_cells", [2.5, 4.0])
def test_the_paper_count_reading_sees_the_paper_field_of_fewer_grains(width_cells):
    """A model that holds 5x the paper's airborne grains, in the same pattern, sampled by parcels
    of 4 grains: read with the noise of the paper's count (4 parcels per column of 1 grain) it
    gives the lambda of the paper's own field (within 0.3 cell across, 0.5 along), which the
    reading at the paper's Q (the paper's parcels carrying the model's concentration) misses
    along the wind by more than half a cell."""
    rng = np.random.default_rng(int(10 * width_cells))
    nx, ny = 96, 64
    intensity = streak_intensity(60, nx, ny, 3.0, width_cells / (4 * CORE), rng)
    paper_count, excess, weight = 4.0, 5.0, 4.0
    paper = parcel_planes(intensity, paper_count, 1.0, rng)
    run = parcel_planes(intensity, paper_count * excess / weight, weight, rng)
    own = st.poisson_noise_variance(run, weight, AREA)
    at_count = own - st.count_noise_variance(run, paper_count / AREA, AREA)
    at_q = own - st.poisson_noise_variance(run, 1.0, AREA)
    # the paper's count on its columns is 1/count of mean(C_p)^2, whatever the concentration
    assert st.count_noise_variance(paper, paper_count / AREA, AREA) == pytest.approx(
        paper.mean(axis=(1, 2)) ** 2 / paper_count)
    lx_paper, ly_paper = lambdas(paper)
    lx_count, ly_count = lambdas(run, at_count)
    lx_q, _ = lambdas(run, at_q)
    assert abs(ly_count - ly_paper) <= 0.3 * D, (ly_count / D, ly_paper / D)
    assert abs(lx_count - lx_paper) <= 0.5 * D, (lx_count / D, lx_paper / D)
    assert lx_q - lx_paper > 0.5 * D, (lx_q / D, lx_paper / D)
    assert np.all(np.isnan(st.count_noise_variance(run, 0.0, AREA)))
