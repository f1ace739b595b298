"""Aeolian streamers from the C_p planes: lambda_x, lambda_y, delta_y, lifetime and speed.

``C_p(x, y)`` is the vertically integrated, Q-weighted grain count per unit bed area [m-2]
(section 4.1, Fig. 9a), one plane every ``plane_interval`` s. The fields are periodic: every
correlation and spectrum is an FFT on the full domain of each plane's deviation from its mean.

Parcel-count noise (beyond the paper)
    A column of area ``A = dx dy`` holds ``N = C_p A / w`` parcels of ``w`` grains (samples.nc
    ``Q``), Poisson given the pattern: white noise of variance ``s^2 = mean(C_p) w / A``
    (:func:`poisson_noise_variance`), ``s^2`` in every non-zero 2-D mode; not estimated from the
    high wavenumbers, where streamers 2.5-6 cells wide put real power. The paper's estimate
    carried its own parcels' noise, ``s_paper^2 = mean(C_p) Q / A_paper`` (~20 parcels per 0.1 m
    column in case 2). **lambda_x, lambda_y, S_c and R_cu carry the paper's noise level**:
    ``s^2 - s_paper^2`` is removed from each plane, so parcel weight and column size are pure cost
    knobs. Beside them: ``*_noise_free`` (all of ``s^2`` removed), ``*_raw`` (none) and
    ``*_paper_count`` (:func:`count_noise_variance`: the paper's 2,000 parcels per m2, [28]).
    Parcels ejected together raise the variance at 2-4 cells by a factor F the counts cannot
    tell from a pattern; ``C_p_small_scale_over_poisson`` (:func:`small_scale_power` over
    ``s^2``) bounds F from above: 1.5-1.7 in the reduced study, 1.9-2.5 in the smoke study.

lambda_x, lambda_y (section 4.1 [46], Table 2)
    Twice the first lag at which the spatial autocorrelation drops below 0.4 (:func:`core_length`;
    NaN if it stays above): the autocovariance after the noise is averaged over the planes, then
    normalised (a plane's corrected variance is a small difference at ~1 parcel per column).

delta_y (section 4.1 [46], [49], Fig. 10; which reading and why: docs/STREAMERS.md)
    The spanwise spectrum with ``N_BLOCKS`` contiguous time blocks for its error
    (:func:`spanwise_spectrum_blocks`), read three ways by :func:`spanwise_spacing`. A peak is
    an interior local maximum (modes ``2 <= m < M``) standing ``PEAK_N_SE`` standard errors above
    its base, the higher of its two valley floors; the relative block variance is pooled over
    ``PEAK_POOL_MODES`` modes either side; under ``MIN_BLOCKS`` blocks a peak must stand
    ``PEAK_FALLBACK_MARGIN`` above its base. Measured on Poisson parcel counts (64 x 48 to
    64 x 150 columns, 20-300 planes, 1.25-20 parcels per column):

    * false peaks on pure noise: premultiplied 0 of 1600, density 14 of 1600 (at 4.0 standard
      errors 10 in 400), correlation 1 of 1600;
    * a lattice of streaks 2.5-6 cells apart (s.d. 11 % of the mean) found by the density in
      34 of 40 (25 of 40 at 5.0 standard errors); a faint one (3-6 cells, s.d. 5 %) by the
      density in 72 of 80, the premultiplied reading in 26 of 80, the correlation in 1 of 80.

Streamer lifetime and speed (beyond the paper; Baas and Sherman 2005, quoted in [46]: 0.5-1 s,
3.6 m s-1)
    From the peak ``R*(tau)`` over spatial lags of corr(C_p'(t), C_p'(t + tau)) at ``(X*, Y*)``
    (:func:`space_time_correlation`): ``streamer_speed`` the slope through the origin of X*
    against tau over the lags with ``R* >= 1/e``, ``streamer_lifetime`` the lag where R* first
    drops below 1/e (interpolated).
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
    ``parcels_per_m2`` parcels per m2 on columns of area ``A``: ``mean(C_p)^2 / (n A)`` (the
    paper's 2,000 per m2, [28], on 0.1 m columns: 1/20 of mean(C_p)^2)."""
    if not (parcels_per_m2 > 0 and cell_area > 0):
        return np.full(np.shape(planes)[0], np.nan)
    return _plane_means(planes) ** 2 / (parcels_per_m2 * cell_area)


def small_scale_power(dev: np.ndarray) -> np.ndarray:
    """Per-plane mean of ``|FFT2|^2 / (nx ny)`` over the modes with ``|kx|, |ky| >= SMALL_SCALE_K``
    cycles per cell (white noise of variance s^2 gives s^2 there); zeros when the grid has no
    such mode. A diagnostic of the noise beside its Poisson value, not a noise estimate."""
    dev = np.asarray(dev, dtype=np.float64)
    nt, nx, ny = dev.shape
    kx, ky = np.abs(np.fft.fftfreq(nx)), np.abs(np.fft.fftfreq(ny))
    corner = (kx[:, None] >= SMALL_SCALE_K) & (ky[None, :] >= SMALL_SCALE_K)
    if nt == 0 or not corner.any():
        return np.zeros(nt)
    return np.array([(np.abs(np.fft.fft2(dev[t])) ** 2 / (nx * ny))[corner].mean()
                     for t in range(nt)])


def centred_lags(n: int, d: float) -> np.ndarray:
    """Lags of a fftshift-ed periodic correlation: ``(i - n//2) d`` for i = 0..n-1."""
    return (np.arange(n) - n // 2) * d


def autocorrelation_2d(planes: np.ndarray, noise: np.ndarray | None = None) -> np.ndarray:
    """Time-averaged normalised periodic autocorrelation of (nt, nx, ny) planes, fftshift-ed
    (zero lag at ``[nx//2, ny//2]``, :func:`centred_lags`). ``noise`` (nt,): white-noise variance
    removed from every non-zero Fourier mode of each plane. All NaN if no plane has variance or
    none is left after the noise."""
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
    planes: the one-sided density (``sum_m S_m dky`` = mean spatial variance, dky = 1/Ly),
    averaged over x and time. The blocks are ``min(n_blocks, nt)`` contiguous runs of planes;
    the error is their standard deviation over sqrt(nb) (NaN, and no blocks, under 4 planes).
    ``noise`` (nt,): each plane's white-noise variance s^2, whose floor is subtracted (``s^2/ny``
    per two-sided mode, ``(1 - 1/nx) s^2/ny`` at ky = 0: the rows' means are deviations)."""
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
    its topographic base (module docstring); -1 when none does. The error of ``F`` at mode i is
    ``sqrt(r2) scale[i]``, r2 the mean of ``rel2`` over ``pool`` modes on either side. With
    ``both_valleys`` the peak must stand out of both valley floors (where ``scale`` varies the
    higher floor need not be the one it stands least out of). Without ``rel2``: a relative
    ``fallback_margin`` above the base."""
    M = F.size - 1
    best_m, best_f = -1, -math.inf
    for m in range(2, M):
        if not (F[m] > F[m - 1] and F[m] >= F[m + 1]):
            continue
        kl, kr = _valley_floors(F, m)
        kb = kl if F[kl] >= F[kr] else kr        # the higher floor: topographic prominence
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
    ky, S = (np.asarray(v, dtype=np.float64) for v in (ky, S))
    M = S.size - 1
    if M < 3 or not np.all(np.isfinite(S[1:])) or not np.any(S[1:] > 0):
        return math.nan
    m = _prominent_maximum(S, S, _relative_block_variance(S, blocks), n_se, pool,
                           fallback_margin)
    if m < 0:
        return math.nan
    return float(ky[m] + _parabolic(S[m - 1], S[m], S[m + 1]) * (ky[1] - ky[0]))


def premultiplied_peak(ky: np.ndarray, S: np.ndarray, blocks: np.ndarray | None = None,
                       S_raw: np.ndarray | None = None, nyquist_half_bin: bool = False,
                       n_se: float = PEAK_N_SE, pool: int = PEAK_POOL_MODES,
                       fallback_margin: float = PEAK_FALLBACK_MARGIN) -> float:
    """ky [cycles m-1] of the peak of ``ky S(ky)`` on a logarithmic wavelength axis (Table 2's
    delta_y, docs/STREAMERS.md); NaN when there is none (a flat k^-1 density, or a spectrum
    rising or falling to either end).

    ``S`` [variance m]: the density to read. ``blocks`` (nb, nky) and ``S_raw`` (default ``S``):
    the block spectra with all the record's noise in and their mean; the error of ``ky S`` is
    ``ky`` times that of ``S_raw``. ``nyquist_half_bin``: the last mode is the Nyquist mode of an
    even number of cells, which holds the density of half a bin; it is doubled to a point
    density, else a spectrum rising to it (white noise) would show a false peak one mode before."""
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
    ky, S = (np.asarray(v, dtype=np.float64) for v in (ky, S))
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
    sampling noise (the correlation reading of delta_y is twice it); NaN when there is none.

    A local minimum at lag j (0 < j < ny//2: every periodic correlation is stationary at the
    half-domain lag) counts if the correlation rises from it again, before ny//2, by ``n_se``
    standard errors of the difference (the blocks' standard deviation over sqrt(nb), squared
    and pooled over ``pool`` lags on either side; with fewer than ``MIN_BLOCKS`` blocks a rise of
    ``fallback_rise`` in correlation units). It need not be negative: a red background lifts the
    whole correlation without moving the alternation. Refined by a parabola."""
    ky, S = (np.asarray(v, dtype=np.float64) for v in (ky, S))
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

    ``S``: the spanwise density with ``noise`` (nt,) removed (for C_p, the run's parcel noise
    less the paper's), on which the premultiplied peak and the correlation minimum (white noise
    touches only its zero lag) are read; the density peak is read on the raw spectrum (a flat
    floor moves neither the peak nor its prominence). Every error is the raw record's."""
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
    below = np.flatnonzero(R[1:] < level)
    k = int(below[0]) + 1 if below.size else lag.size     # the first lag below the level
    lifetime = math.nan
    if below.size:
        s = (R[k - 1] - level) / (R[k - 1] - R[k])
        lifetime = float(lag[k - 1] + s * (lag[k] - lag[k - 1]))
    if k < 2:
        return math.nan, lifetime
    tt, xx = lag[1:k], X[1:k]           # the contiguous run of lags above the level
    return float(np.sum(tt * xx) / np.sum(tt * tt)), lifetime
