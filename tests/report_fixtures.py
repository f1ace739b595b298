"""Minimal synthetic ``analysis.nc`` archives for the report tests.

The archives follow the schema of docs/ARCHITECTURE.md ("analysis.nc"). Their numbers are
plausible, not physical: profiles have the right shapes (exponential tau_p and G, log-law wind,
a streaky C_p field) so that the figures are readable, and each case differs from the others.
They are deliberately *not* equal to the paper's values (a scale factor ``bias`` is applied), so
a test comparing "computed" with "paper" exercises a non-zero difference.

The report tests build their archives here, apart from the analysis's own fixtures
(tests/analysis_fixtures.py), so they need only xarray and numpy, not the analysis.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import xarray as xr

from saltstudy.ncio import write_dataset

#: (u*s [m/s], u*t [m/s], mu1 [m], Q) per case: the case definitions (cases/caseNN.toml inputs)
CASES = {
    1: (0.41, 0.26, 200e-6, 200), 2: (0.54, 0.26, 200e-6, 600), 3: (0.65, 0.26, 200e-6, 1000),
    4: (0.75, 0.26, 200e-6, 1400), 5: (0.93, 0.26, 200e-6, 3000), 6: (1.10, 0.26, 200e-6, 4500),
    7: (0.57, 0.24, 90e-6, 28000), 8: (0.53, 0.24, 100e-6, 15000), 9: (0.54, 0.29, 300e-6, 200),
    10: (0.54, 0.33, 400e-6, 50),
}

RHO, RHO_P, NU, G, KAPPA, Z0 = 1.2, 2650.0, 1.5e-5, 9.81, 0.40, 1e-5


def _levels(nz: int = 40, lz: float = 6.0, dz0: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    k = np.arange(nz + 1, dtype=float)
    a = (lz - dz0 * nz) / nz ** 3
    zw = dz0 * k + a * k ** 3
    return 0.5 * (zw[1:] + zw[:-1]), zw


def make_analysis_dataset(case: int, *, bias: float = 1.07, seed: int | None = None,
                          fidelity: str = "reduced", label: str | None = None,
                          wall_time_s: float = 120.0, lx: float = 10.0, ly: float = 7.5,
                          lz: float = 6.0, damping_depth: float = 1.5, nx: int = 48, ny: int = 36,
                          nz: int = 40, with_cp_stack: bool = False) -> xr.Dataset:
    """One synthetic analysis archive for case ``case`` (1-10)."""
    us_in, ut, mu1, q = CASES[case]
    rng = np.random.default_rng(case if seed is None else seed)
    us = us_in * bias
    ratio = us / ut
    z, zw = _levels(nz, lz)
    # saltation layer height: linear in u*s (cases 1-6), smaller for fine sand
    zm = (0.2 + 0.45 * (us - 0.41)) * (0.7 if mu1 <= 100e-6 else 1.0) * bias
    z0s = 0.002 * (us ** 2 / G) * ratio ** 1.5
    # tau_p: exponential, reaching 0.1 % of rho u*s^2 at z_m
    f0 = min(0.95, 0.12 * ratio)
    ell = zm / np.log(f0 / 1e-3)
    tau_p = RHO * us ** 2 * f0 * np.exp(-z / ell)
    g_tot = 1.1 * np.sqrt(mu1 / 250e-6) * RHO * us ** 3 / G * (1 - 1 / ratio ** 2) * bias
    ell_g = zm / 5.0
    g_prof = g_tot / ell_g * np.exp(-z / ell_g)
    zeta = z / zm
    r_cu = -0.2 * np.exp(-zeta / 0.03) + 0.5 * zeta / 0.15 * np.exp(1 - zeta / 0.15) * 0.6 \
        + 0.3 * (1 - np.exp(-zeta / 0.4))
    t_p = RHO_P * mu1 ** 2 / (18 * RHO * NU)
    t_eps = 0.02 + 0.5 * z
    st = t_p / t_eps * np.exp(-zeta / 0.05) * 5 + 0.1
    u_mean = us / KAPPA * np.log(np.maximum(z, 1.5 * z0s) / z0s)
    u0 = 0.9 * us
    u_spin = u0 / KAPPA * np.log(z / Z0)
    uw = -us ** 2 * np.ones_like(z) * (1 - 0.3 * np.exp(-z / zm))
    uw0 = -u0 ** 2 * np.ones_like(z) * (1 - 0.2 * np.exp(-z / 0.05))

    # series: overshoot then equilibrium
    t = np.arange(0.0, 90.0, 0.5)
    area = lx * ly
    n_eq = 6e5 * area / 300.0 / 4.0 * (us / 0.54) ** 2
    n_par = n_eq * (1 + 1.5 * (t / 5) * np.exp(1 - t / 5)) + 0.03 * n_eq * rng.standard_normal(t.size)
    n_par[0] = 10000 * area / 300 / 4
    gser = g_tot * (1 + 0.12 * rng.standard_normal(t.size))
    sigma_g = float(np.std(gser[t > 30]))

    # spanwise spectra with peaks at 1/delta_y
    dy_c = {1: 0.70, 2: 0.65, 3: 0.60, 4: 0.50, 5: 0.40, 6: 0.40, 7: 0.40, 8: 0.50}.get(case, 1.5) * bias
    ky = np.arange(1, ny // 2 + 1) / ly
    s_c = np.exp(-0.5 * ((np.log(ky) - np.log(1 / dy_c)) / 0.3) ** 2) / ky + 0.05
    s_u = np.exp(-0.5 * ((np.log(ky) - np.log(1 / (0.9 * dy_c))) / 0.35) ** 2) / ky + 0.08

    # streaky snapshots
    x = (np.arange(nx) + 0.5) * lx / nx
    y = (np.arange(ny) + 0.5) * ly / ny
    X, Y = np.meshgrid(x, y, indexing="ij")
    phase = rng.uniform(0, 2 * np.pi, 3)
    streak = sum(np.cos(2 * np.pi * Y / dy_c + p + 0.3 * np.sin(2 * np.pi * X / lx * (j + 1)))
                 for j, p in enumerate(phase))
    noise = rng.standard_normal((nx, ny))
    cp = np.maximum(0.0, 1e6 * q / 600 * (streak + 0.5 * noise + 1.0))
    u_snap = u_mean[np.searchsorted(z, 0.1)] * (1 + 0.1 * streak / 3 + 0.05 * noise)

    lag_x = np.arange(nx // 2) * lx / nx
    lag_y = np.arange(ny // 2) * ly / ny
    LX, LY = np.meshgrid(lag_x, lag_y, indexing="ij")
    autocorr = np.exp(-LX / (2.0 * bias) - (LY / 0.3) ** 2)

    d_edges = np.geomspace(mu1 / 2.5, mu1 * 2.5, 21)
    d_bin = np.sqrt(d_edges[1:] * d_edges[:-1])
    z_band_edges = np.array([0.0, 0.05, 0.1, 0.2, 0.4])
    z_band = 0.5 * (z_band_edges[1:] + z_band_edges[:-1])
    logd = np.log(d_bin)
    bed = np.exp(-0.5 * ((logd - np.log(mu1)) / np.log(1.2)) ** 2)
    bed /= bed.sum()
    shift = np.where(mu1 < 150e-6, -0.04, 0.04) * np.arange(z_band.size)[:, None] / 3
    air = np.exp(-0.5 * ((logd[None, :] - np.log(mu1) - shift) / np.log(1.2)) ** 2)
    air /= air.sum(axis=1, keepdims=True)

    lag_t = np.arange(-2.0, 2.01, 0.5)
    z_plane = np.array([0.02, 0.05, 0.1, 0.2, 0.4])
    r_lag = 0.3 * np.exp(-(lag_t[:, None] - 0.3) ** 2) * np.ones(z_plane.size)[None, :]

    scene = {"label": label or f"case{case:02d}",
             "case": {"number": case, "forcing": {"u_star_s": us_in, "z_ref": 2.0},
                      "soil": {"modes": [{"mass_fraction": 1.0, "mu": mu1, "sigma": 1.2}],
                               "rho_p": RHO_P},
                      "particles": {"Q": q}},
             "fidelity": {"name": fidelity, "q_multiplier": 4.0,
                          "grid": {"Lx": lx, "Ly": ly, "Lz": lz, "nx": nx,
                                                     "ny": ny, "nz": nz,
                                                     "damping_depth": damping_depth}}}
    sc = {
        "u_star_s": (us, "m s-1"), "z0s": (z0s, "m"), "u_star_0": (u0, "m s-1"), "z0_0": (Z0, "m"),
        "z_m": (zm, "m"), "z_m_flux995": (0.95 * zm, "m"), "G_tot": (g_tot, "kg m-1 s-1"),
        "sigma_G": (sigma_g, "kg m-1 s-1"), "sigma_G_over_G_tot": (sigma_g / g_tot, "1"),
        "lambda_x": ({1: 2.7, 2: 2.3, 3: 1.9, 4: 2.2, 5: 1.9, 6: 0.9, 7: 0.3, 8: 0.3, 9: 3.4,
                      10: 6.0}[case] * bias, "m"),
        "lambda_y": ({1: .4, 2: .3, 3: .4, 4: .4, 5: .3, 6: .3, 7: .2, 8: .2, 9: .4, 10: 2.1}[case]
                     * bias, "m"),
        "delta_y": (dy_c if case <= 8 else np.nan, "m"), "delta_y_u": (0.9 * dy_c, "m"),
        "delta_y_premultiplied": (dy_c if case <= 8 else np.nan, "m"),
        "delta_y_density": (1.1 * dy_c if case <= 8 else np.nan, "m"),
        "delta_y_correlation": (1.2 * dy_c, "m"), "delta_y_u_premultiplied": (0.9 * dy_c, "m"),
        "delta_y_u_density": (np.nan, "m"), "delta_y_u_correlation": (1.1 * dy_c, "m"),
        "u_star_t": (ut, "m s-1"), "tau_p_surface_fraction": (float(tau_p[0] / (RHO * us ** 2)), "1"),
        "R_cu_upper": (float(r_cu[zeta >= 0.6][zeta[zeta >= 0.6] <= 1].mean()), "1"),
        "n_parcels_mean": (float(n_par[t > 30].mean()), "1"), "n_parcels_peak": (float(n_par.max()), "1"),
        "overshoot_ratio": (float(n_par.max() / n_par[t > 30].mean()), "1"),
        "t_equilibrium": (25.0, "s"), "streamer_lifetime": (0.8, "s"), "streamer_speed": (3.0, "m s-1"),
        "E_splash_over_E_impact": (0.55, "1"), "fit_z_min": (0.3, "m"), "fit_z_max": (1.5, "m"),
        # the drive holds the stress reading near the case's u*s
        "u_star_s_stress": (us_in * (0.5 + 0.5 * bias), "m s-1"),
        "airborne_mass_per_m2": (float(n_par[t > 30].mean()) * 4 * q * RHO_P * np.pi * mu1 ** 3 / 6
                                 / area, "kg m-2"),
    }
    data_vars: dict = {k: ((), float(v), {"units": u}) for k, (v, u) in sc.items()}
    prof = {"u_mean": (u_mean, "m s-1"), "u_mean_spinup": (u_spin, "m s-1"),
            "uw_flux": (uw, "m2 s-2"), "uw_flux_spinup": (uw0, "m2 s-2"), "tke": (us ** 2 * 2.5 + 0 * z, "m2 s-2"),
            "tau_p": (tau_p, "kg m-1 s-2"), "G": (g_prof, "kg m-2 s-1"), "R_cu": (r_cu, "1"),
            "St": (st, "1"), "T_p": (t_p + 0 * z, "s"), "T_eps": (t_eps, "s"),
            "eps_tot": (0.1 / (z + 0.1), "m2 s-3")}
    for k, (v, u) in prof.items():
        data_vars[k] = (("z",), np.asarray(v, float), {"units": u})
    data_vars.update({
        "n_parcels": (("time",), n_par, {"units": "1"}),
        "G_tot_series": (("time",), gser, {"units": "kg m-1 s-1"}),
        "S_c": (("ky",), s_c, {"units": "m-4 m"}), "S_u": (("ky",), s_u, {"units": "m2 s-2 m"}),
        "C_p_autocorr": (("lag_x", "lag_y"), autocorr, {"units": "1"}),
        "psd_air": (("z_band", "d_bin"), air, {"units": "1"}),
        "psd_bed": (("d_bin",), bed, {"units": "1"}),
        "C_p_snapshot": (("x", "y"), cp, {"units": "m-2"}),
        "u_snapshot": (("x", "y"), u_snap, {"units": "m s-1"}),
        "R_cu_lag": (("lag_t", "z_plane"), r_lag, {"units": "1"}),
        "z_band_edges": (("z_band_edge",), z_band_edges, {"units": "m"}),
        "d_edges": (("d_edge",), d_edges, {"units": "m"}),
    })
    coords = {"z": ("z", z, {"units": "m"}), "time": ("time", t, {"units": "s"}),
              "time_sample": ("time_sample", np.linspace(30, 90, 13), {"units": "s"}),
              "time_plane": ("time_plane", np.arange(0, 3.0, 0.1) + 30, {"units": "s"}),
              "ky": ("ky", ky, {"units": "m-1"}), "lag_x": ("lag_x", lag_x, {"units": "m"}),
              "lag_y": ("lag_y", lag_y, {"units": "m"}), "lag_t": ("lag_t", lag_t, {"units": "s"}),
              "z_plane": ("z_plane", z_plane, {"units": "m"}), "d_bin": ("d_bin", d_bin, {"units": "m"}),
              "z_band": ("z_band", z_band, {"units": "m"}), "x": ("x", x, {"units": "m"}),
              "y": ("y", y, {"units": "m"})}
    if with_cp_stack:
        tp = coords["time_plane"][1]
        stack = np.stack([np.roll(cp, int(i), axis=0) * (1 + 0.1 * np.sin(i)) for i in range(tp.size)])
        data_vars["C_p_planes"] = (("time_plane", "x", "y"), stack, {"units": "m-2"})
    attrs = {"case_json": json.dumps(scene), "package_version": "0.1.0", "fidelity": fidelity,
             "seed": 20130527, "label": label or f"case{case:02d}", "case_number": case,
             "wall_time_s": float(wall_time_s), "Lx": lx, "Ly": ly, "Lz": lz, "dx": lx / nx,
             "dy": ly / ny, "Q": float(q * 4), "rho": RHO, "rho_p": RHO_P, "nu": NU, "g": G,
             "kappa": KAPPA, "z0": Z0, "u_star_target": us_in, "t_activation": 200.0}
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)


def write_analysis(path: str | Path, case: int, **kw) -> Path:
    """Write :func:`make_analysis_dataset` to ``path`` (atomically, under the NetCDF lock)."""
    return write_dataset(make_analysis_dataset(case, **kw), path)


def write_study(root: str | Path, cases=range(1, 11), missing=(), **kw) -> dict[str, Path | None]:
    """Archives for ``cases`` under ``root``; labels ``caseNN``; ``missing`` cases map to None."""
    root = Path(root)
    runs: dict[str, Path | None] = {}
    for n in cases:
        label = f"case{n:02d}"
        runs[label] = None if n in missing else write_analysis(root / label / "analysis.nc", n, **kw)
    return runs


def modify_archive(path: str | Path, var: str, func) -> None:
    """Replace ``var`` in the archive at ``path`` by ``func(values)`` (rewrites the file)."""
    from saltstudy.ncio import open_dataset
    ds = open_dataset(path)
    ds[var] = (ds[var].dims, np.asarray(func(ds[var].values), dtype=float), ds[var].attrs)
    write_dataset(ds, path)
