"""One case: ``samples.nc`` (+ ``spinup.nc``) -> ``analysis.nc`` (schema in docs/ARCHITECTURE.md).

:func:`analyse_case` (the workflow task, ``saltstudy analyse``) reads the archives only and
writes atomically through :mod:`saltstudy.ncio`; degenerate input (no grains, one sample, tiny
grids, missing optional variables) gives NaN, never an exception. :func:`analyse_datasets`
runs the statistics in the order their coupled definitions need: the stress ``u*`` at
``z_ref_eff`` first, z_m against ``rho u*^2`` with it, the log-law fit above z_m, tau_p at the
bed and the air's budget at the bed with the same ``u*``; the streamers before R_cu, which
removes the same parcel-count noise; the air's balance at the bed before the impact record's.
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
from . import (balance, correlation, flux, layer, profiles, series, sizes, stokes,
               streamer_statistics, streamers)
from .reading import (LAZY_VARIABLES, Rows, as_arrays, attr_float, frame_of, read_archive,
                      rescale_spinup_profiles)
from .schema import HALF_STATISTICS, SAMPLE_VARIABLES_USED, SPEC, Variables, to_dataset

__all__ = ["analyse_case", "analyse_datasets", "half_window_statistics"]

log = logging.getLogger(__name__)

#: the spin-up's variables the analysis reads
SPINUP_VARIABLES_USED = ("u_mean", "uw_res", "uw_sgs", "tke_res", "e_sgs")


def analyse_case(samples_path: str | Path, spinup_path: str | Path | None, out_path: str | Path,
                 wall_time_s: float | None = None) -> Path:
    """Analyse one case's archives into ``out_path`` (analysis.nc). Returns ``out_path``.

    ``spinup_path`` may be None or missing: the spin-up variables are then NaN.
    ``wall_time_s`` (the sum of the case's solver tasks) overrides the samples' attribute.
    """
    t_start = _time.perf_counter()
    s_attrs, s_coords, s = read_archive(samples_path, SAMPLE_VARIABLES_USED, LAZY_VARIABLES)
    if spinup_path is not None and Path(spinup_path).is_file():
        sp_attrs, sp_coords, sp = read_archive(spinup_path, SPINUP_VARIABLES_USED)
        sp = rescale_spinup_profiles(sp, attr_float(s_attrs, "u_star_target")
                                     / attr_float(sp_attrs, "u_star_target"))
    else:
        sp_attrs, sp_coords, sp = {}, {}, {}
    ds = analyse_datasets(s_attrs, s_coords, s, sp_coords, sp)
    for name, vals in half_window_statistics(s_attrs, s_coords, s, sp_coords, sp).items():
        units = ds[name].attrs.get("units", SPEC.get(name, ("1", ""))[0])
        ds[f"{name}_halves"] = xr.DataArray(
            vals, dims=("half",), attrs={"units": units, "long_name": f"{name} over the first and "
                                         "the second half of the sampling window (its 3-D samples "
                                         "split in two; planes and series with them)"})
    from .._identity import __version__
    attrs = {k: v for k, v in s_attrs.items() if k != "saltstudy_complete"}
    attrs.update(wall_time_s=float(wall_time_s if wall_time_s is not None
                                   else attr_float(s_attrs, "wall_time_s")),
                 samples_path=str(samples_path),
                 spinup_path=str(spinup_path) if spinup_path is not None else "")
    if "converged" in sp_attrs:
        attrs["spinup_converged"] = int(bool(sp_attrs["converged"]))
    attrs.update(analysis_version=__version__,
                 analysis_seconds=float(_time.perf_counter() - t_start))
    ds.attrs = attrs
    return write_dataset(ds, out_path)


#: samples.nc variables along the planes' time axis, along the series' and whole (not in time);
#: the others run along the 3-D samples' time axis
_PLANE_VARIABLES = ("C_p", "C_p_above", "G_col", "u_plane")
_SERIES_VARIABLES = ("n_parcels", "G_tot_series", "u_star_ref", "E_impact", "E_splash", "bed_px",
                     "bed_pz")
_WHOLE_VARIABLES = ("d_edges",)


def half_kind(name: str, v: Any, n_sample: int, n_plane: int, n_series: int) -> str:
    """How a half window takes variable ``name``: "sample" (its rows of the 3-D samples),
    "plane" (its planes), "series" or "whole" (kept whole). The lists above name the known
    ones; any other goes by the length of its first axis when that is one time axis's alone (a
    series cut as if it were samples would make every half-window statistic NaN), else samples."""
    for kind, names in (("whole", _WHOLE_VARIABLES), ("series", _SERIES_VARIABLES),
                        ("plane", _PLANE_VARIABLES)):
        if name in names:
            return kind
    shape = getattr(v, "shape", ())
    if not shape:
        return "whole"
    hits = [k for k, n in (("sample", n_sample), ("plane", n_plane), ("series", n_series))
            if shape[0] == n]
    if len(hits) == 1:
        return hits[0]
    return "sample" if "sample" in hits else "whole"


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
    n_series = int(np.asarray(coords.get("time_series", np.zeros(0))).size)
    split = float(t_s[h]) - 1e-9
    out: dict[str, list[float]] = {k: [] for k in HALF_STATISTICS}
    for (a, b) in ((0, h), (h, t_s.size)):
        pa, pb = ((0, int(np.searchsorted(t_p, split))) if a == 0
                  else (int(np.searchsorted(t_p, split)), t_p.size))
        c = {**coords, "time": t_s[a:b], "time_plane": t_p[pa:pb]}
        sub: dict[str, Any] = {}
        for name, v in s.items():
            kind = "whole" if v is None else half_kind(name, v, t_s.size, t_p.size, n_series)
            if kind in ("whole", "series"):
                sub[name] = v
            elif kind == "plane":
                sub[name] = v[pa:pb] if isinstance(v, np.ndarray) else Rows(v, pa, pb)
            else:
                sub[name] = v[a:b] if isinstance(v, np.ndarray) else Rows(v, a, b)
        try:
            ds = analyse_datasets(attrs, c, sub, sp_coords, sp)
        except Exception as exc:  # noqa: BLE001 — a half too short for a statistic: NaN, not a crash
            log.warning("half-window analysis failed: %s", exc)
            ds = None
        for k in HALF_STATISTICS:
            out[k].append(float(ds[k].values) if ds is not None and k in ds.variables
                          and ds[k].ndim == 0 else math.nan)
    return {k: np.asarray(v, dtype=np.float64) for k, v in out.items()}


def analyse_datasets(attrs: dict[str, Any], coords: dict[str, np.ndarray], s: dict[str, Any],
                     sp_coords: dict[str, np.ndarray], sp: dict[str, Any]) -> xr.Dataset:
    """The analysis on arrays already in memory (see :func:`analyse_case`)."""
    fr = frame_of(attrs, coords)
    s = as_arrays(s)
    V = Variables()

    # the wind and the grains' fluxes; z_m, then the log-law fit above it (sections 3.1, 3.2)
    wind = profiles.wind_profiles(fr, s)
    grains = flux.grain_profiles(fr, s, wind.u0_stress)
    V.merge(profiles.log_law_statistics(fr, s, wind, grains.z_m))
    # tau_p at the bed and the momentum balance there, from the air's side
    V.merge(flux.bed_share_statistics(fr, grains.tau_p, grains.z_m, wind.u0_stress,
                                      wind.uw_mean_w))
    budget = balance.air_budget_statistics(fr, s, wind.uw_w, wind.u0_stress)
    V.merge(budget)
    # the particle-free reference, then the profiles with grains beside it
    V.merge(profiles.spinup_reference(fr, sp_coords, sp))
    V.merge(wind.variables)
    V.merge(grains.variables)
    # mass flux and sigma_G (sections 3.2, 4.3); sizes and Stokes numbers (sections 3.2, 4.2)
    V.merge(flux.mass_flux_statistics(fr, s, grains.G, grains.z_m, grains.airborne_mass))
    size = sizes.size_statistics(fr, s)
    V.merge(size.variables)
    V.merge(stokes.stokes_statistics(fr, s, size.hist_z, wind.u_mean, wind.tke_res, wind.uw_sgs_c))
    # streamers (section 4.1), then R_cu (eq. 12) with the same parcel-count noise removed
    streamer = streamer_statistics.streamer_statistics(fr, s)
    V.merge(streamer.variables)
    V.merge(correlation.r_cu_statistics(fr, s, grains.z_m, streamer.noise.to_paper))
    # series (section 3.1) and the threshold u*t
    V.merge(series.series_statistics(fr, s, grains.G_tot_sample))
    V.merge(sizes.threshold_statistics(fr))
    # the layer's anatomy, the balance at the bed from the impact record, the impact record
    band_e, anatomy = layer.anatomy_statistics(fr, s)
    V.merge(anatomy)
    V.merge(balance.impact_balance_statistics(fr, s, budget))
    impact_centres, impacts = layer.impact_record_statistics(fr, s)
    V.merge(impacts)

    band_edges = size.band_edges
    n_band = band_edges.size - 1
    coord_values = {
        "z": fr.z, "z_w": fr.z_w, "time": fr.t_series, "time_sample": fr.t_sample,
        "time_plane": fr.t_plane, "ky": streamer.ky, "lag_x": streamers.centred_lags(fr.nx, fr.dx),
        "lag_y": streamers.centred_lags(fr.ny, fr.dy), "lag_t": streamer.lag_t,
        "z_plane": fr.z_plane, "d_bin": fr.d_bin,
        "z_band": 0.5 * (band_edges[1:] + band_edges[:-1]) if n_band > 0 else np.zeros(0),
        "x": fr.x, "y": fr.y, "height_band": np.arange(band_e.size - 1), **impact_centres,
    }
    return to_dataset(coord_values, V)
