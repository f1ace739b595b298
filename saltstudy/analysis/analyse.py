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

import json
import logging
import math
import time as _time
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..ncio import NC_LOCK, write_dataset
from . import balance, correlation, flux, layer, paper_grid, profiles, series, sizes, stokes, streamers
from ..physics import laws

__all__ = ["analyse_case", "analyse_datasets", "half_window_statistics", "HALF_STATISTICS", "SPEC",
           "REQUIRED_VARIABLES", "MAX_LAG_S",
           "SAMPLE_VARIABLES_USED"]

log = logging.getLogger(__name__)

#: the largest time lag of R_cu_lag and of the space-time correlation of C_p [s]
MAX_LAG_S = 5.0
#: height of the u plane used for delta_y_u and u_snapshot [m] (paper Fig. 9b, 10b)
U_PLANE_HEIGHT = 0.1

# name -> (units, long_name); every variable analysis.nc holds (ARCHITECTURE.md + extensions)
SPEC: dict[str, tuple[str, str]] = {
    # coordinates
    "z": ("m", "height of the cell centres"),
    "z_w": ("m", "height of the cell faces"),
    "time": ("s", "time of the series records since saltation activation"),
    "time_sample": ("s", "time of the 3-D samples since saltation activation"),
    "time_plane": ("s", "time of the 2-D planes since saltation activation"),
    "ky": ("m-1", "spanwise wavenumber (cycles per metre)"),
    "lag_x": ("m", "streamwise lag"),
    "lag_y": ("m", "spanwise lag"),
    "lag_t": ("s", "time lag"),
    "z_plane": ("m", "height of the horizontal wind planes"),
    "d_bin": ("m", "grain diameter bin centre"),
    "z_band": ("m", "height band centre"),
    "x": ("m", "streamwise position of the cell centres"),
    "y": ("m", "spanwise position of the cell centres"),
    "height_band": ("1", "height band: 0 the first grid cell, 1 from there to 5 cm, 2 above "
                    "(analysis/layer.py)"),
    "v_imp": ("m s-1", "impact speed bin centre"),
    "impact_angle": ("degree", "impact angle to the bed, bin centre"),
    "hop_time": ("s", "hop flight time bin centre"),
    "hop_length": ("m", "hop streamwise length bin centre"),
    # the layer's anatomy (analysis/layer.py)
    "band_edges": ("m", "edges of the height bands"),
    "band_parcels_per_m2_at_Q": ("m-2", "airborne grains per m2 of bed in the band over the case's "
                                 "Q (parcels per m2 at the case's parcel weight), mean over the "
                                 "3-D samples"),
    "band_mass_per_m2": ("kg m-2", "airborne grain mass per m2 of bed in the band"),
    "band_flux": ("kg m-1 s-1", "the band's part of the total streamwise mass flux G_tot"),
    "band_speed": ("m s-1", "mass-weighted mean streamwise grain velocity in the band"),
    "band_wind_seen": ("m s-1", "mass-weighted mean streamwise fluid velocity at the grains in "
                       "the band"),
    "first_cell_parcel_fraction": ("1", "share of the airborne grains in the first grid cell"),
    "n_parcels_per_m2_at_Q_above_first_cell": ("m-2", "airborne grains above the first grid cell "
                                               "per m2 of bed over the case's Q, mean over the "
                                               "3-D samples"),
    # the momentum balance at the bed (analysis/balance.py)
    "tau_g_bed_impacts": ("Pa", "streamwise momentum the grains give the bed per unit area and "
                          "time, from the impact record (impacts minus launches)"),
    "bed_vertical_impulse": ("Pa", "vertical momentum the bed gives the grains per unit area and "
                             "time, from the impact record"),
    "mu_b": ("1", "bed friction coefficient from the impact record: streamwise over vertical "
             "momentum exchanged with the bed"),
    "mu_b_se": ("1", "standard error of mu_b from contiguous blocks of the sampling window"),
    "tau_g_bed_budget": ("Pa", "stress the grains carry to the bed from the air's budget: total "
                         "stress at the reference height less the bulk law's bed stress"),
    "bed_fluid_stress_fraction": ("1", "the bulk law's stress on the bed over the total stress at "
                                  "the reference height"),
    "mu_b_budget": ("1", "bed friction coefficient from the air's budget: tau_g_bed_budget over "
                    "the airborne grains' weight"),
    "mu_b_budget_se": ("1", "standard error of mu_b_budget from the per-sample ratios"),
    "column_momentum_rate": ("m2 s-2", "rate of change of the air's streamwise momentum below the "
                             "reference height per unit area over the 3-D samples (linear fit; 0 "
                             "in a steady layer), taken out of the budget's tau_g"),
    "mu_b_ratio_budget_to_impacts": ("1", "mu_b_budget over mu_b (1 in a steady layer whose "
                                     "weight the bed carries)"),
    "tau_g_bed_ratio_budget_to_impacts": ("1", "tau_g_bed_budget over tau_g_bed_impacts (1 in a "
                                          "steady layer that leaks no momentum)"),
    "lambda_x_above_first_cell": ("m", "lambda_x of the grains above the first grid cell"),
    "lambda_y_above_first_cell": ("m", "lambda_y of the grains above the first grid cell"),
    "delta_y_above_first_cell": ("m", "delta_y (premultiplied reading) of the grains above the "
                                 "first grid cell"),
    "impact_speed_pdf": ("s m-1", "probability density of the impact speed over the sampling "
                         "window"),
    "impact_angle_pdf": ("degree-1", "probability density of the impact angle to the bed"),
    "impacts_by_speed": ("1", "parcel impacts over the sampling window by impact speed"),
    "replacement_by_speed": ("1", "rebounds + ejected parcels per impact, by impact speed"),
    "impact_speed_mean": ("m s-1", "mean impact speed over the sampling window"),
    "impact_speed_median": ("m s-1", "median impact speed over the sampling window"),
    "impact_angle_mean": ("degree", "mean impact angle to the bed"),
    "replacement_mean": ("1", "rebounds + ejected parcels per impact over the sampling window "
                         "(1 in a steady layer)"),
    "rebound_fraction": ("1", "rebounds per impact over the sampling window"),
    "ejecta_per_impact": ("1", "ejected parcels per impact over the sampling window"),
    "hop_time_pdf": ("s-1", "probability density of the flight time of the hops a splash launched"),
    "hop_length_pdf": ("m-1", "probability density of the streamwise length of the hops a splash "
                       "launched"),
    "hop_time_mean": ("s", "mean flight time of the hops a splash launched"),
    "hop_time_median": ("s", "median flight time of the hops a splash launched"),
    "hop_length_mean": ("m", "mean streamwise length of the hops a splash launched"),
    "hop_length_median": ("m", "median streamwise length of the hops a splash launched"),
    "hop_height_ballistic_median": ("m", "g t^2 / 8 at the median flight time: the height of a "
                                    "ballistic hop of that flight time (an upper estimate)"),
    # scalars
    "u_star_s": ("m s-1", "saltation friction velocity u*s from the log-law fit above the saltation layer"),
    "z0s": ("m", "saltation roughness length z0s from the log-law fit"),
    "u_star_0": ("m s-1", "friction velocity of the particle-free spin-up from the log-law fit"),
    "z0_0": ("m", "roughness length of the particle-free spin-up from the log-law fit"),
    "u_star_s_stress_series": ("m s-1", "u* of the window-mean total stress at z_ref from the "
                               "drive's high-rate series (beside u_star_s_stress, read from the "
                               "3-D samples' profiles)"),
    "u_star_s_stress_se": ("m s-1", "standard error of the stress u*s from 10-s block means of the "
                           "stress at z_ref over the window (swings longer than the window "
                           "not included)"),
    "u_star_s_se": ("m s-1", "standard error of u*s: standard deviation of the per-sample fits over "
                    "sqrt(number of samples); a lower bound when the samples are correlated"),
    "u_star_s_samples": ("m s-1", "u*s from the log-law fit of each 3-D sample's mean profile "
                         "(same height range as u_star_s)"),
    "u_star_s_stress": ("m s-1", "sqrt|<u'w'>| (resolved + SGS) at the reference height, with grains"),
    "u_star_0_stress": ("m s-1", "sqrt|<u'w'>| (resolved + SGS) at the reference height, spin-up"),
    "z0s_stress": ("m", "z0s from the log law with u* fixed at u_star_s_stress (mean over the fit range)"),
    "z_ref_eff": ("m", "reference height of the stress friction velocity"),
    "fit_r2": ("1", "coefficient of determination of the log-law fit with grains"),
    "fit_r2_0": ("1", "coefficient of determination of the spin-up log-law fit"),
    "fit_n": ("1", "number of levels in the log-law fit with grains"),
    "z_m": ("m", "saltation height: tau_p first below 0.1 % of rho u*s^2"),
    "z_m_flux995": ("m", "height below which 99.5 % of the total mass flux lies"),
    "G_tot": ("kg m-1 s-1", "total (vertically integrated) horizontal mass flux, from the 3-D samples"),
    "G_decay_height": ("m", "e-folding height of G(z) below z_m (regression of ln G on z)"),
    "G_tot_window_mean": ("kg m-1 s-1", "mean of the total-flux series over the sampling window"),
    "sigma_G": ("kg m-1 s-1", "standard deviation of the instantaneous total flux G_tot(t) over the sampling window"),
    "sigma_G_over_G_tot": ("1", "sigma_G divided by the window-mean total flux of the same series"),
    "sigma_G_local": ("kg m-1 s-1", "standard deviation of the local column flux G_col(x, y, t) about its mean"),
    "sigma_G_local_over_mean": ("1", "sigma_G_local divided by the mean column flux"),
    "lambda_x": ("m", "streamer length: streamwise extent of the C_p autocorrelation > 0.4, "
                 "with the paper's parcel-count noise"),
    "lambda_y": ("m", "streamer width: spanwise extent of the C_p autocorrelation > 0.4, "
                 "with the paper's parcel-count noise"),
    "delta_y": ("m", "mean spanwise spacing of streamers, Table 2's reading (docs/STREAMERS.md): "
                "delta_y_premultiplied"),
    "delta_y_premultiplied": ("m", "1/ky at the peak of the premultiplied spanwise spectrum ky S_c(ky) "
                              "of C_p (with the paper's parcel-count noise) on a log wavelength "
                              "axis that stands out of the spectrum's sampling noise"),
    "delta_y_density": ("m", "1/ky at the peak of the spanwise spectral density of C_p (with the "
                        "run's parcel-count noise) that stands out of the spectrum's sampling noise"),
    "delta_y_correlation": ("m", "twice the lag of the first minimum of the spanwise autocorrelation "
                            "of C_p, averaged over x and time, that stands out of its sampling noise"),
    "lambda_x_raw": ("m", "lambda_x with the run's own parcel-count noise"),
    "lambda_y_raw": ("m", "lambda_y with the run's own parcel-count noise"),
    "lambda_x_noise_free": ("m", "lambda_x with all the Poisson parcel-count noise removed"),
    "lambda_y_noise_free": ("m", "lambda_y with all the Poisson parcel-count noise removed"),
    "lambda_x_paper_count": ("m", "lambda_x with the parcel-count noise of the paper's count "
                             "(2,000 parcels per m2, 0.1 m columns) in place of the run's"),
    "lambda_y_paper_count": ("m", "lambda_y with the parcel-count noise of the paper's count "
                             "(2,000 parcels per m2, 0.1 m columns) in place of the run's"),
    "C_p_noise_fraction": ("1", "Poisson parcel-count noise variance of C_p over its spatial variance, "
                           "mean over the planes"),
    "C_p_parcels_per_column": ("1", "mean number of parcels per grid column in the C_p planes"),
    "C_p_parcels_per_column_paper": ("1", "mean number of parcels per 0.1 m x 0.1 m column the "
                                     "paper's parcels (the case's Q) would give for the same C_p"),
    "C_p_small_scale_over_poisson": ("1", "mean power of C_p at wavelengths under 4 cells in both "
                                     "directions over the Poisson noise level (1: independent "
                                     "parcels and no pattern there)"),
    "delta_y_u": ("m", "mean spanwise spacing of streaks of u at the 0.1 m plane, Table 2's reading "
                  "(docs/STREAMERS.md): delta_y_u_premultiplied"),
    "delta_y_u_premultiplied": ("m", "1/ky at the peak of the premultiplied spanwise spectrum "
                                "ky S_u(ky) of u at the 0.1 m plane on a log wavelength axis that "
                                "stands out of the spectrum's sampling noise"),
    "delta_y_u_density": ("m", "1/ky at the peak of the spanwise spectral density of u at the 0.1 m "
                          "plane that stands out of the spectrum's sampling noise"),
    "delta_y_u_correlation": ("m", "twice the lag of the first minimum of the spanwise "
                              "autocorrelation of u at the 0.1 m plane, averaged over x and time, "
                              "that stands out of its sampling noise"),
    "u_star_t": ("m s-1", "threshold friction velocity (Shao and Lu 2000) of the soil's mean diameter"),
    "tau_p_surface_fraction": ("1", "grain-borne share of the momentum flux at the bed: tau_p at z = 0 "
                               "over the total stress rho u*^2 at the reference height"),
    "tau_p_bed": ("Pa", "tau_p at z = 0: the exponential fitted to the layer means of the lowest "
                  "layers, at the bed"),
    "tau_p_bed_decay_height": ("m", "e-folding height of that exponential"),
    "tau_p_paper_cell_fraction": ("1", "mean of that exponential over the paper's first level "
                                  "(0-1 cm) over rho u*^2 at the reference height"),
    "tau_p_surface_fraction_budget": ("1", "1 - air stress at the bed over the total stress at the "
                                      "reference height (the grain share at the bed by the "
                                      "momentum budget of a steady layer)"),
    "R_cu_upper": ("1", "mean R_cu over 0.6 z_m <= z <= z_m"),
    "n_parcels_mean": ("1", "mean number of parcels over the sampling window"),
    "airborne_mass_per_m2": ("kg m-2", "mass of the airborne grains per unit bed area, sum over "
                             "the column of sum Q m_p / (Lx Ly), mean over the 3-D samples"),
    "n_parcels_peak": ("1", "largest number of parcels after activation"),
    "overshoot_ratio": ("1", "n_parcels_peak / n_parcels_mean"),
    "t_equilibrium": ("s", "time after activation when the parcel count settles within 10 % of its plateau"),
    "streamer_lifetime": ("s", "lag at which the moving-frame peak correlation of C_p drops below 1/e"),
    "streamer_speed": ("m s-1", "streamwise propagation speed of the C_p pattern"),
    "E_splash_over_E_impact": ("1", "kinetic energy of rebounding and ejected grains over that of impacting grains"),
    "fit_z_min": ("m", "lowest height of the log-law fit"),
    "fit_z_max": ("m", "highest height of the log-law fit"),
    "n_samples": ("1", "number of 3-D samples used"),
    "n_planes": ("1", "number of 2-D planes used (t >= first 3-D sample)"),
    # profiles on z
    "u_mean": ("m s-1", "horizontally and time averaged streamwise wind, with grains"),
    "u_mean_spinup": ("m s-1", "horizontally and time averaged streamwise wind, particle-free spin-up"),
    "uw_flux": ("m2 s-2", "kinematic momentum flux <u'w'> (resolved + SGS), with grains"),
    "uw_flux_spinup": ("m2 s-2", "kinematic momentum flux <u'w'> (resolved + SGS), spin-up"),
    "tke": ("m2 s-2", "turbulent kinetic energy (resolved + SGS), with grains"),
    "tke_resolved": ("m2 s-2", "resolved turbulent kinetic energy 0.5<u_i'u_i'>, with grains"),
    "tke_spinup": ("m2 s-2", "turbulent kinetic energy (resolved + SGS), spin-up"),
    "tau_p": ("Pa", "grain momentum flux (eq. 10), positive downward"),
    "G": ("kg m-2 s-1", "horizontal mass flux density (eq. 11), horizontally and time averaged"),
    "R_cu": ("1", "zero-lag correlation of C_p and u(z) (eq. 12), with the paper's parcel-count noise"),
    "St": ("1", "Stokes number T_p / T_eps"),
    "T_p": ("s", "response time of the mass-weighted mean grain diameter at that level"),
    "T_eps": ("s", "lifetime of the resolved eddies 0.5<u_i'^2>/eps_tot"),
    "eps_tot": ("m2 s-3", "dissipation of resolved TKE by grain drag and SGS transfer (eq. 13)"),
    "eps_drag": ("m2 s-3", "dissipation of resolved TKE by grain drag (first term of eq. 13)"),
    "eps_sgs": ("m2 s-3", "transfer of resolved fluctuation energy to the SGS (second term of eq. 13)"),
    "d_mass_mean": ("m", "mass-weighted mean grain diameter at that level"),
    # series
    "n_parcels": ("1", "number of parcels in the domain"),
    "G_tot_series": ("kg m-1 s-1", "instantaneous total horizontal mass flux"),
    "u_star_ref": ("m s-1", "friction velocity at the reference height (solver record)"),
    "G_tot_sample": ("kg m-1 s-1", "total horizontal mass flux at each 3-D sample"),
    "C_p_mean": ("m-2", "domain-mean C_p of each plane"),
    # spectra, correlations, distributions, snapshots
    "S_c": ("m-3", "spanwise spectral density of C_p, averaged over time and streamwise wavenumbers, "
            "with the paper's parcel-count noise"),
    "S_c_stderr": ("m-3", "standard error of S_c from contiguous time blocks"),
    "S_u": ("m3 s-2", "spanwise spectral density of u at the 0.1 m plane, averaged over time and streamwise wavenumbers"),
    "S_u_stderr": ("m3 s-2", "standard error of S_u from contiguous time blocks"),
    "C_p_autocorr": ("1", "time-averaged spatial autocorrelation of C_p, with the paper's "
                     "parcel-count noise"),
    "C_p_st_peak": ("1", "peak over spatial lags of the correlation of C_p(t) and C_p(t + lag_t)"),
    "C_p_st_x": ("m", "streamwise position of that peak"),
    "C_p_st_y": ("m", "spanwise position of that peak"),
    "psd_air": ("1", "mass fraction per diameter bin of airborne grains in each height band"),
    "psd_bed": ("1", "mass fraction per diameter bin of the bed (soil distribution)"),
    "z_band_edges": ("m", "edges of the height bands"),
    "d_edges": ("m", "edges of the diameter bins"),
    "C_p_snapshot": ("m-2", "C_p of the last plane"),
    "u_snapshot": ("m s-1", "u at the 0.1 m plane of the last plane"),
    "R_cu_lag": ("1", "correlation of C_p(t) with the past wind u(t - lag_t) at the plane heights"),
}

#: variables of analysis.nc the contract (ARCHITECTURE.md) requires
REQUIRED_VARIABLES = (
    "u_star_s", "z0s", "u_star_0", "z0_0", "z_m", "z_m_flux995", "G_tot", "sigma_G",
    "sigma_G_over_G_tot", "lambda_x", "lambda_y", "delta_y", "delta_y_u", "u_star_t",
    "tau_p_surface_fraction", "R_cu_upper", "n_parcels_mean", "n_parcels_peak", "overshoot_ratio",
    "t_equilibrium", "streamer_lifetime", "streamer_speed", "E_splash_over_E_impact", "fit_z_min",
    "fit_z_max", "u_mean", "u_mean_spinup", "uw_flux", "uw_flux_spinup", "tke", "tau_p", "G",
    "R_cu", "St", "T_p", "T_eps", "eps_tot", "n_parcels", "G_tot_series", "S_c", "S_u",
    "C_p_autocorr", "psd_air", "psd_bed", "C_p_snapshot", "u_snapshot", "R_cu_lag", "z_band_edges",
)
REQUIRED_COORDS = ("z", "time", "time_sample", "time_plane", "ky", "lag_x", "lag_y", "lag_t",
                   "z_plane", "d_bin", "z_band", "x", "y")

SAMPLE_VARIABLES_USED = (
    "u", "C_p_s", "uw_res", "uw_sgs", "u_mean", "tke_res", "e_sgs", "sgs_transfer", "pm", "pmu",
    "pmw", "pmuw", "pdrag", "pmuf_up", "pmuf", "size_hist", "d_edges", "C_p", "G_col", "u_plane",
    "n_parcels", "G_tot_series", "u_star_ref", "E_impact", "E_splash", "pn", "impact_hist",
    "impact_outcomes", "hop_time_hist", "hop_length_hist", "bed_px", "bed_pz", "C_p_above",
)


# ------------------------------------------------------------------------------------------
# reading
# ------------------------------------------------------------------------------------------
#: large variables read slice by slice (a 3-D sample, a plane height, a block of planes) rather
#: than whole: at the paper's fidelity u_plane alone is several GB
LAZY_VARIABLES = ("u", "G_col", "u_plane")
PLANE_CHUNK = 256


class _LazyVar:
    """A variable of an archive whose slices are read on indexing (each read under NC_LOCK)."""

    def __init__(self, path: str | Path, name: str, shape: tuple[int, ...]):
        self.path, self.name, self.shape = str(path), name, tuple(shape)

    @property
    def ndim(self) -> int:
        return len(self.shape)

    def __getitem__(self, key) -> np.ndarray:
        with NC_LOCK:
            with xr.open_dataset(self.path, engine="netcdf4") as ds:
                return np.asarray(ds[self.name][key].values)


def _read(path: str | Path, keep: tuple[str, ...] | None,
          lazy: tuple[str, ...] = ()) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any]]:
    """(attrs, coords, variables) of an archive, reading only ``keep`` variables (all if None);
    the ``lazy`` ones become :class:`_LazyVar` handles."""
    with NC_LOCK:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            attrs = dict(ds.attrs)
            coords = {k: np.asarray(ds[k].values) for k in ds.coords}
            names = [v for v in ds.data_vars if keep is None or v in keep]
            data: dict[str, Any] = {}
            for v in names:
                if v in lazy:
                    data[v] = _LazyVar(path, v, ds[v].shape)
                else:
                    data[v] = np.asarray(ds[v].values)
    return attrs, coords, data


def _f(attrs: dict[str, Any], key: str, default: float = math.nan) -> float:
    try:
        return float(attrs[key])
    except (KeyError, TypeError, ValueError):
        return default


def _case_info(attrs: dict[str, Any]) -> dict[str, Any]:
    """Pieces of the resolved scene (global attribute ``case_json``) the analysis needs."""
    try:
        scene = json.loads(attrs.get("case_json", "{}") or "{}")
    except (TypeError, ValueError):
        scene = {}
    case = scene.get("case", scene) if isinstance(scene, dict) else {}
    fid = scene.get("fidelity", {}) if isinstance(scene, dict) else {}
    grid = fid.get("grid", {}) if isinstance(fid, dict) else {}
    Lz = _f(attrs, "Lz", float(grid.get("Lz", math.nan)))
    damping = grid.get("damping_depth")
    if damping is None:
        damping = _f(attrs, "damping_depth", min(3.0, 0.5 * Lz) if math.isfinite(Lz) else 0.0)
    forcing = case.get("forcing", {}) if isinstance(case, dict) else {}
    drive = str(forcing.get("drive", "top"))
    if drive == "pressure_gradient":
        damping = 0.0  # the model builds no damping layer with this drive
    return {
        "Lz": Lz,
        "drive": drive,
        # the pressure-gradient drive's stress falls linearly to the lid at Lz: fits use that shape
        "H": Lz if drive == "pressure_gradient" and math.isfinite(Lz) else None,
        "damping_depth": float(damping),
        "z_ref": float(forcing.get("z_ref", 2.0)),
        "soil": case.get("soil") if isinstance(case, dict) else None,
        "threshold": case.get("threshold", {}) if isinstance(case, dict) else {},
        "air": case.get("air", {}) if isinstance(case, dict) else {},
        # parcels are q_multiplier x heavier than the case's Q (a cost knob); 1 when unknown
        "q_multiplier": float(fid.get("q_multiplier", 1.0)) if isinstance(fid, dict) else 1.0,
        "Q_case": _f(case.get("particles", {}) if isinstance(case, dict) else {}, "Q"),
    }


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


def _tmean(a: np.ndarray | None, n: int) -> np.ndarray:
    """Time mean over axis 0 (NaN-aware); NaN of length n if absent or empty."""
    if a is None or a.ndim < 1 or a.shape[0] == 0:
        return np.full(n, np.nan)
    a = np.asarray(a, dtype=np.float64)
    if not np.any(np.isfinite(a)):
        return np.full(a.shape[1:], np.nan)
    with np.errstate(invalid="ignore"):
        return np.nanmean(a, axis=0)


def _check_parcel_counts(planes, grains_per_parcel: float, area: float) -> None:
    """Warn when C_p dx dy / w is not a whole number of parcels: samples.nc stores C_p, not the
    counts, and the Poisson noise is derived from them with this parcel weight."""
    if not (grains_per_parcel > 0 and area > 0) or len(planes) == 0:
        return
    n = np.asarray(planes[-1], dtype=np.float64) * area / grains_per_parcel
    off = np.abs(n - np.rint(n))
    if np.any(off > 1e-6 * np.maximum(1.0, np.abs(n))):
        log.warning("C_p dx dy / Q is not a whole number of parcels (largest remainder %.3g): "
                    "the parcel-count noise assumes parcels of %g grains", float(off.max()),
                    grains_per_parcel)


def _tsum(a: np.ndarray | None, n: int) -> np.ndarray:
    if a is None or a.ndim < 2:
        return np.zeros(n)
    return np.nansum(np.asarray(a, dtype=np.float64), axis=0)


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


#: statistics also computed over each half of the sampling window: their difference is the
#: noise of one window (a difference between runs smaller than it is not a result)
HALF_STATISTICS = ("u_star_s", "u_star_s_stress", "z0s", "z0s_stress", "z_m", "G_tot",
                   "G_decay_height", "sigma_G_over_G_tot", "tau_p_surface_fraction", "lambda_x",
                   "lambda_y", "delta_y", "R_cu_upper")
_PLANE_VARIABLES = ("C_p", "G_col", "u_plane")
_SERIES_VARIABLES = ("n_parcels", "G_tot_series", "u_star_ref", "E_impact", "E_splash")
_WHOLE_VARIABLES = ("d_edges",)


class _Rows:
    """Rows ``start:stop`` of an array or a lazy variable (first axis), indexed like a whole one."""

    def __init__(self, base, start: int, stop: int):
        self.base, self.start, self.stop = base, int(start), int(stop)
        self.shape = (self.stop - self.start,) + tuple(base.shape[1:])

    @property
    def ndim(self) -> int:
        return len(self.shape)

    def __getitem__(self, key):
        k0, rest = (key[0], key[1:]) if isinstance(key, tuple) else (key, ())
        n = self.shape[0]
        if isinstance(k0, slice):
            a, b, st = k0.indices(n)
            k0 = slice(self.start + a, self.start + b, st)
        elif isinstance(k0, (int, np.integer)):
            k0 = self.start + int(k0) % n
        else:
            arr = np.asarray(k0)
            if arr.dtype == bool:
                arr = np.flatnonzero(arr)
            k0 = self.start + np.mod(arr, n)
        return self.base[(k0,) + rest]


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


def rescale_spinup_profiles(sp: dict[str, Any], a: float) -> dict[str, Any]:
    """Spin-up profiles at the case's u*s from a spin-up shared by similarity at u*s / ``a``
    (``solver.similarity``): the mean wind times a, the stresses and TKE times a^2. A NaN factor
    (an archive without ``u_star_target``) leaves them as they are."""
    if not math.isfinite(a) or a == 1.0:
        return sp
    power = {"u_mean": 1, "uw_res": 2, "uw_sgs": 2, "tke_res": 2, "e_sgs": 2}
    return {k: np.asarray(v, dtype=np.float64) * a ** power[k] if k in power else v
            for k, v in sp.items()}


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
