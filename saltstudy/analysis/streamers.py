"""Aeolian streamers from the C_p planes: lambda_x, lambda_y, delta_y, lifetime and speed.

``C_p(x, y)`` is the vertically integrated, Q-weighted grain count per unit bed area [m-2]
(paper section 4.1, Fig. 9a), recorded every ``plane_interval`` seconds. All fields are periodic
in x and y, so every correlation and spectrum here is computed with FFTs on the full periodic
domain (no windowing, no padding). Each plane is reduced to its deviation from its own spatial
mean before correlating: the statistics describe the spatial pattern, not the drift of the
domain mean.

Parcel-count noise (beyond the paper)
    C_p counts parcels that each stand for Q grains, so every plane carries a spatially white
    noise from the parcel count per column on top of the concentration pattern: its variance is
    ~ Q mean(C_p) / (dx dy) for independent parcels, more when parcels cluster (ejecta leave an
    impact together). At Q x 16 and 5-10 parcels per column it is 24-76 % of the C_p variance,
    and it decides where the autocorrelation first drops (a spike at zero lag) and how far a
    spanwise peak stands out of the floor. :func:`white_noise_variance` measures it per plane as
    the mean 2-D periodogram over the modes whose wavelengths are shorter than ``1/NOISE_K``
    = 4 cells in *both* directions (a pattern the LES resolves has next to no power there: 2nd-
    order advection damps anything under ~4 cells; in the reduced study this level is flat, 1.5-
    1.7x the independent-parcel value, and the same whatever the cut-off between 1/4 and 0.45
    cycles per cell). Given a per-plane noise variance to remove (``noise``), the autocorrelation
    is normalised by the plane variance minus it (zero lag stays 1) and the spanwise spectrum has
    its flat floor subtracted.

    The noise variance scales with the parcel weight, so a run at ``q_multiplier`` x the case's Q
    carries q_multiplier x the noise of a run at the case's Q. lambda_x, lambda_y and delta_y are
    computed with the fraction ``1 - 1/q_multiplier`` of it removed: the statistic the same flow would give at the
    case's (the paper's) Q, noise and all, which makes Q a pure cost knob for them (nothing is
    removed at q_multiplier 1). The raw values are kept beside them. The wind planes are never
    touched: their small scales are the flow's.

lambda_x, lambda_y (section 4.1 [46], Table 2)
    "estimated from time-average spatial autocorrelation of C_p in the horizontal section. We
    defined the core of the streamer as the region where the autocorrelation is higher than 0.4".
    :func:`autocorrelation_2d` averages the normalised autocorrelation of each plane (equal
    weight per plane; planes with zero variance, e.g. without grains, are skipped).
    :func:`core_length` reads the extent of the > 0.4 region through the origin along one axis:
    twice the first lag at which the correlation drops below 0.4 (linear interpolation between
    the bracketing lags). NaN if it stays above 0.4 up to half the domain (the core then spans
    the periodic domain and has no measurable length).

delta_y (section 4.1 [46], Fig. 10)
    "The two-dimensional Fourier transform of C_p averaged in time and over longitudinal
    wavelengths shows a well-defined maximum ... corresponding to the mean lateral spacing
    delta_y between streamers". By Parseval in x, the 2-D power spectrum averaged over kx equals
    the 1-D spanwise spectrum averaged over x rows; :func:`spanwise_spectrum` returns it as a
    one-sided density in ky (cycles m-1; ``sum S dky`` = variance) with a standard error from
    contiguous time blocks. ``delta_y = 1/ky_peak`` with the peak found by :func:`spectral_peak`:

    * candidates are interior local maxima (``2 <= m < M``: not the domain-scale mode m = 1,
      whose "spacing" is the domain width, and not the Nyquist mode) at wavelengths of at least
      ``MIN_PEAK_CELLS`` = 4 cells (ky at most half the Nyquist wavenumber): shorter ones are not
      resolved by the 2nd-order LES, and that is where the parcel-count noise lives;
    * each candidate's *base* is the higher of the two valley floors that separate it from a
      higher point (or from the ends of the spectrum) on its left and its right (topographic
      prominence);
    * it counts as a peak if ``S_peak >= (1 + PEAK_REL_MARGIN) * base`` and, when a standard
      error is available, ``S_peak - base >= PEAK_N_SE * sqrt(se_peak^2 + se_base^2)``; with no
      standard error (fewer than 4 planes) the margin is ``PEAK_FALLBACK_MARGIN``;
    * of the accepted peaks the highest wins; its ky is refined by a parabola through the three
      points around it. A monotonically decaying spectrum (or one whose only maximum is the
      domain mode) has no accepted peak: ``delta_y`` is NaN.

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

__all__ = ["CORE_LEVEL", "PEAK_REL_MARGIN", "PEAK_N_SE", "PEAK_FALLBACK_MARGIN", "NOISE_K",
           "MIN_PEAK_CELLS",
           "white_noise_variance",
           "centred_lags", "autocorrelation_2d", "core_length", "spanwise_spectrum",
           "spectral_peak", "SpaceTime", "space_time_correlation", "speed_and_lifetime",
           "deviation_planes"]

CORE_LEVEL = 0.4
PEAK_REL_MARGIN = 0.10
PEAK_N_SE = 3.0
PEAK_FALLBACK_MARGIN = 0.2
N_BLOCKS = 8
#: shortest spanwise wavelength, in cells, at which a spectral peak is accepted
MIN_PEAK_CELLS = 4.0
#: white-noise modes: |kx| and |ky| both at least this many cycles per cell (wavelengths < 4 cells)
NOISE_K = 0.25


def deviation_planes(planes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(planes minus their own spatial mean, per-plane variance) for (nt, nx, ny) input."""
    p = np.asarray(planes, dtype=np.float64)
    p = np.where(np.isfinite(p), p, 0.0)
    dev = p - p.mean(axis=(1, 2), keepdims=True)
    var = (dev ** 2).mean(axis=(1, 2))
    return dev, var


def _has_variance(var: np.ndarray, dev: np.ndarray) -> np.ndarray:
    # relative to the largest plane variance: a plane of round-off noise is not a pattern
    scale = float(np.max(var)) if var.size else 0.0
    return var > max(1e-14 * scale, 1e-300)


def white_noise_variance(dev: np.ndarray) -> np.ndarray:
    """Per-plane variance of the spatially white part of (nt, nx, ny) deviation planes.

    Mean of ``|FFT2|^2 / (nx ny)`` (white noise of variance s^2 gives s^2 in every mode) over the
    modes with ``|kx|, |ky| >= NOISE_K`` cycles per cell; zeros when the grid has no such mode.
    """
    dev = np.asarray(dev, dtype=np.float64)
    nt, nx, ny = dev.shape
    kx = np.abs(np.fft.fftfreq(nx))
    ky = np.abs(np.fft.fftfreq(ny))
    corner = (kx[:, None] >= NOISE_K) & (ky[None, :] >= NOISE_K)
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

    Returned fftshift-ed: zero lag at ``[nx//2, ny//2]`` (see :func:`centred_lags`). All NaN if
    no plane has variance. ``noise`` (nt,): white-noise variance removed from each plane (see
    the module docstring); planes with no variance left over are skipped.
    """
    planes = np.asarray(planes, dtype=np.float64)
    nt, nx, ny = planes.shape
    dev, var = deviation_planes(planes)
    ok = _has_variance(var, dev)
    noise = np.zeros(nt) if noise is None else np.asarray(noise, dtype=np.float64)
    ok &= var - noise > 0
    if nt == 0 or not ok.any():
        return np.full((nx, ny), np.nan)
    acc = np.zeros((nx, ny))
    for t in np.flatnonzero(ok):
        F = np.fft.rfft2(dev[t])
        ac = np.fft.irfft2(F * np.conj(F), s=(nx, ny)) / (nx * ny)
        ac[0, 0] -= noise[t]
        acc += ac / ac[0, 0]
    acc /= ok.sum()
    return np.fft.fftshift(acc)


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


def spanwise_spectrum(planes: np.ndarray, dy: float, n_blocks: int = N_BLOCKS,
                      noise: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ky [cycles m-1], S(ky), standard error of S) of (nt, nx, ny) planes.

    One-sided density: ``sum_m S_m dky`` = mean spatial variance of the planes (dky = 1/Ly).
    Averaged over x (= over kx by Parseval) and time. The standard error comes from
    ``min(n_blocks, nt)`` contiguous time blocks (NaN with fewer than 4 planes).
    ``noise`` (nt,): each plane's white-noise variance s^2, whose floor (``s^2 dy`` per two-sided
    mode) is subtracted.
    """
    planes = np.asarray(planes, dtype=np.float64)
    nt, nx, ny = planes.shape
    Ly = ny * dy
    ky = np.arange(ny // 2 + 1) / Ly
    if nt == 0:
        return ky, np.full(ky.size, np.nan), np.full(ky.size, np.nan)
    dev, _ = deviation_planes(planes)
    F = np.fft.rfft(dev, axis=2)                     # (nt, nx, nky)
    P = (np.abs(F) ** 2).mean(axis=1) / ny ** 2      # (nt, nky): sum over ky of 2-sided = var
    w = np.full(ky.size, 2.0)
    w[0] = 1.0
    if ny % 2 == 0:
        w[-1] = 1.0
    if noise is not None:
        P = P - np.asarray(noise, dtype=np.float64)[:, None] / ny
    P = P * w * Ly                                   # density: divide by dky = 1/Ly
    S = P.mean(axis=0)
    se = np.full(ky.size, np.nan)
    nb = min(n_blocks, nt)
    if nt >= 4 and nb >= 2:
        blocks = np.array_split(np.arange(nt), nb)
        bm = np.array([P[b].mean(axis=0) for b in blocks])
        se = bm.std(axis=0, ddof=1) / math.sqrt(nb)
    return ky, S, se


def spectral_peak(ky: np.ndarray, S: np.ndarray, se: np.ndarray | None = None,
                  rel_margin: float = PEAK_REL_MARGIN, n_se: float = PEAK_N_SE,
                  fallback_margin: float = PEAK_FALLBACK_MARGIN,
                  min_cells: float = MIN_PEAK_CELLS) -> float:
    """ky of the spectral peak (criterion in the module docstring); NaN when there is none."""
    ky = np.asarray(ky, dtype=np.float64)
    S = np.asarray(S, dtype=np.float64)
    M = S.size - 1
    if M < 3 or not np.all(np.isfinite(S[1:])) or not np.any(S[1:] > 0):
        return math.nan
    have_se = se is not None and np.all(np.isfinite(np.asarray(se)[1:]))
    se = np.asarray(se, dtype=np.float64) if have_se else np.zeros_like(S)
    best_m, best_s = -1, -math.inf
    ky_resolved = 2.0 * ky[M] / min_cells          # ky[M] is (about) the Nyquist 1/(2 dy)
    for m in range(2, M):
        if ky[m] > ky_resolved * (1.0 + 1e-12):
            break
        if not (S[m] > S[m - 1] and S[m] >= S[m + 1]):
            continue
        # left valley: down to the nearest higher point (or the first non-zero mode)
        j = m - 1
        while j >= 1 and S[j] <= S[m]:
            j -= 1
        left = np.arange(j + 1, m)
        # right valley: up to the nearest higher point (or the last mode)
        j = m + 1
        while j <= M and S[j] <= S[m]:
            j += 1
        right = np.arange(m + 1, min(j, M + 1))
        kl = left[np.argmin(S[left])]
        kr = right[np.argmin(S[right])]
        kb = kl if S[kl] >= S[kr] else kr
        base = S[kb]
        if have_se:
            ok = (S[m] >= (1.0 + rel_margin) * base
                  and S[m] - base >= n_se * math.hypot(se[m], se[kb]))
        else:
            ok = S[m] >= (1.0 + fallback_margin) * base
        if ok and S[m] > best_s:
            best_m, best_s = m, S[m]
    if best_m < 0:
        return math.nan
    m = best_m
    denom = S[m - 1] - 2.0 * S[m] + S[m + 1]
    shift = 0.5 * (S[m - 1] - S[m + 1]) / denom if denom < 0 else 0.0
    shift = float(np.clip(shift, -0.5, 0.5))
    return float(ky[m] + shift * (ky[1] - ky[0]))


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
    ok = _has_variance(var, dev)
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
