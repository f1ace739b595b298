"""The spanwise spacing delta_y read three ways (analysis/streamers.py, docs/STREAMERS.md): the
peak of the premultiplied spectrum ky S(ky) (Table 2's reading), the peak of the density S(ky),
and twice the lag of the first minimum of the spanwise autocorrelation. Synthetic fields with
known answers, seen through Poisson parcel counts at the paper's density (20 parcels per
column) and at the reduced run's (20/16, parcels 16x heavier), read as analyse reads them: the
spectrum carries the paper's noise, the sampling error is the run's."""
from __future__ import annotations

import math

import numpy as np
import pytest

from saltstudy.analysis import streamers as st

D = 0.1                                  # cell size [m]: the paper's
AREA = D * D
#: parcels per column of the paper (case 2: 6e5 parcels over 200 x 150 columns)
PAPER_PARCELS = 20.0
#: the reduced study's parcels are this many times heavier
RUN_Q_MULTIPLIER = 16.0
DENSITIES = [pytest.param(PAPER_PARCELS, 1.0, id="paper-20-per-column"),
             pytest.param(PAPER_PARCELS / RUN_Q_MULTIPLIER, RUN_Q_MULTIPLIER,
                          id="run-1.25-per-column")]


def parcel_planes(intensity, mean_count, weight, rng):
    """C_p [m-2] of whole parcels of ``weight`` grains: Poisson counts per column about
    ``intensity`` (mean 1) times ``mean_count``."""
    return rng.poisson(np.clip(intensity, 0.0, None) * mean_count) * (weight / AREA)


def spacing_as_analysed(planes, weight):
    """delta_y by the three readings [cells], with the run's noise less the paper's removed from
    the spectrum (what analyse does with parcels of ``weight`` grains on the paper's columns)."""
    removed = (st.poisson_noise_variance(planes, weight, AREA)
               - st.poisson_noise_variance(planes, 1.0, st.PAPER_CELL_AREA))
    _, _, _, sp = st.spanwise_spacing(planes, D, noise=removed)
    return sp


def in_cells(sp):
    return np.array([sp.premultiplied, sp.density, sp.correlation]) / D


def power_law_field(nt, nx, ny, rng, slope=-1.0):
    """Gaussian field, zero mean and unit variance, whose spanwise density goes as ky^slope from
    the domain mode to the Nyquist mode (streamwise: smooth over ~20 cells)."""
    kx = np.fft.fftfreq(nx)[:, None]
    ky = np.fft.rfftfreq(ny)[None, :]
    with np.errstate(divide="ignore"):
        amp = np.where(ky > 0, ky ** (0.5 * slope), 0.0) * np.exp(-(kx / 0.05) ** 2)
    f = np.fft.irfft2(np.fft.rfft2(rng.standard_normal((nt, nx, ny))) * amp, s=(nx, ny))
    return f / f.std()


def streak_lattice(nt, nx, ny, spacing, rng, coherent=True, jitter=0.05):
    """Streaks ``spacing`` cells apart (Gaussian, sigma 0.25 spacing, jittered by ``jitter``
    spacing), random phase per plane, zero mean and unit variance. Coherent: one smooth
    amplitude along x for all the streaks of a plane (each row is periodic); else each streak
    has its own."""
    y = np.arange(ny) + 0.5
    x = np.arange(nx) + 0.5
    out = np.zeros((nt, nx, ny))

    def amplitude():
        return 1.0 + 0.5 * np.sin(2 * np.pi * x / nx * rng.integers(1, 4) + rng.uniform(0, 6.3))

    for t in range(nt):
        phase = rng.uniform(0, spacing)
        amp = amplitude()
        for j in range(int(round(ny / spacing))):
            y0 = phase + spacing * (j + jitter * rng.standard_normal())
            gy = np.exp(-0.5 * (((y - y0 + ny / 2) % ny - ny / 2) / (0.25 * spacing)) ** 2)
            out[t] += np.outer(amp if coherent else amplitude(), gy)
    out -= out.mean(axis=(1, 2), keepdims=True)
    return out / out.std()


# ------------------------------------------------------------------------------------------
# a lattice of streaks 3-8 cells apart over a red (k^-1) background
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("parcels, weight", DENSITIES)
@pytest.mark.parametrize("spacing", [3, 4, 5, 6, 8])
def test_streak_lattice_over_a_red_background_in_every_reading(spacing, parcels, weight):
    """Streaks (intensity standard deviation 25 % of the mean) over a k^-1 background of the
    same variance, 60 planes of 64 x 120 columns (whole numbers of streaks for every spacing):
    both spectral readings within half a mode of 1/spacing, the correlation within half a cell
    (the background's decay moves its minimum out by 0.2-0.3 cell)."""
    rng = np.random.default_rng(100 * spacing + int(weight))
    nt, nx, ny = 60, 64, 120
    intensity = (1.0 + 0.25 * streak_lattice(nt, nx, ny, spacing, rng)
                 + 0.25 * power_law_field(nt, nx, ny, rng))
    sp = spacing_as_analysed(parcel_planes(intensity, parcels, weight, rng), weight)
    assert sp.chosen == sp.premultiplied
    half_mode = 0.5 / (ny * D)
    for name, value in (("premultiplied", sp.premultiplied), ("density", sp.density)):
        assert abs(1.0 / value - 1.0 / (spacing * D)) <= half_mode, (name, value / D)
    assert abs(sp.correlation / D - spacing) <= 0.5, sp.correlation / D


def test_individual_streaks_read_long_in_the_correlation():
    """Streaks of individual amplitudes add a bump of the streaks' own width at zero lag: the
    spectra still read the lattice, the correlation's first minimum reads long; the same strictly
    periodic lattice with one amplitude for all its streaks reads right."""
    nt, nx, ny, spacing = 60, 64, 120, 8
    cells = {}
    for coherent in (True, False):
        rng = np.random.default_rng(7)
        intensity = 1.0 + 0.25 * streak_lattice(nt, nx, ny, spacing, rng, coherent=coherent,
                                                jitter=0.0)
        planes = parcel_planes(intensity, PAPER_PARCELS, 1.0, rng)
        cells[coherent] = in_cells(spacing_as_analysed(planes, 1.0))
        assert np.all(np.abs(cells[coherent][:2] - spacing) <= 0.1), cells
    assert abs(cells[True][2] - spacing) <= 0.1, cells
    assert cells[False][2] > spacing + 0.3, cells             # 8.5 cells


# ------------------------------------------------------------------------------------------
# no spacing: a pure k^-1 background, white noise
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pure_k_minus_one_background_has_no_spacing(seed):
    """k^-1: flat premultiplied, decaying density, logarithmically decaying correlation; no
    reading finds a spacing, alone or through parcel counts at either density."""
    rng = np.random.default_rng(seed)
    nt, nx, ny = 100, 64, 48
    field = power_law_field(nt, nx, ny, rng)
    ky, S, _, sp = st.spanwise_spacing(field, D)
    pre = (ky * S)[1:-1]
    # the field is what it claims: flat in premultiplied form, within its sampling scatter
    assert abs(pre[: pre.size // 2].mean() / pre[pre.size // 2:].mean() - 1.0) < 0.1
    assert np.all(np.isnan(in_cells(sp)))
    for parcels, weight in ((PAPER_PARCELS, 1.0), (PAPER_PARCELS / RUN_Q_MULTIPLIER,
                                                   RUN_Q_MULTIPLIER)):
        planes = parcel_planes(1.0 + 0.3 * field, parcels, weight, rng)
        assert np.all(np.isnan(in_cells(spacing_as_analysed(planes, weight)))), (parcels, seed)


@pytest.mark.parametrize("parcels, weight", DENSITIES)
@pytest.mark.parametrize("nt, ny, seed", [(20, 48, 0), (100, 48, 1), (300, 48, 2),
                                          (60, 150, 3)])
def test_white_noise_has_no_spacing_in_any_reading(nt, ny, seed, parcels, weight):
    """Parcel counts of a uniform concentration (at 150 columns across the density reading
    accepts a noise peak in ~1.5 % of records: the seeds here are records where it does not)."""
    rng = np.random.default_rng(seed)
    planes = parcel_planes(np.ones((nt, 64, ny)), parcels, weight, rng)
    assert np.all(np.isnan(in_cells(spacing_as_analysed(planes, weight))))


# ------------------------------------------------------------------------------------------
# where the readings part
# ------------------------------------------------------------------------------------------
def test_a_knee_is_a_premultiplied_peak_and_no_density_peak():
    """A density white at long wavelengths and falling as exp(-(ky/k0)^2): ky S peaks at
    k0/sqrt(2); the density and the (Gaussian) correlation decay monotonically."""
    rng = np.random.default_rng(4)
    nt, nx, ny, k0 = 100, 64, 96, 0.15                  # k0 in cycles per cell
    kx = np.fft.fftfreq(nx)[:, None]
    ky = np.fft.rfftfreq(ny)[None, :]
    amp = np.exp(-0.5 * (ky / k0) ** 2 - (kx / 0.05) ** 2)
    field = np.fft.irfft2(np.fft.rfft2(rng.standard_normal((nt, nx, ny))) * amp, s=(nx, ny))
    _, _, _, sp = st.spanwise_spacing(field, D)
    # modes are 1/96 cycle per cell apart at k0/sqrt(2) = 10.2 modes
    assert sp.premultiplied / D == pytest.approx(math.sqrt(2) / k0, rel=0.05)
    assert math.isnan(sp.density)
    assert math.isnan(sp.correlation)


# ------------------------------------------------------------------------------------------
# the criteria on given spectra
# ------------------------------------------------------------------------------------------
def test_premultiplied_peak_criterion_on_given_block_spectra():
    rng = np.random.default_rng(0)
    ky = np.arange(33) / 9.6                            # 9.6 m across, 64 cells of 0.15 m
    k_minus_one = np.where(ky > 0, 1.0 / np.maximum(ky, 1e-12), 1.0)   # flat ky S
    bump = np.exp(-0.5 * (np.log(ky / 1.25 + 1e-12) / 0.08) ** 2)    # at mode 12 (0.8 m)
    nb, rel = 8, 0.1                                    # blocks scatter by 10 %
    scatter = 1.0 + rel * rng.standard_normal((nb, ky.size))

    def peak(height_in_se, scatter=scatter):
        se12 = rel * 1.0 / math.sqrt(nb)                # standard error of ky S at mode 12
        blocks = (k_minus_one * (1.0 + height_in_se * se12 * bump))[None, :] * scatter
        return st.premultiplied_peak(ky, blocks.mean(axis=0), blocks)

    # threshold 4.5 sqrt(2) ~ 6.4 standard errors over a flat premultiplied base
    assert 1 / peak(12.0) == pytest.approx(0.8, abs=0.02)
    assert math.isnan(peak(2.0))                        # within the sampling noise
    assert math.isnan(peak(0.0))                        # flat: no peak
    # the same bump is a peak or not by its blocks' scatter alone
    assert math.isnan(peak(12.0, 1.0 + 5 * rel * rng.standard_normal((nb, ky.size))))
    # ky S monotonic to either end is no peak: the longest wavelength and the Nyquist mode
    # are ends, not maxima
    for S in (k_minus_one / (1.0 + ky), k_minus_one * (1.0 + ky)):
        blocks = S[None, :] * scatter
        assert math.isnan(st.premultiplied_peak(ky, blocks.mean(axis=0), blocks))
    # without blocks, the fallback margin: 10 % over a flat base is not a peak, 50 % is
    assert math.isnan(st.premultiplied_peak(ky, k_minus_one * (1.0 + 0.1 * bump)))
    assert 1 / st.premultiplied_peak(ky, k_minus_one * (1.0 + 0.5 * bump)) == \
        pytest.approx(0.8, abs=0.02)


def test_nyquist_half_bin_is_no_peak():
    """White parcel noise on an even grid: the Nyquist entry of the one-sided density is a
    half bin. Read as a point density it would make the mode before it a premultiplied peak."""
    rng = np.random.default_rng(5)
    planes = parcel_planes(np.ones((100, 64, 48)), PAPER_PARCELS, 1.0, rng)
    ky, S, _, blocks = st.spanwise_spectrum_blocks(planes, D)
    assert S[-1] == pytest.approx(0.5 * S[1:-1].mean(), rel=0.1)
    assert math.isfinite(st.premultiplied_peak(ky, S, blocks))
    assert math.isnan(st.premultiplied_peak(ky, S, blocks, nyquist_half_bin=True))


@pytest.mark.parametrize("ny", [48, 47])
def test_spanwise_autocovariance_inverts_the_spectrum(ny):
    rng = np.random.default_rng(ny)
    planes = rng.standard_normal((5, 16, ny)).cumsum(axis=2)
    dev = planes - planes.mean(axis=(1, 2), keepdims=True)
    F = np.fft.fft(dev, axis=2)
    direct = (np.fft.ifft(np.abs(F) ** 2, axis=2).real / ny).mean(axis=(0, 1))
    ky, S, _, _ = st.spanwise_spectrum_blocks(planes, D)
    lag, C = st.spanwise_autocovariance(ky, S, D)
    assert lag.size == ny // 2 + 1 and lag[1] == pytest.approx(D)
    np.testing.assert_allclose(C, direct[: ny // 2 + 1], rtol=1e-10, atol=1e-12 * direct[0])


def test_correlation_minimum_of_given_spectra():
    ny = 60
    ky = np.arange(ny // 2 + 1) / (ny * D)
    # one spanwise cosine of 6 cells: C ~ cos, first minimum at 3 cells
    line = np.zeros(ky.size)
    line[10] = 1.0
    rng = np.random.default_rng(1)
    nb = 8
    blocks = (line + 0.02 * rng.standard_normal((nb, ky.size)))
    assert 2 * st.correlation_minimum(ky, blocks.mean(axis=0), D, blocks) / D == \
        pytest.approx(6.0, abs=0.1)
    # a monotonic correlation (white at long wavelengths, Gaussian fall-off) has no minimum
    smooth = np.exp(-(ky / 1.5) ** 2)
    blocks = smooth * (1.0 + 0.05 * rng.standard_normal((nb, ky.size)))
    assert math.isnan(st.correlation_minimum(ky, blocks.mean(axis=0), D, blocks))
    # the same cosine under block scatter larger than its swing: no minimum
    blocks = line + 3.0 * rng.standard_normal((nb, ky.size))
    assert math.isnan(st.correlation_minimum(ky, line, D, blocks))
    # without blocks, the fallback rise (0.1 in correlation units)
    assert 2 * st.correlation_minimum(ky, line, D) / D == pytest.approx(6.0, abs=0.1)
    weak = smooth + 0.02 * line * smooth.sum()          # a swing of ~0.03 on a large bump
    assert math.isnan(st.correlation_minimum(ky, weak, D))


@pytest.mark.parametrize("seed", [6, 20, 95, 126, 194])
def test_a_noise_maximum_must_stand_out_of_both_valley_floors(seed):
    """Parcels 16x heavier, 20 planes: with the run's noise less the paper's removed, ky S of
    pure noise rises gently (the paper's floor times ky) under a scatter that grows as ky. A
    noise maximum near the Nyquist mode then stands out of its floor at long wavelengths (whose
    error is small) but not out of the one on its short-wavelength side: no peak. (In these
    records it passed the test against the higher floor alone.)"""
    rng = np.random.default_rng(90000 + 7 * seed + 48 + 20)
    planes = parcel_planes(np.ones((20, 64, 48)), PAPER_PARCELS / RUN_Q_MULTIPLIER,
                           RUN_Q_MULTIPLIER, rng)
    assert math.isnan(spacing_as_analysed(planes, RUN_Q_MULTIPLIER).premultiplied)


def test_a_first_minimum_lost_in_the_noise_is_no_spacing():
    """A faint lattice (5 % intensity contrast, 4 cells) through the heaviest parcels: the
    correlation's later minima are as deep as its first, so one of them may stand out where the
    first does not; reading it would give a multiple of the spacing (27.6 cells in this
    record), so the first minimum decides. In another record of the same field it stands out,
    and the reading is right."""
    found = {}
    for seed in (15, 11):
        rng = np.random.default_rng(seed)
        intensity = 1.0 + 0.05 * streak_lattice(100, 64, 60, 4, rng)
        planes = parcel_planes(intensity, PAPER_PARCELS / RUN_Q_MULTIPLIER, RUN_Q_MULTIPLIER, rng)
        found[seed] = spacing_as_analysed(planes, RUN_Q_MULTIPLIER).correlation / D
    assert math.isnan(found[15]), found
    assert found[11] == pytest.approx(4.0, abs=0.25), found
