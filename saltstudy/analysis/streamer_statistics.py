"""The streamers of one case (section 4.1, Table 2, Figs. 9-10): :mod:`~.streamers`' readings
of the case's planes over the sampling window: lambda_x, lambda_y, S_c and delta_y of C_p (and of
the grains above the first cell), S_u and delta_y_u of the wind at 0.1 m, the streamers' speed
and lifetime, and R_cu_lag (C_p against the past wind: beyond eq. 12, the paper's remark in
[51]). :class:`ParcelNoise`: the parcel-count noise removed down to the paper's (streamers.py).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import correlation, paper_grid, streamers
from .reading import Frame, attr_float, check_parcel_counts
from .schema import MAX_LAG_S, U_PLANE_HEIGHT, Variables

__all__ = ["ParcelNoise", "parcel_noise", "window_planes", "concentration_readings",
           "streak_readings", "above_first_cell_readings", "space_time_readings",
           "lagged_wind_correlation", "StreamerStatistics", "streamer_statistics"]


@dataclass(frozen=True)
class ParcelNoise:
    """The Poisson parcel-count noise of C_p planes: the run's and the paper's."""
    #: grains per parcel of the run (the case's Q times the fidelity's q_multiplier)
    w_run: float
    #: grains per parcel of the paper (the case's Q)
    Q_paper: float
    #: the run's column area dx dy [m2]
    cell_area: float

    def run(self, planes) -> np.ndarray:
        """Per-plane noise variance of the run's parcels (NaN where unknown)."""
        return streamers.poisson_noise_variance(planes, self.w_run, self.cell_area)

    def to_paper(self, planes) -> np.ndarray:
        """Per-plane noise variance to remove so that the paper's remains (0 when unknown)."""
        run = self.run(planes)
        paper = streamers.poisson_noise_variance(planes, self.Q_paper, streamers.PAPER_CELL_AREA)
        out = run - paper
        return np.where(np.isfinite(out), out, 0.0)

    def definition(self) -> str:
        return (f"Poisson parcel-count noise mean(C_p) w / (dx dy) with w = {self.w_run:g} grains "
                f"per parcel, less the paper's mean(C_p) Q / {streamers.PAPER_CELL_AREA:g} m2 with "
                f"Q = {self.Q_paper:g} (saltstudy.analysis.streamers)")


def parcel_noise(fr: Frame) -> ParcelNoise:
    """The case's :class:`ParcelNoise`: the run's parcel weight is samples.nc's ``Q`` (else the
    case's Q times q_multiplier), the paper's the case's Q."""
    info = fr.info
    w_run = attr_float(fr.attrs, "Q", info["Q_case"] * info["q_multiplier"])
    Q_paper = info["Q_case"] if math.isfinite(info["Q_case"]) else w_run / info["q_multiplier"]
    return ParcelNoise(w_run, Q_paper, fr.dx * fr.dy)


def window_planes(fr: Frame, planes) -> np.ndarray | None:
    """The (time, x, y) planes of the sampling window, None when the archive has none."""
    if planes is None or planes.ndim != 3 or planes.shape[0] != fr.plane_mask.size:
        return None
    return planes[fr.plane_mask]


def _put_spacing(V: Variables, field: str, spacing: streamers.SpanwiseSpacing) -> None:
    # Table 2 reads the premultiplied spectrum (docs/STREAMERS.md); the other readings stay
    # beside it so that what the choice does to each case can be seen
    V.put(field, (), spacing.chosen, reading="premultiplied",
          definition="saltstudy.analysis.streamers.premultiplied_peak; docs/STREAMERS.md")
    for reading, func in (("premultiplied", "premultiplied_peak"), ("density", "spectral_peak"),
                          ("correlation", "correlation_minimum")):
        V.put(f"{field}_{reading}", (), getattr(spacing, reading),
              definition=f"saltstudy.analysis.streamers.{func}")


def _lambdas(fr: Frame, planes: np.ndarray, noise: np.ndarray | None
             ) -> tuple[np.ndarray, float, float]:
    """(autocorrelation, lambda_x, lambda_y) of the planes with the per-plane ``noise`` removed."""
    ac = streamers.autocorrelation_2d(planes, noise=noise)
    return (ac, streamers.core_length(ac[:, fr.ny // 2], fr.dx),
            streamers.core_length(ac[fr.nx // 2, :], fr.dy))


def concentration_readings(fr: Frame, C_w: np.ndarray | None, noise: ParcelNoise
                           ) -> tuple[np.ndarray, np.ndarray, Variables]:
    """(ky [cycles m-1] of S_c, the per-plane noise variance removed to leave the paper's,
    variables): lambda_x, lambda_y, S_c and delta_y of the window's C_p planes ``C_w`` (section
    4.1 [46], [49]), with the noise readings beside them (module docstring)."""
    nx, ny = fr.nx, fr.ny
    n_planes = int(C_w.shape[0]) if C_w is not None else 0
    area = noise.cell_area
    removed = np.zeros(n_planes)
    n_col = n_col_paper = small_ratio = noise_frac = math.nan
    ac = snap_c = np.full((nx, ny), np.nan)
    lams = dict.fromkeys(("", "_raw", "_noise_free", "_paper_count"), (math.nan, math.nan))
    spacing_c = streamers.SpanwiseSpacing(math.nan, math.nan, math.nan)
    ky = np.arange(ny // 2 + 1) / fr.Ly if ny else np.zeros(0)
    S_c = S_c_se = np.full(ky.size, np.nan)
    if C_w is not None and n_planes and nx >= 2 and ny >= 2:
        dev_c, var_c = streamers.deviation_planes(C_w)
        noise_run = noise.run(C_w)
        noise_run = np.where(np.isfinite(noise_run), noise_run, 0.0)
        has = var_c > 0
        noise_frac = float(np.mean(noise_run[has] / var_c[has])) if has.any() else math.nan
        removed = noise.to_paper(C_w)
        n_col = float(np.mean(streamers.parcels_per_cell(C_w, noise.w_run, area)))
        n_col_paper = float(np.mean(streamers.parcels_per_cell(C_w, noise.Q_paper,
                                                               streamers.PAPER_CELL_AREA)))
        check_parcel_counts(C_w, noise.w_run, area)
        poisson = noise_run[has]
        if has.any() and np.all(poisson > 0):
            small_ratio = float(np.mean(streamers.small_scale_power(dev_c[has]) / poisson))
        del dev_c
        # S_c carries the paper's parcel noise; each reading's error is the run's own
        ky, S_c, S_c_se, spacing_c = streamers.spanwise_spacing(C_w, fr.dy, noise=removed)
        # the paper's field held its own count of parcels (2,000 per m2 at Q, [28]), not the
        # run's: with that relative noise the reading sees a field as noisy as the paper's
        at_count = noise_run - streamers.count_noise_variance(
            C_w, paper_grid.PAPER_PARCELS_PER_M2, streamers.PAPER_CELL_AREA)
        for suffix, taken_out in (("", removed), ("_raw", None), ("_noise_free", noise_run),
                                  ("_paper_count", at_count)):
            ac_k, *lams[suffix] = _lambdas(fr, C_w, taken_out)
            ac = ac_k if not suffix else ac
        snap_c = np.asarray(C_w[-1], dtype=np.float64)
    noise_def = noise.definition()
    V = Variables()
    for i, name in enumerate(("lambda_x", "lambda_y")):
        V.put(name, (), lams[""][i],
              definition="2 x lag where the autocorrelation of C_p drops below 0.4",
              noise_removed=noise_def)
    _put_spacing(V, "delta_y", spacing_c)
    for suffix in ("_raw", "_noise_free", "_paper_count"):
        V.put(f"lambda_x{suffix}", (), lams[suffix][0])
        V.put(f"lambda_y{suffix}", (), lams[suffix][1])
    V.put("C_p_noise_fraction", (), noise_frac,
          definition="saltstudy.analysis.streamers.poisson_noise_variance")
    V.put("C_p_parcels_per_column", (), n_col, definition="mean(C_p) dx dy / w")
    V.put("C_p_parcels_per_column_paper", (), n_col_paper, definition="mean(C_p) 0.01 m2 / Q")
    V.put("C_p_small_scale_over_poisson", (), small_ratio,
          definition="saltstudy.analysis.streamers.small_scale_power over poisson_noise_variance")
    V.put("C_p_autocorr", ("lag_x", "lag_y"), ac)
    V.put("S_c", ("ky",), S_c)
    V.put("S_c_stderr", ("ky",), S_c_se)
    V.put("C_p_snapshot", ("x", "y"), snap_c)
    return ky, removed, V


def _u_plane(fr: Frame, s: dict):
    """The archive's u planes (time, x, y, z_plane) if they fit the plane times, else None."""
    u_pl = s.get("u_plane")
    ok = u_pl is not None and u_pl.ndim == 4 and u_pl.shape[0] == fr.plane_mask.size
    return u_pl if ok else None


def streak_readings(fr: Frame, s: dict, n_ky: int) -> Variables:
    """S_u and delta_y_u of the wind at the plane nearest 0.1 m over the window, and its last
    plane (Figs. 9b, 10b); ``n_ky`` the length of S_c's wavenumber axis, which S_u shares."""
    nx, ny = fr.nx, fr.ny
    z_plane = fr.z_plane
    k_up = int(np.argmin(np.abs(z_plane - U_PLANE_HEIGHT))) if z_plane.size else -1
    u_pl = _u_plane(fr, s)
    U_w = u_pl[:, :, :, k_up][fr.plane_mask] if u_pl is not None and k_up >= 0 else None
    if U_w is not None and U_w.shape[0] and ny >= 2:
        _, S_u, S_u_se, spacing_u = streamers.spanwise_spacing(U_w, fr.dy)
        snap_u = np.asarray(U_w[-1], dtype=np.float64)
    else:
        S_u = S_u_se = np.full(n_ky, np.nan)
        spacing_u = streamers.SpanwiseSpacing(math.nan, math.nan, math.nan)
        snap_u = np.full((nx, ny), np.nan)
    V = Variables()
    _put_spacing(V, "delta_y_u", spacing_u)
    V.put("S_u", ("ky",), S_u)
    V.put("S_u_stderr", ("ky",), S_u_se)
    V.put("u_snapshot", ("x", "y"), snap_u,
          z_plane=float(z_plane[k_up]) if k_up >= 0 else math.nan)
    return V


def above_first_cell_readings(fr: Frame, s: dict, noise: ParcelNoise) -> Variables:
    """lambda_x, lambda_y and delta_y of the grains above the first cell (z >= z_f[1]), with the
    same noise removal as C_p's."""
    nx, ny = fr.nx, fr.ny
    Ca_w = window_planes(fr, s.get("C_p_above"))
    lam_xa = lam_ya = dya = math.nan
    if Ca_w is not None and Ca_w.shape[0] and nx >= 2 and ny >= 2 and np.any(Ca_w > 0):
        rem_a = noise.to_paper(Ca_w)
        _, lam_xa, lam_ya = _lambdas(fr, Ca_w, rem_a)
        dya = streamers.spanwise_spacing(Ca_w, fr.dy, noise=rem_a)[3].chosen
    V = Variables()
    for name, val in (("lambda_x_above_first_cell", lam_xa), ("lambda_y_above_first_cell", lam_ya),
                      ("delta_y_above_first_cell", dya)):
        V.put(name, (), val, definition=f"{name.split('_above')[0]} of C_p_above (the grains above "
              "the first grid cell), the same noise removal")
    return V


def space_time_readings(fr: Frame, C_w: np.ndarray | None) -> tuple[np.ndarray, Variables]:
    """(the lags [s], variables): the peak of the space-time correlation of C_p over lags 0 to
    ``MAX_LAG_S`` at the planes' spacing, and the streamers' speed and lifetime from it."""
    nx, ny = fr.nx, fr.ny
    tp_w = fr.t_plane[fr.plane_mask] if fr.t_plane.size else fr.t_plane
    dtp = float(np.median(np.diff(tp_w))) if tp_w.size >= 2 else math.nan
    K = int(min(tp_w.size - 1, math.floor(MAX_LAG_S / dtp + 1e-9))) if math.isfinite(dtp) and dtp > 0 else 0
    lag_t = np.arange(K + 1) * (dtp if math.isfinite(dtp) else 0.0)
    st_peak, st_x, st_y = (np.full(K + 1, np.nan) for _ in range(3))
    speed = lifetime = math.nan
    if C_w is not None and K >= 1 and nx >= 2 and ny >= 2:
        st = streamers.space_time_correlation(C_w, dtp, fr.dx, fr.dy, max_lag_s=K * dtp + 0.5 * dtp)
        n = st.lag_t.size
        st_peak[:n], st_x[:n], st_y[:n] = st.peak, st.x_peak, st.y_peak
        speed, lifetime = streamers.speed_and_lifetime(st)
    V = Variables()
    V.put("C_p_st_peak", ("lag_t",), st_peak)
    V.put("C_p_st_x", ("lag_t",), st_x)
    V.put("C_p_st_y", ("lag_t",), st_y)
    V.put("streamer_speed", (), speed)
    V.put("streamer_lifetime", (), lifetime)
    return lag_t, V


def lagged_wind_correlation(fr: Frame, s: dict, C_w: np.ndarray | None, n_lags: int,
                            removed: np.ndarray) -> Variables:
    """R_cu_lag (``n_lags`` lags, one column per plane height), with the mean of the per-plane
    noise ``removed`` taken out of C_p's variance."""
    z_plane = fr.z_plane
    R_lag = np.full((n_lags, z_plane.size), np.nan)
    u_pl = _u_plane(fr, s)
    if C_w is not None and u_pl is not None:
        noise_w = float(removed.mean()) if removed.size else 0.0
        for j in range(z_plane.size):     # one plane height at a time (memory)
            R_lag[:, j] = correlation.lagged_correlation(
                C_w, u_pl[:, :, :, j][fr.plane_mask][..., None], n_lags - 1, noise=noise_w)[:, 0]
    V = Variables()
    V.put("R_cu_lag", ("lag_t", "z_plane"), R_lag)
    return V


@dataclass(frozen=True, eq=False)
class StreamerStatistics:
    ky: np.ndarray
    lag_t: np.ndarray
    noise: ParcelNoise
    variables: Variables


def streamer_statistics(fr: Frame, s: dict) -> StreamerStatistics:
    """Every streamer statistic of the case (module docstring), in order."""
    noise = parcel_noise(fr)
    C_w = window_planes(fr, s.get("C_p"))
    V = Variables()
    V.put("n_planes", (), int(C_w.shape[0]) if C_w is not None else 0)
    V.put("n_samples", (), fr.n_t)
    ky, removed, conc = concentration_readings(fr, C_w, noise)
    V.merge(conc)
    V.merge(streak_readings(fr, s, ky.size))
    V.merge(above_first_cell_readings(fr, s, noise))
    lag_t, st = space_time_readings(fr, C_w)
    V.merge(st)
    V.merge(lagged_wind_correlation(fr, s, C_w, lag_t.size, removed))
    return StreamerStatistics(ky, lag_t, noise, V)
