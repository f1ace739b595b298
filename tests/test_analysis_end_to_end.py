"""analyse_case on schema-complete synthetic archives (tests/analysis_fixtures.py)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from typer.testing import CliRunner

try:
    from analysis_fixtures import build_archives
except ImportError:  # tests run as a package
    from tests.analysis_fixtures import build_archives

from saltstudy.analysis.analyse import analyse_case
from saltstudy.ncio import is_complete, open_dataset

# docs/ARCHITECTURE.md, "analysis.nc": written out here (not imported) so that the code's own
# list cannot drift unnoticed.
CONTRACT_COORDS = ["z", "time", "time_sample", "time_plane", "ky", "lag_x", "lag_y", "lag_t",
                   "z_plane", "d_bin", "z_band", "x", "y"]
CONTRACT_SCALARS = [
    "u_star_s", "z0s", "u_star_0", "z0_0", "z_m", "z_m_flux995", "G_tot", "sigma_G",
    "sigma_G_over_G_tot", "lambda_x", "lambda_y", "delta_y", "delta_y_u", "u_star_t",
    "tau_p_surface_fraction", "R_cu_upper", "n_parcels_mean", "n_parcels_peak", "overshoot_ratio",
    "t_equilibrium", "streamer_lifetime", "streamer_speed", "E_splash_over_E_impact",
    "fit_z_min", "fit_z_max"]
CONTRACT_ARRAYS = {
    **{k: ("z",) for k in ("u_mean", "u_mean_spinup", "uw_flux", "uw_flux_spinup", "tke", "tau_p",
                           "G", "R_cu", "St", "T_p", "T_eps", "eps_tot")},
    "n_parcels": ("time",), "G_tot_series": ("time",), "S_c": ("ky",), "S_u": ("ky",),
    "C_p_autocorr": ("lag_x", "lag_y"), "psd_air": ("z_band", "d_bin"), "psd_bed": ("d_bin",),
    "C_p_snapshot": ("x", "y"), "u_snapshot": ("x", "y"), "R_cu_lag": ("lag_t", "z_plane"),
}


def check_contract(ds):
    for c in CONTRACT_COORDS:
        assert c in ds.coords and ds[c].dims == (c,), c
    for v in CONTRACT_SCALARS:
        assert v in ds.data_vars and ds[v].dims == (), v
    for v, dims in CONTRACT_ARRAYS.items():
        assert v in ds.data_vars and ds[v].dims == dims, (v, ds[v].dims if v in ds else None)
    assert "z_band_edges" in ds
    for name in ds.variables:
        assert ds[name].attrs.get("units"), f"{name} lacks units"
        assert ds[name].attrs.get("long_name"), f"{name} lacks long_name"
    for a in ("case_json", "package_version", "fidelity", "seed", "label", "case_number", "Lx", "Ly",
              "Lz", "dx", "dy", "Q", "rho", "rho_p", "nu", "g", "kappa", "z0", "u_star_target",
              "t_activation", "wall_time_s"):
        assert a in ds.attrs, a


def test_end_to_end_schema_and_known_answers(tmp_path):
    samples, spinup, truth = build_archives(tmp_path)
    out = analyse_case(samples, spinup, tmp_path / "analysis.nc", wall_time_s=42.0)
    assert is_complete(out)
    ds = open_dataset(out)
    check_contract(ds)
    assert ds.attrs["wall_time_s"] == 42.0
    assert float(ds.u_star_s) == pytest.approx(truth["u_star_s"], rel=1e-6)
    assert float(ds.z0s) == pytest.approx(truth["z0s"], rel=1e-5)
    assert float(ds.u_star_0) == pytest.approx(truth["u_star_0"], rel=1e-6)
    assert float(ds.z0_0) == pytest.approx(truth["z0_0"], rel=1e-5)
    assert np.allclose(ds.tau_p.values, truth["tau_p"], rtol=1e-9, atol=1e-15)
    assert float(ds.G_tot) == pytest.approx(truth["G_tot"], rel=1e-9)
    assert float(ds.z_m) == pytest.approx(truth["z_m"], rel=1e-9)
    assert float(ds.sigma_G) == pytest.approx(truth["sigma_G"], rel=0.05)
    assert float(ds.n_parcels_peak) == truth["n_parcels_peak"]
    assert float(ds.n_parcels_mean) == pytest.approx(truth["n_parcels_mean"], rel=0.01)
    # the grain mass over the bed: the column integral of the layers' mass density
    assert float(ds.airborne_mass_per_m2) == pytest.approx(truth["airborne_mass_per_m2"], rel=1e-9)
    assert ds.airborne_mass_per_m2.attrs["units"] == "kg m-2"
    assert float(ds.E_splash_over_E_impact) == pytest.approx(0.6)
    assert float(ds.delta_y) == pytest.approx(truth["streak_spacing"], abs=float(ds.attrs["dy"]))
    # delta_y[_u] is the premultiplied reading, each reading under its own name too
    # (docs/STREAMERS.md)
    for field in ("delta_y", "delta_y_u"):
        assert float(ds[field]) == float(ds[f"{field}_premultiplied"]), field
        for reading in ("premultiplied", "density", "correlation"):
            assert ds[f"{field}_{reading}"].dims == () and ds[f"{field}_{reading}"].attrs["units"] == "m"
    assert float(ds.delta_y_density) == pytest.approx(truth["streak_spacing"],
                                                      abs=float(ds.attrs["dy"]))
    assert float(ds.streamer_speed) == pytest.approx(truth["streak_speed"], rel=0.02)
    eps = truth["eps_sgs"] + truth["eps_drag"]
    assert np.allclose(ds.eps_tot.values, eps, rtol=1e-9)
    assert np.allclose(ds.T_p.values[:3], truth["T_p"], rtol=0.02)
    for v in ("lambda_x", "lambda_y", "u_star_t", "R_cu_upper", "overshoot_ratio", "t_equilibrium"):
        assert math.isfinite(float(ds[v])), v
    assert np.nansum(ds.psd_bed.values) == pytest.approx(1.0)
    assert np.nansum(ds.psd_air.values[0]) == pytest.approx(1.0)
    # tau_p at the bed over the stress reading, and the same share from the wall stress
    assert float(ds.tau_p_surface_fraction) == pytest.approx(truth["tau_p_surface_fraction"], rel=1e-3)
    assert float(ds.tau_p_surface_fraction_budget) == pytest.approx(truth["tau_p_surface_fraction"])
    assert float(ds.tau_p_paper_cell_fraction) < float(ds.tau_p_surface_fraction)


def test_streamer_noise_uses_the_archive_parcel_weight_and_the_paper_columns(tmp_path):
    """C_p is stored as whole parcels of Q grains: the analysis recovers the counts per column,
    their Poisson noise, and the streamer core of the noiseless pattern."""
    samples, spinup, truth = build_archives(tmp_path)
    ds = open_dataset(analyse_case(samples, spinup, tmp_path / "analysis.nc"))
    with open_dataset(samples) as s:
        C = s.C_p.values[s.time_plane.values >= s.time.values[0] - 1e-9]
        Q, dx, dy = float(s.attrs["Q"]), float(s.attrs["dx"]), float(s.attrs["dy"])
    assert np.allclose(C * dx * dy / Q, np.rint(C * dx * dy / Q))       # whole parcels
    assert float(ds.C_p_parcels_per_column) == pytest.approx(C.mean() * dx * dy / Q)
    assert float(ds.C_p_parcels_per_column_paper) == pytest.approx(C.mean() * 0.01 / Q)
    noise = C.mean(axis=(1, 2)) * Q / (dx * dy)
    assert float(ds.C_p_noise_fraction) == pytest.approx(np.mean(noise / C.var(axis=(1, 2))))
    for v in ("lambda_x", "lambda_y"):
        d = dx if v == "lambda_x" else dy
        assert float(ds[v + "_noise_free"]) == pytest.approx(truth[v + "_noise_free"], abs=0.5 * d)
        # the fixture's columns are twice the paper's at the same Q: fewer parcels' noise in the
        # run than the paper's, so the paper-level value lies below the raw one
        assert float(ds[v]) < float(ds[v + "_raw"]) < float(ds[v + "_noise_free"])
    assert 0.5 < float(ds.C_p_small_scale_over_poisson) < 1.5


@pytest.mark.parametrize("kwargs", [
    dict(grains=False),
    dict(n_samples=1),
    dict(nx=4, ny=4, nz=4, Lz=1.0, damping=0.3, n_samples=1, plane_interval=5.0),
    dict(full_fields=False),
])
def test_degenerate_archives_give_nan_not_errors(tmp_path, kwargs):
    samples, spinup, _ = build_archives(tmp_path, **kwargs)
    ds = open_dataset(analyse_case(samples, spinup, tmp_path / "analysis.nc"))
    check_contract(ds)
    if kwargs.get("grains") is False:
        for v in ("z_m", "lambda_x", "lambda_y", "delta_y", "R_cu_upper", "overshoot_ratio",
                  "streamer_speed", "sigma_G_over_G_tot"):
            assert math.isnan(float(ds[v])), v
        assert float(ds.G_tot) == 0.0
        assert np.all(np.isnan(ds.St.values))
    if kwargs.get("full_fields") is False:
        assert np.all(np.isnan(ds.R_cu.values))


def test_missing_spinup_gives_nan_spinup_values(tmp_path):
    samples, _, _ = build_archives(tmp_path)
    ds = open_dataset(analyse_case(samples, None, tmp_path / "analysis.nc"))
    assert math.isnan(float(ds.u_star_0)) and np.all(np.isnan(ds.u_mean_spinup.values))
    assert math.isfinite(float(ds.u_star_s))


def test_cli_analyse(tmp_path):
    from saltstudy.cli import app
    samples, spinup, _ = build_archives(tmp_path)
    runner = CliRunner()
    res = runner.invoke(app, ["analyse", "--samples", str(samples), "--spinup", str(spinup),
                              "--out", str(tmp_path / "a.nc")])
    assert res.exit_code == 0, res.output
    assert "u_star_s = 0.5" in res.output
    assert is_complete(tmp_path / "a.nc")
    res = runner.invoke(app, ["analyse", str(tmp_path)])
    assert res.exit_code == 0 and (tmp_path / "analysis.nc").is_file()
    res = runner.invoke(app, ["analyse", "--samples", str(tmp_path / "nope.nc")])
    assert res.exit_code == 2


def test_pressure_gradient_drive_fits_the_linear_stress_profile(tmp_path):
    """With the pressure-gradient drive the stress falls linearly to the lid: the analysis fits
    that profile (lower third of the domain) and recovers the surface u*_0 and z0, where the plain
    log law would not."""
    samples, spinup, truth = build_archives(tmp_path, drive="pressure_gradient", Lz=6.0, nz=24)
    ds = open_dataset(analyse_case(samples, spinup, tmp_path / "analysis.nc"))
    assert float(ds.u_star_s) == pytest.approx(truth["u_star_s"], rel=1e-6)
    assert float(ds.z0s) == pytest.approx(truth["z0s"], rel=1e-5)
    assert float(ds.u_star_0) == pytest.approx(truth["u_star_0"], rel=1e-6)
    assert float(ds.z0_0) == pytest.approx(truth["z0_0"], rel=1e-5)
    assert float(ds.fit_z_max) == pytest.approx(2.0)
    from saltstudy.analysis.profiles import log_law_fit
    plain = log_law_fit(ds.z.values, ds.u_mean.values, float(ds.fit_z_min), 2.0, 0.4)
    assert plain.u_star < 0.95 * truth["u_star_s"]


def test_u_star_s_standard_error_from_per_sample_fits(tmp_path):
    # three samples whose profiles are exact log laws with u* 0.45, 0.50, 0.55 (same z0s): the fit
    # of the mean profile is 0.50 and the per-sample fits recover each u*_i
    import xarray as xr
    samples, spinup, truth = build_archives(tmp_path, n_samples=3)
    u_i = truth["u_star_s"] * np.array([0.9, 1.0, 1.1])
    with xr.open_dataset(samples) as ds:
        ds = ds.load()
    z = ds["z"].values
    prof = np.array([(u / 0.40) * np.log(z / truth["z0s"]) for u in u_i])
    ds["u_mean"] = (("time", "z"), prof, ds["u_mean"].attrs)
    edited = tmp_path / "edited.nc"
    ds.to_netcdf(edited)
    out = open_dataset(analyse_case(edited, spinup, tmp_path / "analysis.nc"))
    assert float(out.u_star_s) == pytest.approx(truth["u_star_s"], rel=1e-6)
    assert np.allclose(out.u_star_s_samples.values, u_i, rtol=1e-6)
    assert float(out.u_star_s_se) == pytest.approx(np.std(u_i, ddof=1) / math.sqrt(3), rel=1e-6)
    assert out.u_star_s_se.attrs["units"] == "m s-1"


def test_half_window_statistics_of_a_stationary_archive(tmp_path):
    """A stationary synthetic run: each half of the window gives the whole window's u*s, z_m and
    G_tot (its fields do not change in time), with units; fewer than four samples give none."""
    samples, spinup, _ = build_archives(tmp_path, n_samples=6)
    ds = open_dataset(analyse_case(samples, spinup, tmp_path / "analysis.nc"))
    for name in ("u_star_s_stress", "z_m", "G_tot"):
        h = ds[f"{name}_halves"]
        assert h.dims == ("half",) and h.size == 2 and h.attrs["units"] == ds[name].attrs["units"]
        assert np.allclose(h.values, float(ds[name]), rtol=1e-6), name
    few_s, few_sp, _ = build_archives(tmp_path / "few", n_samples=3)
    few = open_dataset(analyse_case(few_s, few_sp, tmp_path / "few.nc"))
    assert "z_m_halves" not in few.variables


def test_a_half_window_cuts_each_record_along_its_own_time_axis():
    """13 samples, 301 planes, 841 series records: a record not in the known lists is placed by
    the length of its first axis; one matching two axes is taken as samples."""
    from saltstudy.analysis.analyse import half_kind
    n = dict(n_sample=13, n_plane=301, n_series=841)
    assert half_kind("bed_px", np.zeros(841), **n) == "series"
    assert half_kind("C_p_above", np.zeros((301, 4, 4)), **n) == "plane"
    assert half_kind("new_series", np.zeros(841), **n) == "series"
    assert half_kind("new_planes", np.zeros((301, 4)), **n) == "plane"
    assert half_kind("new_profile", np.zeros((13, 54)), **n) == "sample"
    assert half_kind("edges", np.zeros(25), **n) == "whole"
    assert half_kind("both", np.zeros(13), n_sample=13, n_plane=13, n_series=841) == "sample"
