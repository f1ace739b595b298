"""The contract of ``analysis.nc`` (docs/ARCHITECTURE.md): ``SPEC``, each variable's and
coordinate's ``(units, long_name)``, from which :func:`to_dataset` takes them (a variable missing
from it cannot be written); ``SAMPLE_VARIABLES_USED``, the samples.nc variables read;
``HALF_STATISTICS``, also written over each half of the sampling window.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

__all__ = ["SPEC", "SAMPLE_VARIABLES_USED", "MAX_LAG_S", "U_PLANE_HEIGHT", "HALF_STATISTICS",
           "Variables", "to_dataset"]

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

#: the variables of samples.nc the analysis reads (the others are never loaded)
SAMPLE_VARIABLES_USED = (
    "u", "C_p_s", "uw_res", "uw_sgs", "u_mean", "tke_res", "e_sgs", "sgs_transfer", "pm", "pmu",
    "pmw", "pmuw", "pdrag", "pmuf_up", "pmuf", "size_hist", "d_edges", "C_p", "G_col", "u_plane",
    "n_parcels", "G_tot_series", "u_star_ref", "E_impact", "E_splash", "pn", "impact_hist",
    "impact_outcomes", "hop_time_hist", "hop_length_hist", "bed_px", "bed_pz", "C_p_above",
)

#: statistics also computed over each half of the sampling window: their difference is the
#: noise of one window (a difference between runs smaller than it is not a result)
HALF_STATISTICS = ("u_star_s", "u_star_s_stress", "z0s", "z0s_stress", "z_m", "G_tot",
                   "G_decay_height", "sigma_G_over_G_tot", "tau_p_surface_fraction", "lambda_x",
                   "lambda_y", "delta_y", "R_cu_upper")


class Variables(dict):
    """Variables of analysis.nc, in the order they are put: name -> (dims, float64 values,
    extra attributes beside the units and long name)."""

    def put(self, name: str, dims: tuple[str, ...], data, **extra) -> None:
        self[name] = (dims, np.asarray(data, dtype=np.float64), extra)

    def merge(self, other: dict) -> None:
        """Add another statistic's variables; a name two statistics both write is an error
        (one would silently replace the other)."""
        twice = sorted(set(self) & set(other))
        if twice:
            raise ValueError(f"analysis variables written twice: {', '.join(twice)}")
        self.update(other)


def to_dataset(coords: dict[str, Any], variables: dict[str, tuple[tuple[str, ...], Any, dict]]
               ) -> xr.Dataset:
    """The Dataset of ``coords`` (name -> values) and ``variables`` (:class:`Variables`), each
    with the units and long name of ``SPEC``."""
    out = xr.Dataset()
    for name, val in coords.items():
        units, long_name = SPEC[name]
        out = out.assign_coords({name: (name, np.asarray(val, dtype=np.float64),
                                        {"units": units, "long_name": long_name})})
    for name, (dims, data, extra) in variables.items():
        units, long_name = SPEC[name]
        out[name] = xr.DataArray(data, dims=dims, attrs={"units": units, "long_name": long_name, **extra})
    return out
