"""One case: ``samples.nc`` (+ ``spinup.nc``) -> ``analysis.nc`` (schema in docs/ARCHITECTURE.md).

:func:`analyse_case` is what the workflow task and ``saltstudy analyse`` call. It reads only the
archives (no solver), computes every statistic with the functions of this package's modules
(whose docstrings define each one, with the paper's section and equation), and writes the
result atomically through :mod:`saltstudy.ncio`. Degenerate input (no grains, one sample, tiny
grids, missing optional variables) gives NaN, never an exception.

Order of the coupled definitions:

1. ``u*`` from the stress at ``z_ref_eff = min(forcing.z_ref, (Lz - damping)/2)``
   (``u_star_s_stress``), used as the first guess of ``u*s``;
2. ``z_m`` from tau_p with that ``u*``; the log-law fit over ``[max(0.3 m, z_m), (Lz-damping)/2]``
   gives ``u_star_s, z0s``; ``z_m`` is recomputed with the fitted ``u_star_s`` and the fit
   repeated once if its lower bound moved (the fit falls back to the stress u* for z_m when it
   is undefined);
3. ``tau_p`` at the bed from the exponential fitted to the layers below ``0.25 z_m``, over
   ``rho u*^2`` with the stress ``u*`` of step 1 (``tau_p_surface_fraction``, flux module).

C_p statistics carry the paper's parcel-count noise: the run's Poisson noise less the paper's is
removed (streamers module).
"""
from __future__ import annotations

import logging
import math
import time as _time
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..ncio import write_dataset
from . import balance, correlation, flux, layer, paper_grid, profiles, series, sizes, stokes, streamers
from ..physics import laws
from .reading import LAZY_VARIABLES, PLANE_CHUNK, LazyVar as _LazyVar, Rows as _Rows
from .reading import attr_float as _f, case_info as _case_info, read_archive as _read
from .reading import check_parcel_counts as _check_parcel_counts, rescale_spinup_profiles
from .reading import time_mean as _tmean, time_sum as _tsum
from .schema import (HALF_STATISTICS, MAX_LAG_S, REQUIRED_COORDS, REQUIRED_VARIABLES,
                     SAMPLE_VARIABLES_USED, SPEC, U_PLANE_HEIGHT)

__all__ = ["analyse_case", "analyse_datasets", "half_window_statistics", "HALF_STATISTICS", "SPEC",
           "REQUIRED_VARIABLES", "REQUIRED_COORDS", "MAX_LAG_S", "U_PLANE_HEIGHT",
           "SAMPLE_VARIABLES_USED", "rescale_spinup_profiles"]

log = logging.getLogger(__name__)


def _u_star_t(info: dict[str, Any], rho: float, rho_p: float, g: float) -> float:
    soil = info.get("soil") or {}
    modes = soil.get("modes") or [{}]
    d_mean = sum(float(m.get("mass_fraction", 1.0)) * float(m.get("mu", 2e-4)) for m in modes)
    th = info.get("threshold") or {}
    try:
        from ..physics.threshold import threshold_friction_velocity  # another engineer's module
    except ImportError:
        log.warning("saltstudy.physics.threshold missing: u_star_t is NaN")
        return math.nan
    try:
        return float(threshold_friction_velocity(d_mean, rho_p, rho, g, float(th.get("A_N", 0.0123)),
                                                 float(th.get("gamma", 3.0e-4))))
    except Exception as exc:  # noqa: BLE001 - a scalar for the report, never fatal
        log.warning("u_star_t failed: %s", exc)
        return math.nan


# ------------------------------------------------------------------------------------------
# the analysis
# ------------------------------------------------------------------------------------------
def analyse_case(samples_path: str | Path, spinup_path: str | Path | None, out_path: str | Path,
                 wall_time_s: float | None = None) -> Path:
    """Analyse one case's archives into ``out_path`` (analysis.nc). Returns ``out_path``.

    ``spinup_path`` may be None or missing: the spin-up variables are then NaN.
    ``wall_time_s`` (the sum of the case's solver tasks) overrides the samples' attribute.
    """
    t_start = _time.perf_counter()
    s_attrs, s_coords, s = _read(samples_path, SAMPLE_VARIABLES_USED, LAZY_VARIABLES)
    if spinup_path is not None and Path(spinup_path).is_file():
        sp_attrs, sp_coords, sp = _read(spinup_path, ("u_mean", "uw_res", "uw_sgs", "tke_res", "e_sgs"))
        sp = rescale_spinup_profiles(sp, _f(s_attrs, "u_star_target") / _f(sp_attrs, "u_star_target"))
    else:
        sp_attrs, sp_coords, sp = {}, {}, {}
    ds = analyse_datasets(s_attrs, s_coords, s, sp_coords, sp)
    for name, vals in half_window_statistics(s_attrs, s_coords, s, sp_coords, sp).items():
        units = ds[name].attrs.get("units", SPEC.get(name, ("1", ""))[0])
        ds[f"{name}_halves"] = xr.DataArray(
            vals, dims=("half",), attrs={"units": units, "long_name": f"{name} over the first and "
                                         "the second half of the sampling window (its 3-D samples "
                                         "split in two; planes and series with them)"})
    attrs = {k: v for k, v in s_attrs.items() if k != "saltstudy_complete"}
    wt = wall_time_s if wall_time_s is not None else _f(s_attrs, "wall_time_s")
    attrs["wall_time_s"] = float(wt)
    attrs["samples_path"] = str(samples_path)
    attrs["spinup_path"] = str(spinup_path) if spinup_path is not None else ""
    if "converged" in sp_attrs:
        attrs["spinup_converged"] = int(bool(sp_attrs["converged"]))
    from .. import __version__
    attrs["analysis_version"] = __version__
    attrs["analysis_seconds"] = float(_time.perf_counter() - t_start)
    ds.attrs = attrs
    return write_dataset(ds, out_path)




#: samples.nc variables along the planes' time axis, along the series' and whole (not in time);
#: the others run along the 3-D samples' time axis
_PLANE_VARIABLES = ("C_p", "G_col", "u_plane")
_SERIES_VARIABLES = ("n_parcels", "G_tot_series", "u_star_ref", "E_impact", "E_splash")
_WHOLE_VARIABLES = ("d_edges",)


def half_window_statistics(attrs: dict[str, Any], coords: dict[str, np.ndarray], s: dict[str, Any],
                           sp_coords: dict[str, np.ndarray], sp: dict[str, Any]) -> dict[str, np.ndarray]:
    """HALF_STATISTICS over the first and the second half of the 3-D samples ({} if < 4 samples).

    The first half takes samples [0, h) and the planes before sample h; the second the rest; the
    series stay whole (the window statistics read them between the half's first and last sample).
    """
    t_s = np.asarray(coords.get("time", np.zeros(0)), dtype=np.float64)
    if t_s.size < 4:
        return {}
    h = t_s.size // 2
    t_p = np.asarray(coords.get("time_plane", np.zeros(0)), dtype=np.float64)
    split = float(t_s[h]) - 1e-9
    out: dict[str, list[float]] = {k: [] for k in HALF_STATISTICS}
    for (a, b) in ((0, h), (h, t_s.size)):
        pa, pb = ((0, int(np.searchsorted(t_p, split))) if a == 0
                  else (int(np.searchsorted(t_p, split)), t_p.size))
        c = dict(coords)
        c["time"] = t_s[a:b]
        c["time_plane"] = t_p[pa:pb]
        sub: dict[str, Any] = {}
        for name, v in s.items():
            if v is None or name in _SERIES_VARIABLES or name in _WHOLE_VARIABLES:
                sub[name] = v
            elif name in _PLANE_VARIABLES:
                sub[name] = v[pa:pb] if isinstance(v, np.ndarray) else _Rows(v, pa, pb)
            else:
                sub[name] = v[a:b] if isinstance(v, np.ndarray) else _Rows(v, a, b)
        try:
            ds = analyse_datasets(attrs, c, sub, sp_coords, sp)
        except Exception as exc:  # noqa: BLE001 — a half too short for a statistic: NaN, not a crash
            log.warning("half-window analysis failed: %s", exc)
            ds = None
        for k in HALF_STATISTICS:
            val = math.nan
            if ds is not None and k in ds.variables and ds[k].ndim == 0:
                val = float(ds[k].values)
            out[k].append(val)
    return {k: np.asarray(v, dtype=np.float64) for k, v in out.items()}


def analyse_datasets(attrs: dict[str, Any], coords: dict[str, np.ndarray], s: dict[str, Any],
                     sp_coords: dict[str, np.ndarray], sp: dict[str, Any]) -> xr.Dataset:
    """The analysis on arrays already in memory (see :func:`analyse_case`)."""
    V: dict[str, tuple[tuple[str, ...], Any, dict[str, Any]]] = {}

    def put(name: str, dims: tuple[str, ...], data, **extra) -> None:
        V[name] = (dims, np.asarray(data, dtype=np.float64), extra)

    info = _case_info(attrs)
    rho = _f(attrs, "rho", 1.2)
    rho_p = _f(attrs, "rho_p", 2650.0)
    nu = _f(attrs, "nu", 1.5e-5)
    g = _f(attrs, "g", 9.81)
    kappa = _f(attrs, "kappa", 0.40)
    z = np.asarray(coords["z"], dtype=np.float64)
    z_w = np.asarray(coords.get("z_w", np.zeros(0)), dtype=np.float64)
    if z_w.size != z.size + 1:  # reconstruct faces from centres: z_w[k+1] = 2 z[k] - z_w[k]
        z_w = np.zeros(z.size + 1)
        for k in range(z.size):
            z_w[k + 1] = 2.0 * z[k] - z_w[k]
    dz = np.diff(z_w)
    nz = z.size
    x = np.asarray(coords.get("x", np.zeros(0)), dtype=np.float64)
    y = np.asarray(coords.get("y", np.zeros(0)), dtype=np.float64)
    nx, ny = x.size, y.size
    dx = _f(attrs, "dx", float(x[1] - x[0]) if nx > 1 else math.nan)
    dy = _f(attrs, "dy", float(y[1] - y[0]) if ny > 1 else math.nan)
    Lx = _f(attrs, "Lx", nx * dx)
    Ly = _f(attrs, "Ly", ny * dy)
    Lz = info["Lz"] if math.isfinite(info["Lz"]) else float(z_w[-1])
    t_sample = np.asarray(coords.get("time", np.zeros(0)), dtype=np.float64)
    t_series = np.asarray(coords.get("time_series", np.zeros(0)), dtype=np.float64)
    t_plane = np.asarray(coords.get("time_plane", np.zeros(0)), dtype=np.float64)
    z_plane = np.asarray(coords.get("z_plane", np.zeros(0)), dtype=np.float64)
    d_bin = np.asarray(coords.get("d_bin", np.zeros(0)), dtype=np.float64)
    n_t = t_sample.size

    def get(name):
        a = s.get(name)
        return a if a is None or isinstance(a, (_LazyVar, _Rows)) else np.asarray(a)

    # sampling window: from the first to the last 3-D sample; one sample -> to the end of the run
    if n_t:
        t0 = float(t_sample[0])
        t1 = float(t_sample[-1])
        if t1 <= t0:
            t1 = float(max(t_series.max() if t_series.size else t0,
                           t_plane.max() if t_plane.size else t0))
    else:
        t0, t1 = (float(t_series[0]) if t_series.size else 0.0), (
            float(t_series[-1]) if t_series.size else 0.0)

    # ---------------- profiles (section 3.1) ----------------
    u_mean = _tmean(get("u_mean"), nz)
    uw_w = None
    if get("uw_res") is not None and get("uw_sgs") is not None:
        uw_w = get("uw_res").astype(np.float64) + get("uw_sgs").astype(np.float64)
    uw_flux = profiles.faces_to_centres(_tmean(uw_w, nz + 1))
    uw_sgs_c = profiles.faces_to_centres(_tmean(get("uw_sgs"), nz + 1))
    tke_res = _tmean(get("tke_res"), nz)
    e_sgs = _tmean(get("e_sgs"), nz)
    tke = tke_res + e_sgs

    H = info["H"]
    z_ref_eff = _f(attrs, "z_ref_eff", min(info["z_ref"], 0.5 * (Lz - info["damping_depth"])))

    def rng_fit(zm):
        return profiles.fit_range(zm, Lz, info["damping_depth"], drive=info["drive"])

    u_star_stress = profiles.stress_u_star(z_w, _tmean(uw_w, nz + 1), z_ref_eff)

    # ---------------- tau_p, z_m, log fit (sections 3.1, 3.2) ----------------
    pm, pmu, pmw, pmuw = (get(k) for k in ("pm", "pmu", "pmw", "pmuw"))
    if pm is not None and pm.ndim == 2 and pm.shape[0] > 0:
        tau_p = flux.tau_p_profile(pm, pmu, pmw, pmuw, dz, Lx, Ly)
        G = flux.mass_flux_profile(pmu, dz, Lx, Ly)
        G_tot_sample = np.nansum(np.asarray(pmu, dtype=np.float64), axis=1) / (Lx * Ly)
        airborne_mass = float(np.mean(np.nansum(np.asarray(pm, dtype=np.float64), axis=1))) / (Lx * Ly)
    else:
        tau_p = np.full(nz, np.nan)
        G = np.full(nz, np.nan)
        G_tot_sample = np.full(n_t, np.nan)
        airborne_mass = math.nan

    # the surface value of the stress u*: the linear stress of the pressure-gradient drive is
    # u*_0^2 (1 - z/H) at z_ref
    u0_stress = u_star_stress / math.sqrt(1.0 - z_ref_eff / H) if H else u_star_stress
    # z_m against the flow's momentum flux above the layer, rho u*s^2 with the u*s read the
    # paper's way (the total stress at the reference height, its [33]), the u*s that leads Table 2
    z_m = flux.z_m_from_tau(z, tau_p, rho, u0_stress)
    fit = profiles.log_law_fit(z, u_mean, *rng_fit(z_m), kappa, H=H)
    u_star_s = fit.u_star
    # z0s with u* fixed at the stress value (the paper's u* at the reference height)
    z0s_stress = laws.z0_at_fixed_u_star(z, u_mean, u0_stress, kappa, fit.z_min, fit.z_max, H)

    put("u_star_s", (), u_star_s, fit_range=f"[{fit.z_min:g}, {fit.z_max:g}] m, {fit.n_points} levels")
    put("z0s", (), fit.z0)
    put("u_star_s_stress", (), u_star_stress)
    put("z0s_stress", (), z0s_stress)
    put("z_ref_eff", (), z_ref_eff)
    put("fit_r2", (), fit.r2)
    put("fit_n", (), fit.n_points)
    put("fit_z_min", (), fit.z_min)
    put("fit_z_max", (), fit.z_max)
    # the sampling error of u*s, from the scatter of the same fit on each sample's profile: large
    # eddies (turnover H/u* ~ 4-11 s) make single samples scatter by 5-15 %
    u_prof = get("u_mean")
    u_star_i = np.full(n_t, np.nan)
    if u_prof is not None and u_prof.ndim == 2 and u_prof.shape[0] == n_t:
        u_star_i = np.array([profiles.log_law_fit(z, row, fit.z_min, fit.z_max, kappa, H=H).u_star
                             for row in np.asarray(u_prof, dtype=np.float64)])
    ok_i = u_star_i[np.isfinite(u_star_i)]
    put("u_star_s_samples", ("time_sample",), u_star_i)
    put("u_star_s_se", (), float(np.std(ok_i, ddof=1) / math.sqrt(ok_i.size)) if ok_i.size >= 2
        else math.nan)
    put("z_m", (), z_m, definition="tau_p first below 0.1 % of rho u_star_s_stress^2 (log "
        "interpolation)")
    # tau_p at the bed over the total stress at the reference height (flux module doc)
    bed = flux.bed_value(z_w, tau_p, flux.BED_FIT_FRACTION * z_m)
    rho_u2_stress = rho * u0_stress ** 2 if math.isfinite(u0_stress) else math.nan
    put("tau_p_bed", (), bed.value, layers_fitted=bed.n_layers)
    put("tau_p_bed_decay_height", (), bed.height)
    ok_norm = rho_u2_stress > 0
    put("tau_p_surface_fraction", (), bed.value / rho_u2_stress if ok_norm else math.nan,
        definition="tau_p_bed / (rho u_star_s_stress^2) (saltstudy.analysis.flux)")
    put("tau_p_paper_cell_fraction", (), bed.layer_mean(paper_grid.PAPER_FIRST_LAYER) / rho_u2_stress
        if ok_norm else math.nan)
    uw_mean_w = _tmean(uw_w, nz + 1)
    put("tau_p_surface_fraction_budget", (), flux.budget_bed_fraction(
        float(uw_mean_w[0]), -u0_stress ** 2) if uw_mean_w.size == nz + 1 else math.nan)
    # the momentum balance at the bed from the air's side (analysis/balance.py)
    uw_bed_i = (np.asarray(uw_w, dtype=np.float64)[:, 0]
                if uw_w is not None and uw_w.ndim == 2 and uw_w.shape[0] == n_t else None)
    mass_i = (np.nansum(np.asarray(pm, dtype=np.float64), axis=1) / (Lx * Ly)
              if pm is not None and pm.ndim == 2 and pm.shape[0] == n_t else None)
    col_rate = balance.column_momentum_rate(t_sample, get("u_mean"), z_w, z_ref_eff)
    # the bed's total stress: u*_0^2, with the pressure-gradient drive's body force on the column
    # below z_ref included (u*_0^2 = u*(z_ref)^2 + G z_ref)
    bud = balance.budget_friction(rho, g, u0_stress ** 2 if math.isfinite(u0_stress) else math.nan,
                                  uw_bed_i, mass_i, col_rate)
    put("column_momentum_rate", (), col_rate)
    for name, val in bud.items():
        put(name, (), val)

    # ---------------- spin-up (particle-free) ----------------
    sp_z = np.asarray(sp_coords.get("z", z), dtype=np.float64)
    sp_zw = np.asarray(sp_coords.get("z_w", z_w), dtype=np.float64)

    def on_z(prof, zz):
        prof = np.asarray(prof, dtype=np.float64)
        if prof.shape != zz.shape:
            return np.full(nz, np.nan)
        if zz.shape == z.shape and np.allclose(zz, z):
            return prof
        return np.interp(z, zz, prof, left=np.nan, right=np.nan)

    def sp_get(name, n):
        a = sp.get(name)
        if a is None:
            return np.full(n, np.nan)
        a = np.asarray(a, dtype=np.float64)
        return a if a.ndim == 1 else _tmean(a, n)

    u_sp = on_z(sp_get("u_mean", sp_z.size), sp_z)
    uw_sp_w = sp_get("uw_res", sp_zw.size) + sp_get("uw_sgs", sp_zw.size)
    uw_sp = on_z(profiles.faces_to_centres(uw_sp_w), 0.5 * (sp_zw[1:] + sp_zw[:-1])) \
        if sp_zw.size >= 2 else np.full(nz, np.nan)
    tke_sp = on_z(sp_get("tke_res", sp_z.size) + sp_get("e_sgs", sp_z.size), sp_z)
    fit0 = profiles.log_law_fit(z, u_sp, *rng_fit(math.nan), kappa, H=H)
    put("u_star_0", (), fit0.u_star, fit_range=f"[{fit0.z_min:g}, {fit0.z_max:g}] m, {fit0.n_points} levels")
    put("z0_0", (), fit0.z0)
    put("fit_r2_0", (), fit0.r2)
    put("u_star_0_stress", (), profiles.stress_u_star(sp_zw, uw_sp_w, z_ref_eff)
        if sp_zw.size == uw_sp_w.size else math.nan)

    put("u_mean", ("z",), u_mean)
    put("u_mean_spinup", ("z",), u_sp)
    put("uw_flux", ("z",), uw_flux)
    put("uw_flux_spinup", ("z",), uw_sp)
    put("tke", ("z",), tke)
    put("tke_resolved", ("z",), tke_res)
    put("tke_spinup", ("z",), tke_sp)
    put("tau_p", ("z",), tau_p, sign="positive for a downward flux of streamwise momentum")

    # ---------------- mass flux (section 3.2, 4.3) ----------------
    G_tot = flux.total_flux(G, dz)
    put("G", ("z",), G)
    put("G_tot", (), G_tot)
    put("airborne_mass_per_m2", (), airborne_mass)
    put("z_m_flux995", (), flux.flux_height(z_w, G))
    put("G_decay_height", (), flux.decay_height(z, G, z_m))
    G_series = get("G_tot_series")
    if G_series is not None and t_series.size == G_series.size:
        g_mean, sigma_G = flux.sigma_series(t_series, G_series, t0, t1)
    else:
        g_mean, sigma_G = math.nan, math.nan
    put("G_tot_window_mean", (), g_mean)
    put("sigma_G", (), sigma_G, definition="std over the sampling window of the total-flux series "
        "G_tot_series (see saltstudy.analysis.flux)")
    put("sigma_G_over_G_tot", (), sigma_G / g_mean if g_mean and math.isfinite(g_mean) and g_mean > 0
        else math.nan)

    # planes restricted to the sampling window (t >= first 3-D sample)
    C_all = get("C_p")
    G_col = get("G_col")
    u_pl = get("u_plane")
    pmask = np.ones(t_plane.size, bool)
    if t_plane.size and n_t:
        m = t_plane >= t0 - 1e-9
        if m.any():
            pmask = m
    C_w = C_all[pmask] if C_all is not None and C_all.ndim == 3 and C_all.shape[0] == pmask.size else None
    if G_col is not None and G_col.ndim == 3 and G_col.shape[0] == pmask.size and pmask.any():
        idx = np.flatnonzero(pmask)
        m_loc, s_loc = flux.pooled_mean_std(
            G_col[idx[i:i + PLANE_CHUNK]] for i in range(0, idx.size, PLANE_CHUNK))
    else:
        s_loc, m_loc = math.nan, math.nan
    put("sigma_G_local", (), s_loc)
    put("sigma_G_local_over_mean", (), s_loc / m_loc if m_loc and math.isfinite(m_loc) and m_loc > 0
        else math.nan)

    # ---------------- sizes and Stokes (sections 3.2, 4.2) ----------------
    hist = get("size_hist")
    d_edges = get("d_edges")
    if d_edges is None or d_edges.size != d_bin.size + 1:
        if d_bin.size >= 2:
            mid = 0.5 * (d_bin[1:] + d_bin[:-1])
            d_edges = np.concatenate([[d_bin[0] - (mid[0] - d_bin[0])], mid,
                                      [d_bin[-1] + (d_bin[-1] - mid[-1])]])
        else:
            d_edges = np.array([0.5, 1.5]) * (d_bin[0] if d_bin.size else 1e-4)
    hist_z = _tsum(hist, nz) if hist is not None and hist.ndim == 3 else np.zeros((nz, d_bin.size))
    band_edges = sizes.band_edges_for(float(z_w[-1]))
    psd_air = sizes.band_mass_fractions(hist_z, z, d_bin, band_edges) if d_bin.size else \
        np.full((band_edges.size - 1, 0), np.nan)
    psd_bed, bed_src = sizes.bed_mass_fractions(info.get("soil"), d_edges)
    put("psd_air", ("z_band", "d_bin"), psd_air, weighting="mass (count x d_bin^3)")
    put("psd_bed", ("d_bin",), psd_bed, source=bed_src)
    put("z_band_edges", ("z_band_edge",), band_edges)
    put("d_edges", ("d_edge",), d_edges)

    d_mass = stokes.mass_mean_diameter(hist_z, d_bin) if d_bin.size else np.full(nz, np.nan)
    T_p = stokes.response_time(d_mass, rho_p, rho, nu)
    P_m = _tsum(pm, nz)
    beta = stokes.drag_rate(_tmean(get("pdrag"), nz), rho, dz, Lx, Ly) if get("pdrag") is not None \
        else np.zeros(nz)
    beta = np.nan_to_num(beta)
    cov_fp = stokes.fluid_grain_covariance(P_m, _tsum(get("pmuf_up"), nz), _tsum(get("pmuf"), nz),
                                           _tsum(pmu, nz))
    e_drag = stokes.eps_drag(beta, tke_res, cov_fp)
    st_tr = _tmean(get("sgs_transfer"), nz)
    e_sgs_f = stokes.eps_sgs_fluct(st_tr, uw_sgs_c, u_mean, z)
    eps_tot = stokes.eps_total(e_drag, e_sgs_f)
    T_eps = stokes.eddy_time(tke_res, eps_tot)
    put("d_mass_mean", ("z",), d_mass)
    put("T_p", ("z",), T_p)
    put("eps_drag", ("z",), e_drag)
    put("eps_sgs", ("z",), e_sgs_f)
    put("eps_tot", ("z",), eps_tot)
    put("T_eps", ("z",), T_eps)
    put("St", ("z",), stokes.stokes_number(T_p, T_eps))

    # ---------------- streamers (section 4.1) ----------------
    k_up = int(np.argmin(np.abs(z_plane - U_PLANE_HEIGHT))) if z_plane.size else -1
    U_w = None
    u_pl_ok = u_pl is not None and u_pl.ndim == 4 and u_pl.shape[0] == pmask.size
    if u_pl_ok and k_up >= 0:
        U_w = u_pl[:, :, :, k_up][pmask]
    n_planes = int(C_w.shape[0]) if C_w is not None else 0
    put("n_planes", (), n_planes)
    put("n_samples", (), n_t)
    # parcel-count noise of C_p (streamers module doc): Poisson, from the mean count per column.
    # The run's parcels weigh w grains on columns of dx dy; the paper's weigh the case's Q on
    # its 0.1 m columns. The statistics keep the paper's noise: the difference is removed.
    w_run = _f(attrs, "Q", info["Q_case"] * info["q_multiplier"])
    Q_paper = info["Q_case"] if math.isfinite(info["Q_case"]) else w_run / info["q_multiplier"]
    area = dx * dy

    def noise_to_paper(planes) -> np.ndarray:
        """Per-plane noise variance to remove so that the paper's remains (0 when unknown)."""
        run = streamers.poisson_noise_variance(planes, w_run, area)
        paper = streamers.poisson_noise_variance(planes, Q_paper, streamers.PAPER_CELL_AREA)
        out = run - paper
        return np.where(np.isfinite(out), out, 0.0)

    removed = np.zeros(n_planes)
    n_col = n_col_paper = small_ratio = math.nan
    if C_w is not None and n_planes and nx >= 2 and ny >= 2:
        dev_c, var_c = streamers.deviation_planes(C_w)
        noise_run = streamers.poisson_noise_variance(C_w, w_run, area)
        noise_run = np.where(np.isfinite(noise_run), noise_run, 0.0)
        has = var_c > 0
        noise_frac = float(np.mean(noise_run[has] / var_c[has])) if has.any() else math.nan
        removed = noise_to_paper(C_w)
        n_col = float(np.mean(streamers.parcels_per_cell(C_w, w_run, area)))
        n_col_paper = float(np.mean(streamers.parcels_per_cell(C_w, Q_paper,
                                                               streamers.PAPER_CELL_AREA)))
        _check_parcel_counts(C_w, w_run, area)
        poisson = noise_run[has]
        if has.any() and np.all(poisson > 0):
            small_ratio = float(np.mean(streamers.small_scale_power(dev_c[has]) / poisson))
        del dev_c
        ac = streamers.autocorrelation_2d(C_w, noise=removed)
        lam_x = streamers.core_length(ac[:, ny // 2], dx)
        lam_y = streamers.core_length(ac[nx // 2, :], dy)
        # S_c carries the paper's parcel noise; each reading's error is the run's own
        ky, S_c, S_c_se, spacing_c = streamers.spanwise_spacing(C_w, dy, noise=removed)
        ac_raw = streamers.autocorrelation_2d(C_w)
        lam_x_raw = streamers.core_length(ac_raw[:, ny // 2], dx)
        lam_y_raw = streamers.core_length(ac_raw[nx // 2, :], dy)
        ac_free = streamers.autocorrelation_2d(C_w, noise=noise_run)
        lam_x_free = streamers.core_length(ac_free[:, ny // 2], dx)
        lam_y_free = streamers.core_length(ac_free[nx // 2, :], dy)
        # the paper's field held its own count of parcels (2,000 per m2 at Q, [28]), not the
        # run's: with that relative noise the reading sees a field as noisy as the paper's
        at_count = noise_run - streamers.count_noise_variance(
            C_w, paper_grid.PAPER_PARCELS_PER_M2, streamers.PAPER_CELL_AREA)
        ac_count = streamers.autocorrelation_2d(C_w, noise=at_count)
        lam_x_count = streamers.core_length(ac_count[:, ny // 2], dx)
        lam_y_count = streamers.core_length(ac_count[nx // 2, :], dy)
        snap_c = np.asarray(C_w[-1], dtype=np.float64)
    else:
        ac = np.full((nx, ny), np.nan)
        lam_x = lam_y = lam_x_raw = lam_y_raw = noise_frac = math.nan
        spacing_c = streamers.SpanwiseSpacing(math.nan, math.nan, math.nan)
        lam_x_free = lam_y_free = lam_x_count = lam_y_count = math.nan
        ky = np.arange(ny // 2 + 1) / Ly if ny else np.zeros(0)
        S_c = S_c_se = np.full(ky.size, np.nan)
        snap_c = np.full((nx, ny), np.nan)
    if U_w is not None and U_w.shape[0] and ny >= 2:
        _, S_u, S_u_se, spacing_u = streamers.spanwise_spacing(U_w, dy)
        snap_u = np.asarray(U_w[-1], dtype=np.float64)
    else:
        S_u = S_u_se = np.full(ky.size, np.nan)
        spacing_u = streamers.SpanwiseSpacing(math.nan, math.nan, math.nan)
        snap_u = np.full((nx, ny), np.nan)
    noise_def = (f"Poisson parcel-count noise mean(C_p) w / (dx dy) with w = {w_run:g} grains per "
                 f"parcel, less the paper's mean(C_p) Q / {streamers.PAPER_CELL_AREA:g} m2 with "
                 f"Q = {Q_paper:g} (saltstudy.analysis.streamers)")
    put("lambda_x", (), lam_x, definition="2 x lag where the autocorrelation of C_p drops below 0.4",
        noise_removed=noise_def)
    put("lambda_y", (), lam_y, definition="2 x lag where the autocorrelation of C_p drops below 0.4",
        noise_removed=noise_def)
    # Table 2 reads the premultiplied spectrum (docs/STREAMERS.md); the other readings stay
    # beside it so that what the choice does to each case can be seen
    for field, spacing in (("delta_y", spacing_c), ("delta_y_u", spacing_u)):
        put(field, (), spacing.chosen, reading="premultiplied",
            definition="saltstudy.analysis.streamers.premultiplied_peak; docs/STREAMERS.md")
        put(f"{field}_premultiplied", (), spacing.premultiplied,
            definition="saltstudy.analysis.streamers.premultiplied_peak")
        put(f"{field}_density", (), spacing.density,
            definition="saltstudy.analysis.streamers.spectral_peak")
        put(f"{field}_correlation", (), spacing.correlation,
            definition="saltstudy.analysis.streamers.correlation_minimum")
    put("lambda_x_raw", (), lam_x_raw)
    put("lambda_y_raw", (), lam_y_raw)
    put("lambda_x_noise_free", (), lam_x_free)
    put("lambda_y_noise_free", (), lam_y_free)
    put("lambda_x_paper_count", (), lam_x_count)
    put("lambda_y_paper_count", (), lam_y_count)
    put("C_p_noise_fraction", (), noise_frac,
        definition="saltstudy.analysis.streamers.poisson_noise_variance")
    put("C_p_parcels_per_column", (), n_col, definition="mean(C_p) dx dy / w")
    put("C_p_parcels_per_column_paper", (), n_col_paper, definition="mean(C_p) 0.01 m2 / Q")
    put("C_p_small_scale_over_poisson", (), small_ratio,
        definition="saltstudy.analysis.streamers.small_scale_power over poisson_noise_variance")
    # the streamers of the grains above the first cell (z >= z_f[1]): the same readings without
    # the slow first-cell population
    Ca_all = get("C_p_above")
    Ca_w = (Ca_all[pmask] if Ca_all is not None and Ca_all.ndim == 3
            and Ca_all.shape[0] == pmask.size else None)
    lam_xa = lam_ya = dya = math.nan
    if Ca_w is not None and Ca_w.shape[0] and nx >= 2 and ny >= 2 and np.any(Ca_w > 0):
        rem_a = noise_to_paper(Ca_w)
        ac_a = streamers.autocorrelation_2d(Ca_w, noise=rem_a)
        lam_xa = streamers.core_length(ac_a[:, ny // 2], dx)
        lam_ya = streamers.core_length(ac_a[nx // 2, :], dy)
        dya = streamers.spanwise_spacing(Ca_w, dy, noise=rem_a)[3].chosen
        del ac_a
    for name, val in (("lambda_x_above_first_cell", lam_xa), ("lambda_y_above_first_cell", lam_ya),
                      ("delta_y_above_first_cell", dya)):
        put(name, (), val, definition=f"{name.split('_above')[0]} of C_p_above (the grains above "
            "the first grid cell), the same noise removal")
    put("C_p_autocorr", ("lag_x", "lag_y"), ac)
    put("S_c", ("ky",), S_c)
    put("S_c_stderr", ("ky",), S_c_se)
    put("S_u", ("ky",), S_u)
    put("S_u_stderr", ("ky",), S_u_se)
    put("C_p_snapshot", ("x", "y"), snap_c)
    put("u_snapshot", ("x", "y"), snap_u, z_plane=float(z_plane[k_up]) if k_up >= 0 else math.nan)

    # plane spacing and lags
    tp_w = t_plane[pmask] if t_plane.size else t_plane
    dtp = float(np.median(np.diff(tp_w))) if tp_w.size >= 2 else math.nan
    K = int(min(tp_w.size - 1, math.floor(MAX_LAG_S / dtp + 1e-9))) if math.isfinite(dtp) and dtp > 0 else 0
    K = max(K, 0)
    lag_t = np.arange(K + 1) * (dtp if math.isfinite(dtp) else 0.0)
    st_peak = np.full(K + 1, np.nan)
    st_x = np.full(K + 1, np.nan)
    st_y = np.full(K + 1, np.nan)
    speed = lifetime = math.nan
    if C_w is not None and K >= 1 and nx >= 2 and ny >= 2:
        st = streamers.space_time_correlation(C_w, dtp, dx, dy, max_lag_s=K * dtp + 0.5 * dtp)
        n = st.lag_t.size
        st_peak[:n], st_x[:n], st_y[:n] = st.peak, st.x_peak, st.y_peak
        speed, lifetime = streamers.speed_and_lifetime(st)
    put("C_p_st_peak", ("lag_t",), st_peak)
    put("C_p_st_x", ("lag_t",), st_x)
    put("C_p_st_y", ("lag_t",), st_y)
    put("streamer_speed", (), speed)
    put("streamer_lifetime", (), lifetime)
    R_lag = np.full((K + 1, z_plane.size), np.nan)
    if C_w is not None and u_pl_ok:
        noise_w = float(removed.mean()) if removed.size else 0.0
        for j in range(z_plane.size):     # one plane height at a time (memory)
            R_lag[:, j] = correlation.lagged_correlation(C_w, u_pl[:, :, :, j][pmask][..., None], K,
                                                         noise=noise_w)[:, 0]
    put("R_cu_lag", ("lag_t", "z_plane"), R_lag)

    # ---------------- R_cu (eq. 12) ----------------
    u3 = get("u")
    Cs = get("C_p_s")
    if u3 is not None and Cs is not None and u3.ndim == 4 and Cs.ndim == 3 and u3.shape[0] == Cs.shape[0]:
        R_cu = correlation.correlation_profile(Cs, u3, noise=float(np.mean(noise_to_paper(Cs))))
    else:
        R_cu = np.full(nz, np.nan)
    put("R_cu", ("z",), R_cu)
    put("R_cu_upper", (), correlation.upper_mean(z, R_cu, z_m))

    # ---------------- series (section 3.1) ----------------
    def series_var(name):
        a = get(name)
        if a is None or a.shape != t_series.shape:
            return np.full(t_series.size, np.nan)
        return a.astype(np.float64)

    n_par = series_var("n_parcels")
    stats = series.overshoot_stats(t_series, n_par, t0, t1)
    for k, v in stats.items():
        put(k, (), v)
    us_ser, us_se, us_nb = series.block_mean_stress_u_star(t_series, series_var("u_star_ref"), t0,
                                                           t1)
    put("u_star_s_stress_series", (), us_ser)
    put("u_star_s_stress_se", (), us_se, blocks=us_nb)
    put("E_splash_over_E_impact", (), series.increment_ratio(
        t_series, series_var("E_splash"), series_var("E_impact"), t0, t1))
    put("n_parcels", ("time",), n_par)
    put("G_tot_series", ("time",), series_var("G_tot_series"))
    put("u_star_ref", ("time",), series_var("u_star_ref"))
    put("G_tot_sample", ("time_sample",), G_tot_sample)
    if C_all is not None and C_all.ndim == 3 and C_all.shape[0] == t_plane.size:
        put("C_p_mean", ("time_plane",), np.asarray(C_all, dtype=np.float64).mean(axis=(1, 2))
            if C_all.size else np.full(t_plane.size, np.nan))
    else:
        put("C_p_mean", ("time_plane",), np.full(t_plane.size, np.nan))

    put("u_star_t", (), _u_star_t(info, rho, rho_p, g))

    # ---------------- the layer's anatomy (analysis/layer.py) ----------------
    q_case = info["Q_case"] if math.isfinite(info["Q_case"]) else _f(attrs, "Q", 1.0)
    anat = layer.band_anatomy(z, z_w, get("pn"), get("pm"), get("pmu"), get("pmuf"), q_case,
                              Lx * Ly)
    band_e = anat.pop("band_edges")
    put("band_edges", ("height_band_edge",), band_e)
    for name, val in anat.items():
        put(name, ("height_band",), val)
    nb = anat["band_parcels_per_m2_at_Q"]
    put("first_cell_parcel_fraction", (), float(nb[0] / np.nansum(nb))
        if np.nansum(nb) > 0 else math.nan)
    put("n_parcels_per_m2_at_Q_above_first_cell", (), float(np.nansum(nb[1:]))
        if np.isfinite(nb).any() else math.nan)
    # the momentum balance at the bed from the impact record (analysis/balance.py)
    imp_bal = balance.bed_exchange(t_series, get("bed_px"), get("bed_pz"), t0, t1, Lx * Ly)
    for name, val in imp_bal.items():
        put(name, (), val)
    tau_g_b = V["tau_g_bed_budget"][1]
    put("mu_b_ratio_budget_to_impacts", (), float(V["mu_b_budget"][1] / imp_bal["mu_b"])
        if imp_bal["mu_b"] and math.isfinite(imp_bal["mu_b"]) else math.nan)
    put("tau_g_bed_ratio_budget_to_impacts", (), float(tau_g_b / imp_bal["tau_g_bed_impacts"])
        if imp_bal["tau_g_bed_impacts"] and math.isfinite(imp_bal["tau_g_bed_impacts"])
        else math.nan)
    # the impact record's bins are the archive's coordinates (their lower edges, equal widths)
    def edges(name):
        lo = np.asarray(coords.get(name, np.zeros(0)), dtype=np.float64)
        if lo.size < 2:
            return np.zeros(1)
        return np.append(lo, lo[-1] + (lo[1] - lo[0]))

    ev, ea, et, el = (edges(k) for k in ("v_imp", "impact_angle", "hop_time", "hop_length"))
    imp = layer.impact_statistics(get("impact_hist"), get("impact_outcomes"), get("hop_time_hist"),
                                  get("hop_length_hist"), ev, ea, et, el, g)
    for name, val in imp.items():
        dims = {"impact_speed_pdf": ("v_imp",), "replacement_by_speed": ("v_imp",),
                "impacts_by_speed": ("v_imp",), "impact_angle_pdf": ("impact_angle",),
                "hop_time_pdf": ("hop_time",), "hop_length_pdf": ("hop_length",)}.get(name, ())
        put(name, dims, val)
    impact_centres = {"v_imp": 0.5 * (ev[1:] + ev[:-1]), "impact_angle": 0.5 * (ea[1:] + ea[:-1]),
                      "hop_time": 0.5 * (et[1:] + et[:-1]), "hop_length": 0.5 * (el[1:] + el[:-1])}

    # ---------------- dataset ----------------
    n_band = band_edges.size - 1
    coord_values = {
        "z": z, "z_w": z_w, "time": t_series, "time_sample": t_sample, "time_plane": t_plane,
        "ky": ky, "lag_x": streamers.centred_lags(nx, dx), "lag_y": streamers.centred_lags(ny, dy),
        "lag_t": lag_t, "z_plane": z_plane, "d_bin": d_bin,
        "z_band": 0.5 * (band_edges[1:] + band_edges[:-1]) if n_band > 0 else np.zeros(0),
        "x": x, "y": y, "height_band": np.arange(band_e.size - 1), **impact_centres,
    }
    out = xr.Dataset()
    for name, val in coord_values.items():
        units, long_name = SPEC[name]
        out = out.assign_coords({name: (name, np.asarray(val, dtype=np.float64),
                                        {"units": units, "long_name": long_name})})
    for name, (dims, data, extra) in V.items():
        units, long_name = SPEC[name]
        out[name] = xr.DataArray(data, dims=dims, attrs={"units": units, "long_name": long_name, **extra})
    return out
