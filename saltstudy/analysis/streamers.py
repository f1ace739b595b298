"""Aeolian streamers from the C_p planes: lambda_x, lambda_y, delta_y, lifetime and speed.

``C_p(x, y)`` is the vertically integrated, Q-weighted grain count per unit bed area [m-2]
(paper section 4.1, Fig. 9a), recorded every ``plane_interval`` seconds. All fields are periodic
in x and y, so every correlation and spectrum here is computed with FFTs on the full periodic
domain (no windowing, no padding). Each plane is reduced to its deviation from its own spatial
mean before correlating: the statistics describe the spatial pattern, not the drift of the
domain mean.

Parcel-count (sampling) noise (beyond the paper)
    C_p counts parcels of ``w`` grains each (``w`` = the run's parcel weight, the case's Q times
    the fidelity's ``q_multiplier``; samples.nc attribute ``Q``), so a column of area
    ``A = dx dy`` holds ``N = C_p A / w`` parcels. samples.nc keeps C_p, not N: the counts are
    recovered from C_p and ``w`` (:func:`parcels_per_cell`). Given the concentration pattern,
    the count of each column is Poisson: its variance is its mean. Averaged over the plane the
    noise is white in space with variance ``n_bar`` parcels^2, ``n_bar`` the plane's mean count
    per column, i.e. in C_p units

        ``s^2 = n_bar (w / A)^2 = mean(C_p) w / A``        (:func:`poisson_noise_variance`)

    known from the plane's mean alone. It adds ``s^2`` to every non-zero 2-D Fourier mode (to
    the autocovariance at zero lag) and a flat floor ``s^2 dy`` per two-sided mode to the
    spanwise spectrum, and nothing else. It is *not* estimated from the high-wavenumber band:
    streamers 2.5-6 cells wide put real power there.

    The paper's own estimate carried the noise of its own parcels: the case's Q on 0.1 m x 0.1 m
    columns (about 20 parcels per column in case 2, 6e5 parcels over 200 x 150 columns), i.e.
    ``s_paper^2 = mean(C_p) Q / A_paper`` in C_p units, which depends on the concentration, not
    on the grid. A run with heavier parcels or other columns has ``s^2`` instead.
    **The reported statistics (lambda_x, lambda_y, the spectrum S_c, R_cu) carry the paper's
    noise level**: ``s^2 - s_paper^2`` is removed from each plane (added when it is negative: a
    run whose columns hold more parcels than the paper's would). Why: Table 2's numbers are the
    noisy estimate, and this makes the parcel weight and the column size pure cost knobs for
    them -- at the paper's Q and grid nothing is removed and the analysis is the paper's. The
    paper's noise is small (at 20 parcels per column and a C_p contrast of order one, a few %
    of the variance), so the noise-free values (``lambda_x_noise_free``,
    ``lambda_y_noise_free``: all of ``s^2`` removed, the streamer core of the concentration
    pattern itself) are kept beside them, and so are the run's own values (``*_raw``: nothing
    removed) and those with the noise of the paper's *count* (``*_paper_count``,
    :func:`count_noise_variance`: the run's noise replaced by 1/20 of mean(C_p)^2 on 0.1 m
    columns, the relative noise of 2,000 parcels per m2, [28]). The paper-level reading assumes
    the paper's parcels carried the run's concentration; a run holding k times the paper's
    airborne grains at Q is then read k times less noisy than the paper's field was, and the
    paper-count reading is the one that sees the paper's noise when the model's count is not
    the paper's.

    The Poisson variance is that of independent parcels. Parcels ejected together from one
    impact travel together for a while, which raises the variance of the counts at the scale of
    such clusters by a factor F (the counts' variance over their mean); a parcel's ejecta are
    parcels of its own weight, so that excess also scales with the weight, and the paper's
    level would be reached by removing ``F (s^2 - s_paper^2)``. F is not known from the counts
    (a pattern 2-4 cells wide looks the same), so F = 1 is removed and the reported values lie
    between the run's raw ones and the paper-level ones when F > 1.
    ``C_p_small_scale_over_poisson`` (:func:`small_scale_power` over ``s^2``), the power at
    wavelengths under 4 cells in both directions -- where an elongated pattern has little --
    over the Poisson floor, bounds F from above: 1.5-1.7 in the reduced study (measured when
    that band was the noise estimate), 1.9-2.5 in the smoke study's tiny grid.

lambda_x, lambda_y (section 4.1 [46], Table 2)
    "estimated from time-average spatial autocorrelation of C_p in the horizontal section. We
    defined the core of the streamer as the region where the autocorrelation is higher than 0.4".
    :func:`autocorrelation_2d` averages the spatial autocovariance of the planes over time and
    normalises it by its value at zero lag (the time-averaged spatial variance), after the
    sampling-noise variance to remove has been taken out of every non-zero Fourier mode of each
    plane. The ratio of the averages, rather than the average of per-plane ratios, because a
    plane's noise-corrected variance is a small difference at ~1 parcel per column; planes
    without variance (no grains) are skipped.
    :func:`core_length` reads the extent of the > 0.4 region through the origin along one axis:
    twice the first lag at which the correlation drops below 0.4 (linear interpolation between
    the bracketing lags). NaN if it stays above 0.4 up to half the domain (the core then spans
    the periodic domain and has no measurable length).

delta_y (section 4.1 [46], [49], Fig. 10; the reading: docs/STREAMERS.md)
    "The two-dimensional Fourier transform of C_p averaged in time and over longitudinal
    wavelengths shows a well-defined maximum ... corresponding to the mean lateral spacing
    delta_y between streamers". By Parseval in x, the 2-D power spectrum averaged over kx equals
    the 1-D spanwise spectrum averaged over x rows; :func:`spanwise_spectrum` returns it as a
    one-sided density in ky (cycles m-1; ``sum S dky`` = variance), with the spectra of
    ``N_BLOCKS`` contiguous time blocks (:func:`spanwise_spectrum_blocks`) for its sampling
    error. :func:`spanwise_spacing` reads delta_y three ways, each judged against that error:

    * premultiplied (Table 2's reading, ``delta_y``): ``1/ky`` at the peak of ``ky S(ky)`` on a
      logarithmic wavelength axis (:func:`premultiplied_peak`), read on the spectrum with the
      paper's parcel noise (S_c): white noise rises as ky there, and heavier parcels must not
      tilt it. A k^-1 density is flat in this form and has no peak;
    * density: ``1/ky`` at the peak of ``S(ky)`` (:func:`spectral_peak`), read on the spectrum
      with the run's noise in it: a flat floor moves neither the peak nor its prominence;
    * correlation: twice the lag of the first minimum of the spanwise autocorrelation
      (averaged over x and time, from S: :func:`spanwise_autocovariance`) after which the
      correlation rises again by ``CORRELATION_N_SE`` standard errors
      (:func:`correlation_minimum`). It reads the alternation of high and low values, and
      individually varying streaks (each with its own amplitude) add a bump at zero lag of the
      streaks' own width, which moves the first minimum out: over such streaks it reads a
      longer spacing than the spectra.

    The spectral peaks share one criterion (:func:`_prominent_maximum`), with no limit on the
    wavelength but the grid's (a local maximum needs a neighbour on each side, so the shortest
    spacing is just over 2 cells):

    * candidates are interior local maxima, modes ``2 <= m < M`` (not the domain-scale mode
      m = 1, whose "spacing" is the domain width, and not the last mode M);
    * each candidate's *base* is the higher of the two valley floors that separate it from a
      higher point (or from the ends of the spectrum) on its left and its right (topographic
      prominence);
    * it counts as a peak if ``S_peak - base >= PEAK_N_SE * sqrt(se_peak^2 + se_base^2)``. The
      standard errors come from the scatter of the block spectra: a periodogram average has a
      standard deviation proportional to its mean, so the relative block variance is pooled over
      the ``PEAK_POOL_MODES`` modes on either side of the candidate (more degrees of freedom
      than one mode's 7) and scaled by ``S_peak`` and ``base``. ``PEAK_N_SE`` = 4.5 allows for
      the selection of a maximum over a minimum among ~20-70 modes. Measured on Poisson parcel
      counts: on pure noise (64 x 48 columns, 20 or 300 planes, 1.25 or 20 parcels per
      column) it accepts a peak in 1 record of 400; a lattice of streaks 2.5-6 cells apart
      (64 x 60 columns)
      whose count intensity varies by 11 % (spatial standard deviation over mean) is found,
      at the right spacing, in 34 records of 40 at 1.25 parcels per column over 100 planes
      (4.0 standard errors: 10 false peaks in 400; 5.0: 25 of 40 found);
    * the standard errors are those of the spectrum with the run's noise in it (the "raw"
      spectrum; for the premultiplied reading times ky): removing a known floor shifts a
      spectrum, not its scatter, and the noise a peak stands out of is the run's. A
      heavier-parcel run therefore finds a peak only where it stands out of its own (larger)
      noise. In the premultiplied reading ``ky S_raw`` grows along the spectrum, so a valley
      floor at long wavelengths has a small error and the higher floor need not be the one a
      peak stands least out of: the peak must stand out of both floors;
    * measured on the same records of pure Poisson noise (both densities): the premultiplied
      reading accepts a peak in none of 1200 records of 64 x 48 columns (20, 100 or 300
      planes) and none of 400 of 64 x 150 (20 or 60 planes); the density reading in 8 of 1200
      and 6 of 400 (the false rate grows with the number of modes searched). A faint lattice
      (coherent streaks 3-6 cells apart, intensity standard deviation 5 % of the mean, 64 x 60
      columns, 100 planes, 1.25 parcels per column) is found at its spacing in 72 records of 80
      by the density reading and 26 of 80 by the premultiplied one: white noise rises as ky in
      premultiplied form and lifts the floor on a peak's short-wavelength side;
    * the Nyquist mode of an even number of cells holds the density of half a bin (so that
      ``sum S dky`` is the variance); the premultiplied reading doubles it to a point density,
      or a spectrum rising to the Nyquist mode would show a false peak one mode before it;
    * with fewer than ``MIN_BLOCKS`` blocks (fewer than 4 planes) there is no error estimate and
      a peak must stand ``PEAK_FALLBACK_MARGIN`` (20 %) above its base;
    * of the accepted peaks the highest wins; its ky is refined by a parabola through the three
      points around it (in ln ky for the premultiplied reading). A monotonically decaying
      density (or one whose only maximum is the domain mode), or white noise, has no accepted
      density peak; a premultiplied spectrum that is flat or monotonic up to either end, or
      white noise, has no accepted premultiplied peak: the reading is NaN. A decaying density
      with a knee (white at long wavelengths, steeper than k^-1 at short ones) has a
      premultiplied peak at the knee and no density peak: there the readings part.

    The correlation minimum is judged on the autocovariance of the blocks: its standard error
    at each lag is the blocks' standard deviation over sqrt(nb), squared and pooled over
    ``PEAK_POOL_MODES`` lags on either side. On the pure-noise records above it accepts a
    minimum in none of 1200 (64 x 48) and 1 of 400 (64 x 150); one lag's own 7 degrees of
    freedom would let 3 and 4 pass. Only the first local minimum is judged: a periodic
    pattern's later minima are as deep as its first, and one of them standing out where the
    first does not would read a multiple of the spacing. On the faint lattice above it finds
    the spacing in 1 record of 80: it is the least sensitive reading.

Streamer lifetime and propagation speed (beyond the paper; compare Baas and Sherman 2005,
quoted in section 4.1 [46]: lifetime 0.5-1 s, speed 3.6 m s-1)
    :func:`space_time_correlation` correlates ``C_p'(t)`` with ``C_p'(t + tau)`` at all spatial
    lags (normalised per pair of planes, averaged over time origins). For each ``tau`` the peak
    value ``R*(tau)`` and its position ``(X*(tau), Y*(tau))`` (parabolic sub-grid refinement,
    unwrapped across the periodic boundary) describe the moving frame.
    ``streamer_speed`` = least-squares slope through the origin of ``X*(tau)`` against ``tau``
    over the lags with ``R* >= 1/e``; ``streamer_lifetime`` = the lag at which ``R*`` first
    drops below ``1/e`` (linear interpolation), NaN if it does not within the lag range.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import paper_grid

__all__ = ["CORE_LEVEL", "PEAK_N_SE", "PEAK_POOL_MODES", "PEAK_FALLBACK_MARGIN", "N_BLOCKS",
           "MIN_BLOCKS", "SMALL_SCALE_K", "PAPER_CELL_AREA",
           "deviation_planes", "parcels_per_cell", "poisson_noise_variance", "count_noise_variance",
           "small_scale_power",
           "centred_lags", "autocorrelation_2d", "core_length", "spanwise_spectrum",
           "spanwise_spectrum_blocks", "spectral_peak", "premultiplied_peak",
           "spanwise_autocovariance", "correlation_minimum", "CORRELATION_N_SE",
           "CORRELATION_FALLBACK_RISE", "SpanwiseSpacing", "spanwise_spacing", "SpaceTime",
           "space_time_correlation", "speed_and_lifetime"]

CORE_LEVEL = 0.4
#: a spectral peak must stand this many standard errors above its base
PEAK_N_SE = 4.5
#: modes on either side of a candidate over which the relative block variance is pooled
PEAK_POOL_MODES = 3
#: relative height over its base of a peak in a record too short for an error estimate
PEAK_FALLBACK_MARGIN = 0.2
#: the spanwise correlation must rise this many standard errors after a minimum
CORRELATION_N_SE = 5.0
#: that rise, in correlation units, in a record too short for an error estimate
CORRELATION_FALLBACK_RISE = 0.1
#: contiguous time blocks of the spanwise spectrum's error estimate
N_BLOCKS = 8
#: fewest blocks with which the error estimate is used
MIN_BLOCKS = 4
#: small-scale modes of the diagnostic: |kx| and |ky| both at least this many cycles per cell
SMALL_SCALE_K = 0.25


#: bed area of one column of the paper's grid [m2] (0.1 m x 0.1 m, section 2.4 [26])
PAPER_CELL_AREA = paper_grid.PAPER_CELL_AREA


def deviation_planes(planes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(planes minus their own spatial mean, per-plane variance) for (nt, nx, ny) input."""
    p = np.asarray(planes, dtype=np.float64)
    p = np.where(np.isfinite(p), p, 0.0)
    dev = p - p.mean(axis=(1, 2), keepdims=True)
    var = (dev ** 2).mean(axis=(1, 2))
    return dev, var


def _has_variance(var: np.ndarray) -> np.ndarray:
    # relative to the largest plane variance: a plane of round-off noise is not a pattern
    scale = float(np.max(var)) if var.size else 0.0
    return var > max(1e-14 * scale, 1e-300)


def _plane_means(planes: np.ndarray) -> np.ndarray:
    p = np.asarray(planes, dtype=np.float64)
    return np.where(np.isfinite(p), p, 0.0).mean(axis=(1, 2))


def parcels_per_cell(planes: np.ndarray, grains_per_parcel: float, cell_area: float) -> np.ndarray:
    """Mean number of parcels per column of each (nt, nx, ny) C_p plane: ``mean(C_p) A / w``."""
    return _plane_means(planes) * cell_area / grains_per_parcel


def poisson_noise_variance(planes: np.ndarray, grains_per_parcel: float,
                           cell_area: float) -> np.ndarray:
    """Per-plane variance [m-4] of the Poisson parcel-count noise of C_p (module docstring):
    ``mean(C_p) w / A`` for parcels of ``w`` grains on columns of area ``A``."""
    if not (grains_per_parcel > 0 and cell_area > 0):
        return np.full(np.shape(planes)[0], np.nan)
    return _plane_means(planes) * grains_per_parcel / cell_area


def count_noise_variance(planes: np.ndarray, parcels_per_m2: float,
                         cell_area: float) -> np.ndarray:
    """Per-plane variance [m-4] of the Poisson noise C_p would carry if its mean were made of
    ``parcels_per_m2`` parcels per m2 on columns of area ``A``: ``mean(C_p)^2 / (n A)``, the
    same relative noise (1 / parcels per column) whatever the concentration. For the paper's
    count (2,000 per m2 at its Q, [28]) on its 0.1 m columns that is 1/20 of mean(C_p)^2: the
    noise of the paper's field, where :func:`poisson_noise_variance` at the paper's Q is the
    noise of the paper's parcels carrying the run's concentration."""
    if not (parcels_per_m2 > 0 and cell_area > 0):
        return np.full(np.shape(planes)[0], np.nan)
    return _plane_means(planes) ** 2 / (parcels_per_m2 * cell_area)


def small_scale_power(dev: np.ndarray) -> np.ndarray:
    """Per-plane mean of ``|FFT2|^2 / (nx ny)`` over the modes with ``|kx|, |ky| >= SMALL_SCALE_K``
    cycles per cell (white noise of variance s^2 gives s^2 there); zeros when the grid has no
    such mode. A diagnostic of the noise beside its Poisson value, not a noise estimate."""
    dev = np.asarray(dev, dtype=np.float64)
    nt, nx, ny = dev.shape
    kx = np.abs(np.fft.fftfreq(nx))
    ky = np.abs(np.fft.fftfreq(ny))
    corner = (kx[:, None] >= SMALL_SCALE_K) & (ky[None, :] >= SMALL_SCALE_K)
    if nt == 0 or not corner.any():
        return np.zeros(nt)
    out = np.empty(nt)
    for t in range(nt):
        P = np.abs(np.fft.fft2(dev[t])) ** 2 / (nx * ny)
        out[t] = P[corner].mean()
    return out


def centred_lags(n: int, d: float) -> np.ndarray:
    """Lags of a fftshift-ed periodic correlation: ``(i - n//2) d`` for i = 0..n-1."""
    return (np.arange(n) - n // 2) * d


def autocorrelation_2d(planes: np.ndarray, noise: np.ndarray | None = None) -> np.ndarray:
    """Time-averaged normalised periodic autocorrelation of (nt, nx, ny) planes.

    Returned fftshift-ed: zero lag at ``[nx//2, ny//2]`` (see :func:`centred_lags`). ``noise``
    (nt,): white-noise variance removed from each plane, from every non-zero Fourier mode (the
    expected effect of white noise on a plane whose mean has been removed). The autocovariance
    is averaged over the planes with variance and normalised by its zero-lag value (module
    docstring). All NaN if no plane has variance or none is left after the noise.
    """
    planes = np.asarray(planes, dtype=np.float64)
    nt, nx, ny = planes.shape
    dev, var = deviation_planes(planes)
    ok = _has_variance(var)
    noise = np.zeros(nt) if noise is None else np.asarray(noise, dtype=np.float64)
    if nt == 0 or not ok.any() or not np.all(np.isfinite(noise[ok])):
        return np.full((nx, ny), np.nan)
    P = np.zeros((nx, ny // 2 + 1))
    for t in np.flatnonzero(ok):
        F = np.fft.rfft2(dev[t])
        P += (F.real ** 2 + F.imag ** 2) / (nx * ny)
    P[0, 0] = 0.0                      # the planes' own means are out
    # white noise of variance s^2 puts s^2 into every mode of the full 2-D transform; the
    # half-plane rfft2 holds each mode once and irfft2 restores the conjugate partners
    n_ok = int(ok.sum())
    P_w = P - float(noise[ok].sum())
    P_w[0, 0] = 0.0
    acov = np.fft.irfft2(P_w, s=(nx, ny)) / n_ok
    if not acov[0, 0] > 1e-14 * float(var[ok].mean()):
        return np.full((nx, ny), np.nan)
    return np.fft.fftshift(acov / acov[0, 0])


def core_length(r_centred_1d: np.ndarray, d: float, level: float = CORE_LEVEL) -> float:
    """Full extent of ``r > level`` through the origin of a centred periodic correlation cut.

    ``r_centred_1d[n//2]`` is zero lag. Uses lags 0..n//2: the periodic correlation is even.
    """
    r = np.asarray(r_centred_1d, dtype=np.float64)
    n = r.size
    i0 = n // 2
    if n < 2 or not np.isfinite(r[i0]):
        return math.nan
    pos = r[i0:]                              # lags 0, d, ..., (n - 1 - i0) d
    neg = r[i0::-1]                           # lags 0, -d, ..., -i0 d
    m = min(pos.size, neg.size)
    half = 0.5 * (pos[:m] + neg[:m])
    if n % 2 == 0 and neg.size > m:           # lag n/2 appears once (the -n/2 image)
        half = np.append(half, neg[m])
    for k in range(1, half.size):
        if half[k] < level:
            s = (half[k - 1] - level) / (half[k - 1] - half[k])
            return float(2.0 * d * (k - 1 + s))
    return math.nan


def spanwise_spectrum_blocks(planes: np.ndarray, dy: float, n_blocks: int = N_BLOCKS,
                             noise: np.ndarray | None = None
                             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(ky [cycles m-1], S(ky), standard error of S, block spectra (nb, nky)) of (nt, nx, ny)
    planes.

    One-sided density: ``sum_m S_m dky`` = mean spatial variance of the planes (dky = 1/Ly).
    Averaged over x (= over kx by Parseval) and time. The blocks are ``min(n_blocks, nt)``
    contiguous runs of planes; the standard error is their standard deviation over sqrt(nb)
    (NaN with fewer than 4 planes, and then no blocks: shape (0, nky)).
    ``noise`` (nt,): each plane's white-noise variance s^2, whose floor is subtracted (``s^2/ny``
    per two-sided mode of a row, ``(1 - 1/nx) s^2/ny`` at ky = 0 where the rows' means keep
    only their deviation from the plane's).
    """
    planes = np.asarray(planes, dtype=np.float64)
    nt, nx, ny = planes.shape
    Ly = ny * dy
    ky = np.arange(ny // 2 + 1) / Ly
    if nt == 0:
        nan = np.full(ky.size, np.nan)
        return ky, nan, nan.copy(), np.zeros((0, ky.size))
    dev, _ = deviation_planes(planes)
    F = np.fft.rfft(dev, axis=2)                     # (nt, nx, nky)
    P = (F.real ** 2 + F.imag ** 2).mean(axis=1) / ny ** 2   # (nt, nky): sum of 2-sided = var
    w = np.full(ky.size, 2.0)
    w[0] = 1.0
    if ny % 2 == 0:
        w[-1] = 1.0
    if noise is not None:
        floor = np.full(ky.size, 1.0 / ny)
        floor[0] *= 1.0 - 1.0 / nx
        P = P - np.asarray(noise, dtype=np.float64)[:, None] * floor[None, :]
    P = P * w * Ly                                   # density: divide by dky = 1/Ly
    S = P.mean(axis=0)
    se = np.full(ky.size, np.nan)
    bm = np.zeros((0, ky.size))
    nb = min(n_blocks, nt)
    if nt >= 4 and nb >= 2:
        blocks = np.array_split(np.arange(nt), nb)
        bm = np.array([P[b].mean(axis=0) for b in blocks])
        se = bm.std(axis=0, ddof=1) / math.sqrt(nb)
    return ky, S, se, bm


def spanwise_spectrum(planes: np.ndarray, dy: float, n_blocks: int = N_BLOCKS,
                      noise: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ky, S, standard error of S): :func:`spanwise_spectrum_blocks` without the blocks."""
    ky, S, se, _ = spanwise_spectrum_blocks(planes, dy, n_blocks, noise)
    return ky, S, se


def _valley_floors(S: np.ndarray, m: int) -> tuple[int, int]:
    """Indices of the two valley floors between mode m and a higher point (or the ends of the
    spectrum, modes 1..M) on its left and on its right."""
    M = S.size - 1
    j = m - 1
    while j >= 1 and S[j] <= S[m]:
        j -= 1
    left = np.arange(j + 1, m)
    j = m + 1
    while j <= M and S[j] <= S[m]:
        j += 1
    right = np.arange(m + 1, min(j, M + 1))
    return int(left[np.argmin(S[left])]), int(right[np.argmin(S[right])])


def _prominence_base(S: np.ndarray, m: int) -> int:
    """Index of the higher of the two valley floors of mode m (:func:`_valley_floors`)."""
    kl, kr = _valley_floors(S, m)
    return kl if S[kl] >= S[kr] else kr


def _relative_block_variance(S: np.ndarray, blocks: np.ndarray | None) -> np.ndarray | None:
    """Squared relative standard error of each mode of ``S`` from the scatter of the block
    spectra it is the mean of; None with fewer than ``MIN_BLOCKS`` usable blocks."""
    bm = None if blocks is None else np.asarray(blocks, dtype=np.float64)
    if not (bm is not None and bm.ndim == 2 and bm.shape[0] >= MIN_BLOCKS
            and bm.shape[1] == S.size and np.all(np.isfinite(bm[:, 1:]))):
        return None
    nb = bm.shape[0]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(S > 0, bm.var(axis=0, ddof=1) / (nb * S * S), np.nan)


def _prominent_maximum(F: np.ndarray, scale: np.ndarray, rel2: np.ndarray | None,
                       n_se: float, pool: int, fallback_margin: float,
                       both_valleys: bool = False) -> int:
    """Mode of the highest interior maximum of ``F`` (modes ``2 <= m < M``) that stands out of
    its topographic base (module docstring); -1 when none does.

    The standard error of ``F`` at mode i is ``sqrt(r2) scale[i]``, r2 the mean of ``rel2``
    over the ``pool`` modes on either side of the candidate (a periodogram average scatters in
    proportion to its mean, ``scale``). With ``both_valleys`` the peak must stand out of each
    of its two valley floors, not only the higher: where ``scale`` varies along the spectrum
    the higher floor need not be the one the peak stands least out of. Without ``rel2`` a peak
    must stand ``fallback_margin`` times its base's magnitude above it."""
    M = F.size - 1
    best_m, best_f = -1, -math.inf
    for m in range(2, M):
        if not (F[m] > F[m - 1] and F[m] >= F[m + 1]):
            continue
        kb = _prominence_base(F, m)
        base = F[kb]
        if rel2 is not None:
            r2 = rel2[max(1, m - pool): min(M, m + pool) + 1]
            r2 = r2[np.isfinite(r2)]
            if r2.size == 0:
                continue
            floors = _valley_floors(F, m) if both_valleys else (kb,)
            ok = all(F[m] - F[k] >= n_se * math.sqrt(float(r2.mean())
                                                     * (scale[m] ** 2 + scale[k] ** 2))
                     for k in floors)
        else:
            ok = F[m] - base >= fallback_margin * abs(base)
        if ok and F[m] > best_f:
            best_m, best_f = m, F[m]
    return best_m


def spectral_peak(ky: np.ndarray, S: np.ndarray, blocks: np.ndarray | None = None,
                  n_se: float = PEAK_N_SE, pool: int = PEAK_POOL_MODES,
                  fallback_margin: float = PEAK_FALLBACK_MARGIN) -> float:
    """ky [cycles m-1] of the peak of the spectral density ``S`` (the density reading of
    delta_y; criterion in the module docstring); NaN when there is none. ``blocks`` (nb, nky):
    the block spectra S is the mean of (from :func:`spanwise_spectrum_blocks`, with the noise
    left in); with fewer than ``MIN_BLOCKS`` of them the fallback margin applies."""
    ky = np.asarray(ky, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    M = S.size - 1
    if M < 3 or not np.all(np.isfinite(S[1:])) or not np.any(S[1:] > 0):
        return math.nan
    m = _prominent_maximum(S, S, _relative_block_variance(S, blocks), n_se, pool,
                           fallback_margin)
    if m < 0:
        return math.nan
    denom = S[m - 1] - 2.0 * S[m] + S[m + 1]
    shift = 0.5 * (S[m - 1] - S[m + 1]) / denom if denom < 0 else 0.0
    shift = float(np.clip(shift, -0.5, 0.5))
    return float(ky[m] + shift * (ky[1] - ky[0]))


def premultiplied_peak(ky: np.ndarray, S: np.ndarray, blocks: np.ndarray | None = None,
                       S_raw: np.ndarray | None = None, nyquist_half_bin: bool = False,
                       n_se: float = PEAK_N_SE, pool: int = PEAK_POOL_MODES,
                       fallback_margin: float = PEAK_FALLBACK_MARGIN) -> float:
    """ky [cycles m-1] of the peak of the premultiplied spectrum ``ky S(ky)`` on a logarithmic
    wavelength axis (the reading of delta_y that Table 2 uses, docs/STREAMERS.md); NaN when
    there is none.

    ``S`` [variance m]: the density to read (for C_p, the one carrying the paper's parcel
    noise). ``blocks`` (nb, nky) and ``S_raw``: the block spectra of the record with all its
    noise in, and their mean (default ``S``); the standard error of ``ky S`` at a mode is
    ``ky`` times that of ``S_raw`` (removing a known noise floor shifts the spectrum, not its
    scatter). The peak must stand out of its base as in :func:`spectral_peak`; the longest
    resolved wavelength (mode 1) and the Nyquist mode are never peaks, so a premultiplied
    spectrum that is flat (a k^-1 density) or rises or falls to either end has none. The
    position is refined by a parabola through the three modes around the maximum in ln ky.

    ``nyquist_half_bin``: the last mode is the Nyquist mode of an even number of cells, where
    :func:`spanwise_spectrum_blocks` gives the density of a half bin (so that ``sum S dky`` is
    the variance); it is doubled to the point density, else a spectrum rising to the Nyquist
    mode (white noise, premultiplied) would show a false peak one mode before it."""
    ky = np.asarray(ky, dtype=np.float64)
    S = np.array(S, dtype=np.float64)
    S_raw = S.copy() if S_raw is None else np.array(S_raw, dtype=np.float64)
    bm = None if blocks is None else np.array(blocks, dtype=np.float64)
    if nyquist_half_bin:
        S[-1] *= 2.0
        S_raw[-1] *= 2.0
        if bm is not None and bm.ndim == 2 and bm.shape[1] == S.size:
            bm[:, -1] *= 2.0
    M = S.size - 1
    if (M < 3 or S_raw.shape != S.shape or not np.all(np.isfinite(S[1:]))
            or not np.all(np.isfinite(S_raw[1:])) or not np.any(S[1:] > 0)):
        return math.nan
    F = ky * S
    # ky S_raw grows along the spectrum, so a floor at low ky has a small error: both floors
    m = _prominent_maximum(F, ky * S_raw, _relative_block_variance(S_raw, bm), n_se, pool,
                           fallback_margin, both_valleys=True)
    if m < 0:
        return math.nan
    # vertex of the parabola through (ln k, F) at modes m-1, m, m+1 (unevenly spaced in ln k)
    x0, x1, x2 = np.log(ky[m - 1: m + 2])
    f0, f1, f2 = F[m - 1: m + 2]
    a, b = x0 - x1, x2 - x1
    d0, d2 = f0 - f1, f2 - f1
    curv = (d0 * b - d2 * a) / (a * b * (a - b))       # second-order coefficient
    slope = (d0 - curv * a * a) / a
    shift = -0.5 * slope / curv if curv < 0 else 0.0
    shift = float(np.clip(shift, 0.5 * a, 0.5 * b))
    return float(math.exp(x1 + shift))


def spanwise_autocovariance(ky: np.ndarray, S: np.ndarray, dy: float
                            ) -> tuple[np.ndarray, np.ndarray]:
    """(lag [m], C(lag)) of the spanwise autocovariance whose one-sided density ``S`` is (the
    inverse of :func:`spanwise_spectrum_blocks`): ``C(j dy) = sum_m S_m dky cos(2 pi ky_m j dy)``
    for j = 0 .. ny//2, ny = Ly/dy. ``S`` may be (nky,) or (nb, nky) (then C is (nb, nlag))."""
    ky = np.asarray(ky, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    dky = float(ky[1] - ky[0])
    ny = int(round(1.0 / (dky * dy)))
    lag = np.arange(ny // 2 + 1) * dy
    basis = np.cos(2.0 * np.pi * np.outer(ky, lag)) * dky          # (nky, nlag)
    return lag, S @ basis


def correlation_minimum(ky: np.ndarray, S: np.ndarray, dy: float,
                        blocks: np.ndarray | None = None, n_se: float = CORRELATION_N_SE,
                        pool: int = PEAK_POOL_MODES,
                        fallback_rise: float = CORRELATION_FALLBACK_RISE) -> float:
    """Lag [m] of the first minimum of the spanwise autocorrelation that stands out of the
    sampling noise (delta_y of the correlation reading is twice it); NaN when there is none.

    The autocovariance C and its standard error come from ``S`` and the block spectra
    (:func:`spanwise_autocovariance`; the error is the blocks' standard deviation over
    sqrt(nb), its square pooled over the ``pool`` lags on either side). A local minimum at lag
    j (0 < j < ny//2: the half-domain lag, where every periodic correlation is stationary, is
    not one) counts if the correlation rises from it again, before the half-domain lag, by
    ``n_se`` standard errors of the difference: the alternation of high and low values that a
    spacing is. It need not be negative: a red background (motions larger than the spacing)
    lifts the whole correlation without moving the alternation. Only the first local minimum
    is judged (a later one standing out where the first does not would be a multiple of the
    spacing); it is refined by a parabola through its neighbours. With fewer than
    ``MIN_BLOCKS`` blocks the rise must be ``fallback_rise`` in correlation units."""
    ky = np.asarray(ky, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    if S.size < 4 or not np.all(np.isfinite(S)):
        return math.nan
    lag, C = spanwise_autocovariance(ky, S, dy)
    J = lag.size - 1
    if J < 2 or not C[0] > 0:
        return math.nan
    bm = None if blocks is None else np.asarray(blocks, dtype=np.float64)
    se = None
    if (bm is not None and bm.ndim == 2 and bm.shape[0] >= MIN_BLOCKS
            and bm.shape[1] == S.size and np.all(np.isfinite(bm))):
        Cb = spanwise_autocovariance(ky, bm, dy)[1]
        var = Cb.var(axis=0, ddof=1) / bm.shape[0]
        # pooled over neighbouring lags (not the zero lag, whose scatter is of another kind):
        # one lag's 7 degrees of freedom would let an underestimated error pass a noise dip
        se = np.array([math.sqrt(float(var[max(1, j - pool): min(J, j + pool) + 1].mean()))
                       for j in range(J + 1)])
    for j in range(1, J):
        if not (C[j] < C[j - 1] and C[j] <= C[j + 1]):
            continue
        i = j + 1 + int(np.argmax(C[j + 1:]))
        if se is None:
            rise = fallback_rise * C[0]
        else:
            rise = n_se * math.sqrt(se[j] ** 2 + se[i] ** 2)
        if C[i] - C[j] >= rise:
            return float(lag[j] + _parabolic(-C[j - 1], -C[j], -C[j + 1]) * dy)
        # a periodic pattern's later minima are as deep as its first: passing over a first
        # minimum lost in the noise would read a multiple of the spacing
        return math.nan
    return math.nan


@dataclass(frozen=True)
class SpanwiseSpacing:
    """delta_y [m] of one field by the three readings (docs/STREAMERS.md); NaN where a reading
    finds no spacing. ``chosen`` is the reading Table 2 uses."""
    premultiplied: float
    density: float
    correlation: float

    @property
    def chosen(self) -> float:
        return self.premultiplied


def spanwise_spacing(planes: np.ndarray, dy: float, noise: np.ndarray | None = None,
                     n_blocks: int = N_BLOCKS
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, SpanwiseSpacing]:
    """(ky, S, standard error of S, delta_y by the three readings) of (nt, nx, ny) planes.

    ``S`` is the spanwise density with ``noise`` (nt,) removed (:func:`spanwise_spectrum`; for
    C_p, the run's parcel noise less the paper's). The premultiplied peak is read on it; the
    density peak on the spectrum with all the record's noise in (a flat floor moves neither a
    peak of the density nor its prominence); the correlation minimum on ``S`` (white noise
    touches only the zero lag). Every reading's sampling error comes from the blocks of the
    record with all its noise in: that is the scatter a spacing must stand out of."""
    ky, S, se, blocks = spanwise_spectrum_blocks(planes, dy, n_blocks, noise)
    S_raw = S
    if noise is not None:
        _, S_raw, _, blocks = spanwise_spectrum_blocks(planes, dy, n_blocks)
    even = np.shape(planes)[2] % 2 == 0
    spacing = SpanwiseSpacing(premultiplied=1.0 / premultiplied_peak(ky, S, blocks, S_raw, even),
                              density=1.0 / spectral_peak(ky, S_raw, blocks),
                              correlation=2.0 * correlation_minimum(ky, S, dy, blocks))
    return ky, S, se, spacing


def _parabolic(fm: float, f0: float, fp: float) -> float:
    denom = fm - 2.0 * f0 + fp
    if denom >= 0:
        return 0.0
    return float(np.clip(0.5 * (fm - fp) / denom, -0.5, 0.5))


@dataclass(frozen=True)
class SpaceTime:
    """Peak of the space-time correlation of C_p' against time lag."""
    lag_t: np.ndarray      # s
    peak: np.ndarray       # R*(tau)
    x_peak: np.ndarray     # m, unwrapped
    y_peak: np.ndarray     # m, unwrapped


def space_time_correlation(planes: np.ndarray, dt: float, dx: float, dy: float,
                           max_lag_s: float = 5.0, max_origins: int = 200) -> SpaceTime:
    """Peak of ``corr(C_p'(t), C_p'(t + tau))`` over spatial lags, for tau = 0, dt, ..., max_lag.

    Planes with zero variance are skipped; at most ``max_origins`` evenly spread time origins.
    """
    planes = np.asarray(planes, dtype=np.float64)
    nt, nx, ny = planes.shape
    empty = SpaceTime(np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0))
    if nt < 2 or not (dt > 0):
        return empty
    K = int(min(nt - 1, math.floor(max_lag_s / dt + 1e-9)))
    if K < 1:
        return empty
    dev, var = deviation_planes(planes)
    ok = _has_variance(var)
    F = np.fft.rfft2(dev)
    Lx, Ly = nx * dx, ny * dy
    lags, peaks, xs, ys = [], [], [], []
    for k in range(K + 1):
        origins = np.flatnonzero(ok[: nt - k] & ok[k:])
        if origins.size == 0:
            break
        if origins.size > max_origins:
            origins = origins[np.linspace(0, origins.size - 1, max_origins).astype(int)]
        acc = np.zeros((nx, ny))
        for t in origins:
            cc = np.fft.irfft2(np.conj(F[t]) * F[t + k], s=(nx, ny)) / (nx * ny)
            acc += cc / math.sqrt(var[t] * var[t + k])
        acc /= origins.size
        i, j = np.unravel_index(int(np.argmax(acc)), acc.shape)
        sx = _parabolic(acc[(i - 1) % nx, j], acc[i, j], acc[(i + 1) % nx, j])
        sy = _parabolic(acc[i, (j - 1) % ny], acc[i, j], acc[i, (j + 1) % ny])
        X = ((i + sx) * dx + 0.5 * Lx) % Lx - 0.5 * Lx
        Y = ((j + sy) * dy + 0.5 * Ly) % Ly - 0.5 * Ly
        lags.append(k * dt)
        peaks.append(float(acc[i, j]))
        xs.append(X)
        ys.append(Y)
    xs_u = np.unwrap(np.asarray(xs), period=Lx) if xs else np.zeros(0)
    ys_u = np.unwrap(np.asarray(ys), period=Ly) if ys else np.zeros(0)
    return SpaceTime(np.asarray(lags), np.asarray(peaks), xs_u, ys_u)


def speed_and_lifetime(st: SpaceTime, level: float = math.exp(-1.0)) -> tuple[float, float]:
    """(streamer_speed [m s-1], streamer_lifetime [s]) from :func:`space_time_correlation`."""
    lag, R, X = st.lag_t, st.peak, st.x_peak
    if lag.size < 2:
        return math.nan, math.nan
    lifetime = math.nan
    for k in range(1, lag.size):
        if R[k] < level:
            s = (R[k - 1] - level) / (R[k - 1] - R[k])
            lifetime = float(lag[k - 1] + s * (lag[k] - lag[k - 1]))
            break
    valid = np.zeros(lag.size, bool)
    for k in range(1, lag.size):         # contiguous run of lags above the level
        if R[k] < level:
            break
        valid[k] = True
    if not valid.any():
        return math.nan, lifetime
    tt, xx = lag[valid], X[valid]
    speed = float(np.sum(tt * xx) / np.sum(tt * tt))
    return speed, lifetime
