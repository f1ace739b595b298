"""Synthetic ``samples.nc`` and ``spinup.nc`` archives that follow docs/ARCHITECTURE.md exactly.

Reusable by any test (analysis, report, workflow): :func:`build_archives` writes both files and
returns their paths plus a ``truth`` dict with the answers the synthetic fields were built from.

The fields are constructed, not simulated:

* wind: a log law ``u = (u*/kappa) ln(z/z0)`` at every level (grains: ``u_star_s, z0s``;
  spin-up: ``u_star_0, z0_0``), a constant stress ``uw_res + uw_sgs = -u*^2``, plus streaks in
  the 3-D and plane fields;
* grains: mass density ``rho_m(z) = c exp(-z/H_m)`` per layer, mean grain velocity
  ``U_p(z) = 2 + 3z``, a momentum flux ``tau_p(z) = tau0 exp(-z/H_tau)`` put into ``pmuw``
  (so eq. 10 gives it back exactly), size histograms from a lognormal bed;
* C_p planes: Gaussian streaks of spanwise spacing ``delta_y`` moving downstream at
  ``speed``, sampled as whole parcels of ``PARCEL_WEIGHT`` grains (Poisson counts per column);
  C_p_s at the 3-D sample times is correlated with u;
* the wall stress is the share of the total the grains do not carry at the bed;
* series: parcel count with an overshoot ``n = P (1 + A exp(-(t - t_pk)/tau))`` after a linear
  rise, total flux with a known standard deviation, splash/impact energies with a fixed ratio.

``grains=False`` gives a run without grains (all grain sums zero), ``n_samples=1`` and tiny grids
exercise the degenerate paths.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from saltstudy.analysis import streamers
from saltstudy.config import Case, Fidelity, Scene
from saltstudy.ncio import write_dataset
from saltstudy.physics.laws import log_law_profile

__all__ = ["build_archives", "make_scene", "stretched_faces", "samples_schema_variables"]

RHO, RHO_P, NU, G, KAPPA, Z0 = 1.2, 2650.0, 1.5e-5, 9.81, 0.40, 1.0e-5
#: grains per parcel (the case's Q, q_multiplier 1)
PARCEL_WEIGHT = 20.0

_UNITS = {
    "x": ("m", "x of cell centres (streamwise)"), "y": ("m", "y of cell centres (spanwise)"),
    "z": ("m", "height of cell centres"), "z_w": ("m", "height of cell faces (w levels)"),
    "x_u": ("m", "x of x-faces (u points)"), "y_v": ("m", "y of y-faces (v points)"),
    "time": ("s", "time of 3-D samples since saltation activation"),
    "time_plane": ("s", "time of 2-D planes since saltation activation"),
    "time_series": ("s", "time of series records since saltation activation"),
    "time_hist": ("s", "model time of spin-up history records"),
    "z_plane": ("m", "height of horizontal planes"), "d_bin": ("m", "grain diameter bin centre"),
    "d_edges": ("m", "grain diameter bin edges"),
    "u": ("m s-1", "streamwise velocity"), "v": ("m s-1", "spanwise velocity"),
    "w": ("m s-1", "vertical velocity"), "e": ("m2 s-2", "subgrid-scale TKE"),
    "p": ("m2 s-2", "kinematic pressure"), "u_mean": ("m s-1", "horizontal mean of u"),
    "uw_res": ("m2 s-2", "resolved momentum flux"), "uw_sgs": ("m2 s-2", "SGS momentum flux"),
    "tke_res": ("m2 s-2", "resolved TKE"), "e_sgs": ("m2 s-2", "mean SGS TKE"),
    "eps_sgs": ("m2 s-3", "SGS dissipation"), "sgs_transfer": ("m2 s-3", "-<tau_ij S_ij>"),
    "u_plane": ("m s-1", "u at z_plane"), "u_star_hist": ("m s-1", "u* during spin-up"),
    "tke_hist": ("m2 s-2", "TKE during spin-up"), "C_p": ("m-2", "grains per bed area"),
    "C_p_s": ("m-2", "C_p at 3-D sample times"), "G_col": ("kg m-1 s-1", "column mass flux"),
    "pm": ("kg", "sum Q m_p"), "pmu": ("kg m s-1", "sum Q m_p u_p"), "pmv": ("kg m s-1", "sum Q m_p v_p"),
    "pmw": ("kg m s-1", "sum Q m_p w_p"), "pmuu": ("kg m2 s-2", "sum Q m_p u_p u_p"),
    "pmuw": ("kg m2 s-2", "sum Q m_p u_p w_p"), "pmww": ("kg m2 s-2", "sum Q m_p w_p w_p"),
    "pmvv": ("kg m2 s-2", "sum Q m_p v_p v_p"), "pn": ("1", "sum Q"),
    "pdrag": ("kg s-1", "sum Q m_p f/T_p"), "pmuf_up": ("kg m2 s-2", "sum Q m_p u_f.u_p"),
    "pmuf": ("kg m s-1", "sum Q m_p u_f"), "pmuf_uf": ("kg m2 s-2", "sum Q m_p |u_f|^2"),
    "pmup_up": ("kg m2 s-2", "sum Q m_p |u_p|^2"), "size_hist": ("1", "grains per layer and bin"),
    "n_parcels": ("1", "parcels aloft"), "n_impacts": ("1", "cumulative impacts"),
    "n_rebounds": ("1", "cumulative rebounds"), "n_ejections": ("1", "cumulative ejections"),
    "n_depositions": ("1", "cumulative depositions"),
    "G_tot_series": ("kg m-1 s-1", "total mass flux"), "u_star_ref": ("m s-1", "u* at z_ref_eff"),
    "u_drive": ("m s-1", "driving velocity"), "dt": ("s", "time step"), "max_cfl": ("1", "max CFL"),
    "E_impact": ("J", "cumulative impact energy"), "E_splash": ("J", "cumulative splash energy"),
    "bed_px": ("kg m s-1", "cumulative streamwise momentum given to the bed"),
    "bed_pz": ("kg m s-1", "cumulative vertical momentum the bed gave the grains"),
    "C_p_above": ("m-2", "grains above the first cell per bed area"),
}

_GRAIN_SUMS = ("pm", "pmu", "pmv", "pmw", "pmuu", "pmuw", "pmww", "pmvv", "pn", "pdrag", "pmuf_up",
               "pmuf", "pmuf_uf", "pmup_up")
_SERIES = ("n_parcels", "n_impacts", "n_rebounds", "n_ejections", "n_depositions", "G_tot_series",
           "u_star_ref", "u_drive", "dt", "max_cfl", "E_impact", "E_splash", "bed_px", "bed_pz")


def samples_schema_variables() -> dict[str, tuple[str, ...]]:
    """Variable -> dims of samples.nc as in docs/ARCHITECTURE.md."""
    out = {k: ("time", "x", "y", "z") for k in ("u", "v", "w", "e")}
    out["C_p_s"] = ("time", "x", "y")
    out.update({k: ("time", "z_w") for k in ("uw_res", "uw_sgs")})
    out.update({k: ("time", "z") for k in ("u_mean", "tke_res", "e_sgs", "eps_sgs", "sgs_transfer")})
    out.update({k: ("time", "z") for k in _GRAIN_SUMS})
    out["size_hist"] = ("time", "z", "d_bin")
    out.update({k: ("time_plane", "x", "y") for k in ("C_p", "C_p_above", "G_col")})
    out["u_plane"] = ("time_plane", "x", "y", "z_plane")
    out.update({k: ("time_series",) for k in _SERIES})
    out["d_edges"] = ("d_edge",)
    return out


def stretched_faces(Lz: float, nz: int, dz_bottom: float) -> np.ndarray:
    """Faces cubic in the level index (same law as the solver grid without dz_top)."""
    n = float(nz)
    a, c = np.linalg.solve(np.array([[1.0, 1.0], [n, n ** 3]]), [dz_bottom, Lz])
    k = np.arange(nz + 1, dtype=float)
    zf = a * k + c * k ** 3
    zf[0], zf[-1] = 0.0, Lz
    return zf


def make_scene(*, Lx: float, Ly: float, Lz: float, nx: int, ny: int, nz: int, damping: float,
               u_star: float, Q: float, mu: float, sigma: float, sample_start: float,
               sample_interval: float, sample_count: int, duration: float,
               plane_interval: float, series_interval: float, drive: str = "top") -> Scene:
    case = Case.model_validate({
        "number": 1, "name": "fixture", "forcing": {"u_star_s": u_star, "drive": drive},
        "particles": {"Q": Q}, "soil": {"modes": [{"mass_fraction": 1.0, "mu": mu, "sigma": sigma}]},
    })
    fid = Fidelity.model_validate({
        "name": "fixture", "saltation_duration": duration,
        "grid": {"Lx": Lx, "Ly": Ly, "Lz": Lz, "nx": nx, "ny": ny, "nz": nz, "dz_bottom": min(0.01, Lz / (2 * nz)),
                 "damping_depth": damping},
        "spinup": {"t_min": 1.0, "t_max": 3.0, "window": 1.0},
        "sampling": {"start": sample_start, "interval": sample_interval, "count": sample_count,
                     "plane_interval": plane_interval, "series_interval": series_interval},
    })
    return Scene(label="fixture", case=case, fidelity=fid)


def _v(dims, data, name, dtype=np.float64):
    units, long_name = _UNITS[name]
    return xr.Variable(dims, np.asarray(data, dtype=dtype), attrs={"units": units, "long_name": long_name})


def _streaks(X, Y, t, *, Lx, Ly, spacing, width, length, speed, seed):
    """Gaussian streaks: one per spanwise slot (spacing), one per streamwise period Lx."""
    rng = np.random.default_rng(seed)
    f = np.zeros_like(X)
    n_slots = int(round(Ly / spacing))
    x0 = rng.uniform(0, Lx) + speed * t      # a family of parallel streaks
    for j in range(n_slots):
        y0 = (j + 0.5) * spacing
        dxp = (X - x0 + 0.5 * Lx) % Lx - 0.5 * Lx
        dyp = (Y - y0 + 0.5 * Ly) % Ly - 0.5 * Ly
        f += np.exp(-0.5 * (dxp / length) ** 2 - 0.5 * (dyp / width) ** 2)
    return f


def build_archives(directory: str | Path, *, nx: int = 16, ny: int = 12, nz: int = 16,
                   Lx: float = 2.4, Ly: float = 1.6, Lz: float = 3.0, damping: float = 1.0,
                   n_samples: int = 3, sample_start: float = 1.0, sample_interval: float = 0.5,
                   plane_interval: float = 0.1, series_interval: float = 0.05,
                   grains: bool = True, seed: int = 1, u_star_s: float = 0.5, z0s: float = 2e-4,
                   u_star_0: float = 0.45, z0_0: float = 1e-5, tau0_fraction: float = 0.3,
                   H_tau: float = 0.05, H_m: float = 0.04, mu: float = 2.0e-4, sigma: float = 1.2,
                   streak_spacing: float | None = None, streak_speed: float = 2.0,
                   full_fields: bool = True, drive: str = "top") -> tuple[Path, Path, dict[str, Any]]:
    """Write ``samples.nc`` and ``spinup.nc`` in ``directory``; return (samples, spinup, truth)."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    dx, dy = Lx / nx, Ly / ny
    x = (np.arange(nx) + 0.5) * dx
    y = (np.arange(ny) + 0.5) * dy
    z_w = stretched_faces(Lz, nz, min(0.01, Lz / (2 * nz)))
    z = 0.5 * (z_w[1:] + z_w[:-1])
    dz = np.diff(z_w)
    duration = sample_start + max(n_samples - 1, 0) * sample_interval
    t3 = sample_start + sample_interval * np.arange(n_samples)
    tp = np.arange(sample_start, duration + 1e-9, plane_interval)
    ts = np.arange(0.0, duration + 1e-9, series_interval)
    z_plane = np.array([h for h in (0.02, 0.05, 0.1, 0.2, 0.4) if h < Lz - damping or h == 0.1])
    d_edges = np.geomspace(mu / sigma ** 3, mu * sigma ** 3, 25)
    d_bin = np.sqrt(d_edges[1:] * d_edges[:-1])
    scene = make_scene(Lx=Lx, Ly=Ly, Lz=Lz, nx=nx, ny=ny, nz=nz, damping=damping, u_star=u_star_s,
                       Q=PARCEL_WEIGHT, mu=mu, sigma=sigma, sample_start=sample_start,
                       sample_interval=sample_interval, sample_count=max(n_samples, 1),
                       duration=max(duration, 1e-3), plane_interval=plane_interval,
                       series_interval=series_interval, drive=drive)
    spacing = streak_spacing or (Ly / max(1, ny // 4))
    X, Y = np.meshgrid(x, y, indexing="ij")

    # --- wind ---
    # top drive: constant stress, the plain log law; pressure-gradient drive: the linear-stress
    # profile with the lid at Lz (u*_0 and z0 its surface values)
    H = Lz if drive == "pressure_gradient" else None
    u_prof = log_law_profile(z, u_star_s, z0s, KAPPA, H)
    u_prof0 = log_law_profile(z, u_star_0, z0_0, KAPPA, H)
    uw_res_w = np.full(nz + 1, -0.8 * u_star_s ** 2)
    uw_sgs_w = np.full(nz + 1, -0.2 * u_star_s ** 2)
    uw_res_w[[0, -1]] = 0.0
    # the wall stress: the air carries what the grains do not at the bed (steady budget)
    uw_sgs_w[0], uw_sgs_w[-1] = -(1.0 - (tau0_fraction if grains else 0.0)) * u_star_s ** 2, 0.0
    tke_res = 1.5 * u_star_s ** 2 * np.ones(nz)
    e_sgs = 0.5 * u_star_s ** 2 * np.exp(-z / 0.5)
    # -<tau_ij S_ij> = mean-shear part (-uw_sgs dU/dz) + a fluctuation part 0.2 u*^3/(kappa z)
    dudz = np.gradient(u_prof, z)
    sgs_transfer = 0.2 * u_star_s ** 3 / (KAPPA * z) - 0.5 * (uw_sgs_w[1:] + uw_sgs_w[:-1]) * dudz
    eps_sgs = 0.9 * sgs_transfer

    # --- grains: per-layer sums (identical at every sample) ---
    rho_u2 = RHO * u_star_s ** 2
    c_m = 0.5 if grains else 0.0                       # kg m-3 at the bed
    rho_m = c_m * np.exp(-z / H_m)
    pm = rho_m * Lx * Ly * dz
    U_p = 2.0 + 3.0 * z
    tau_true = tau0_fraction * rho_u2 * np.exp(-z / H_tau) if grains else np.zeros(nz)
    with np.errstate(divide="ignore", invalid="ignore"):
        cov_uw = np.where(rho_m > 0, -tau_true / np.where(rho_m > 0, rho_m, 1.0), 0.0)
    var_u, var_v, var_w = 0.3, 0.05, 0.2
    m_grain = RHO_P * math.pi / 6 * mu ** 3
    T_p = RHO_P * mu ** 2 / (18 * RHO * NU)
    cov_fp = 0.1
    sums = {
        "pm": pm, "pmu": pm * U_p, "pmv": 0 * pm, "pmw": 0 * pm, "pmuu": pm * (U_p ** 2 + var_u),
        "pmuw": pm * cov_uw, "pmww": pm * var_w, "pmvv": pm * var_v, "pn": pm / m_grain,
        "pdrag": pm * 1.5 / T_p, "pmuf": pm * u_prof, "pmuf_up": pm * (u_prof * U_p + cov_fp),
        "pmuf_uf": pm * (u_prof ** 2 + 2 * tke_res), "pmup_up": pm * (U_p ** 2 + var_u + var_v + var_w),
    }
    bed = np.diff(0.5 * (1 + np.array([math.erf(v) for v in
                                         np.log(d_edges / mu) / (math.log(sigma) * math.sqrt(2))])))
    bed /= bed.sum()
    counts = bed / (RHO_P * math.pi / 6 * d_bin ** 3)
    counts /= (counts * RHO_P * math.pi / 6 * d_bin ** 3).sum()    # counts per kg of grains
    size_hist = pm[:, None] * counts[None, :]

    # --- 3-D fields, planes ---
    def cp_field(t, s):
        if not grains:
            return np.zeros((nx, ny))
        f = _streaks(X, Y, t, Lx=Lx, Ly=Ly, spacing=spacing, width=max(0.5 * dy, 0.15 * spacing),
                     length=0.15 * Lx, speed=streak_speed, seed=s)
        return 1e5 * (0.2 + f)

    # C_p as the solver records it: whole parcels of PARCEL_WEIGHT grains per column, Poisson
    # about the pattern (their own generator, so the other fields do not depend on it)
    rng_parcels = np.random.default_rng(seed + 1000)

    def parcel_counts(c):
        return rng_parcels.poisson(c * dx * dy / PARCEL_WEIGHT) * (PARCEL_WEIGHT / (dx * dy))

    u3 = np.empty((n_samples, nx, ny, nz))
    cps = np.empty((n_samples, nx, ny))
    for i, t in enumerate(t3):
        c = cp_field(t, seed + 100 + i)
        cps[i] = parcel_counts(c)
        pert = (c - c.mean()) / (c.std() + 1e-30) if grains else rng.standard_normal((nx, ny))
        noise = rng.standard_normal((nx, ny, nz))
        u3[i] = u_prof[None, None, :] + 0.3 * u_star_s * (0.6 * pert[..., None] + 0.8 * noise)
    planes_c = np.empty((tp.size, nx, ny))
    intensity_c = np.empty((tp.size, nx, ny))
    planes_u = np.empty((tp.size, nx, ny, z_plane.size))
    base = 7 + seed
    for i, t in enumerate(tp):
        c = cp_field(t, base)           # same streak seeds: a pattern that moves at streak_speed
        intensity_c[i] = c
        planes_c[i] = parcel_counts(c)
        pert = (c - c.mean()) / (c.std() + 1e-30) if grains else np.zeros((nx, ny))
        u_pl = np.interp(z_plane, z, u_prof)
        planes_u[i] = u_pl[None, None, :] * (1 + 0.05 * pert[..., None]) \
            + 0.05 * rng.standard_normal((nx, ny, z_plane.size))
    gcol = planes_c * m_grain * 2.5

    # --- series ---
    P, A, tau_relax, t_pk = 1000.0 if grains else 0.0, 1.0, 0.15, 0.2
    n_par = np.where(ts < t_pk, P * (1 + A) * ts / t_pk, P * (1 + A * np.exp(-(ts - t_pk) / tau_relax)))
    G_tot_true = float(np.sum(pm * U_p) / (Lx * Ly))
    g_amp = 0.1 * G_tot_true
    g_series = G_tot_true + g_amp * math.sqrt(2) * np.sin(2 * np.pi * ts / 0.5)
    e_imp = 10.0 * ts
    series = {
        "n_parcels": n_par, "n_impacts": 5 * ts, "n_rebounds": 4 * ts, "n_ejections": 3 * ts,
        "n_depositions": 2 * ts, "G_tot_series": g_series, "u_star_ref": u_star_s + 0 * ts,
        "u_drive": 10.0 + 0 * ts, "dt": 0.01 + 0 * ts, "max_cfl": 0.5 + 0 * ts,
        "E_impact": e_imp, "E_splash": 0.6 * e_imp,
        # the grains' impacts give the bed a steady stress: mu_b = 0.8 of a steady vertical push
        "bed_px": 0.8 * 2.0e-3 * ts, "bed_pz": 2.0e-3 * ts,
    }

    # --- samples.nc ---
    coords = {"x": _v(("x",), x, "x"), "y": _v(("y",), y, "y"), "z": _v(("z",), z, "z"),
              "z_w": _v(("z_w",), z_w, "z_w"), "time": _v(("time",), t3, "time"),
              "time_plane": _v(("time_plane",), tp, "time_plane"),
              "time_series": _v(("time_series",), ts, "time_series"),
              "z_plane": _v(("z_plane",), z_plane, "z_plane"), "d_bin": _v(("d_bin",), d_bin, "d_bin")}
    data = {"d_edges": _v(("d_edge",), d_edges, "d_edges")}
    if full_fields:
        data["u"] = _v(("time", "x", "y", "z"), u3, "u", np.float32)
        data["v"] = _v(("time", "x", "y", "z"), 0.1 * rng.standard_normal(u3.shape), "v", np.float32)
        data["w"] = _v(("time", "x", "y", "z"), 0.1 * rng.standard_normal(u3.shape), "w", np.float32)
        data["e"] = _v(("time", "x", "y", "z"), np.broadcast_to(e_sgs, u3.shape), "e", np.float32)
    data["C_p_s"] = _v(("time", "x", "y"), cps, "C_p_s")
    tile = lambda a: np.broadcast_to(a, (n_samples,) + np.shape(a))  # noqa: E731
    data["uw_res"] = _v(("time", "z_w"), tile(uw_res_w), "uw_res")
    data["uw_sgs"] = _v(("time", "z_w"), tile(uw_sgs_w), "uw_sgs")
    for name, prof in (("u_mean", u_prof), ("tke_res", tke_res), ("e_sgs", e_sgs),
                       ("eps_sgs", eps_sgs), ("sgs_transfer", sgs_transfer)):
        data[name] = _v(("time", "z"), tile(prof), name)
    for name in _GRAIN_SUMS:
        data[name] = _v(("time", "z"), tile(sums[name]), name)
    data["size_hist"] = _v(("time", "z", "d_bin"), tile(size_hist), "size_hist")
    data["C_p"] = _v(("time_plane", "x", "y"), planes_c, "C_p")
    data["C_p_above"] = _v(("time_plane", "x", "y"), 0.4 * planes_c, "C_p_above")
    data["G_col"] = _v(("time_plane", "x", "y"), gcol, "G_col")
    data["u_plane"] = _v(("time_plane", "x", "y", "z_plane"), planes_u, "u_plane")
    for name in _SERIES:
        data[name] = _v(("time_series",), series[name], name)
    attrs = {
        "case_json": scene.model_dump_json(), "package_version": "fixture", "fidelity": "fixture",
        "seed": seed, "label": "fixture", "case_number": 1, "wall_time_s": 12.5,
        "Lx": Lx, "Ly": Ly, "Lz": Lz, "dx": dx, "dy": dy, "Q": PARCEL_WEIGHT, "rho": RHO, "rho_p": RHO_P,
        "nu": NU, "g": G, "kappa": KAPPA, "z0": Z0, "u_star_target": u_star_s, "t_activation": 3.0,
    }
    samples = xr.Dataset(data, coords=coords, attrs=attrs)
    samples_path = write_dataset(samples, directory / "samples.nc")

    # --- spinup.nc ---
    zeros = lambda *s: np.zeros(s)  # noqa: E731
    sp_coords = {"x": _v(("x",), x, "x"), "y": _v(("y",), y, "y"), "z": _v(("z",), z, "z"),
                 "z_w": _v(("z_w",), z_w, "z_w"), "x_u": _v(("x_u",), x - 0.5 * dx, "x_u"),
                 "y_v": _v(("y_v",), y - 0.5 * dy, "y_v"),
                 "time_hist": _v(("time_hist",), np.linspace(0, 3, 31), "time_hist")}
    uw0 = np.full(nz + 1, -u_star_0 ** 2)
    uw0[[0, -1]] = 0.0
    uws0 = np.zeros(nz + 1)
    uws0[0] = -u_star_0 ** 2
    sp_data = {
        "u": _v(("x_u", "y", "z"), np.broadcast_to(u_prof0, (nx, ny, nz)), "u"),
        "v": _v(("x", "y_v", "z"), zeros(nx, ny, nz), "v"),
        "w": _v(("x", "y", "z_w"), zeros(nx, ny, nz + 1), "w"),
        "e": _v(("x", "y", "z"), np.broadcast_to(e_sgs, (nx, ny, nz)), "e"),
        "p": _v(("x", "y", "z"), zeros(nx, ny, nz), "p"),
        "u_mean": _v(("z",), u_prof0, "u_mean"), "uw_res": _v(("z_w",), uw0, "uw_res"),
        "uw_sgs": _v(("z_w",), uws0, "uw_sgs"), "tke_res": _v(("z",), 1.2 * tke_res, "tke_res"),
        "e_sgs": _v(("z",), e_sgs, "e_sgs"),
        "u_star_hist": _v(("time_hist",), np.full(31, u_star_0), "u_star_hist"),
        "tke_hist": _v(("time_hist",), np.full(31, 0.3), "tke_hist"),
    }
    sp_attrs = {k: v for k, v in attrs.items() if k != "t_activation"}
    sp_attrs.update({"converged": 1, "spinup_reason": "steady", "u_drive": 10.0, "t_end": 3.0})
    spinup_path = write_dataset(xr.Dataset(sp_data, coords=sp_coords, attrs=sp_attrs),
                                directory / "spinup.nc")

    G_prof = rho_m * U_p
    # the streamer core of the pattern itself (no parcel noise), by the analysis' own functions
    ac_true = streamers.autocorrelation_2d(intensity_c)
    truth = {
        "u_star_s": u_star_s, "z0s": z0s, "u_star_0": u_star_0, "z0_0": z0_0,
        "tau_p": tau_true, "G": G_prof, "G_tot": G_tot_true, "z": z, "z_w": z_w,
        "z_m": (H_tau * math.log(tau0_fraction / 1e-3) if grains else math.nan),
        "tau_p_surface_fraction": tau0_fraction if grains else math.nan,
        "lambda_x_noise_free": streamers.core_length(ac_true[:, ny // 2], dx),
        "lambda_y_noise_free": streamers.core_length(ac_true[nx // 2, :], dy),
        "sigma_G": g_amp, "n_parcels_peak": float(n_par.max()), "n_parcels_mean": P,
        "airborne_mass_per_m2": float(np.sum(rho_m * dz)),
        "E_splash_over_E_impact": 0.6, "streak_spacing": spacing, "streak_speed": streak_speed,
        # T_p of the mass-weighted mean diameter of the lognormal bed, mu exp(ln^2 sigma / 2)
        "T_p": RHO_P * (mu * math.exp(0.5 * math.log(sigma) ** 2)) ** 2 / (18 * RHO * NU),
        "eps_sgs": 0.2 * u_star_s ** 3 / (KAPPA * z),
        "eps_drag": rho_m * 1.5 / (T_p * RHO) * (2 * tke_res - cov_fp), "tke_res": tke_res,
        "scene": json.loads(scene.model_dump_json()),
    }
    return samples_path, spinup_path, truth
