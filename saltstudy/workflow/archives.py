"""xarray Datasets for ``spinup.nc`` and ``samples.nc`` (schemas in docs/ARCHITECTURE.md).

Every variable carries ``units`` and ``long_name``; global attributes hold the scene as JSON and
the constants analysis needs. ``spinup.nc`` also carries the solver's whole restart checkpoint
(``u, v, w, e, p`` under their names, other entries as ``restart__<name>`` variables or
attributes, kinds in ``restart_manifest``), so :func:`restart_from_dataset` rebuilds it exactly.
"""
from __future__ import annotations

import json
import math
import re
from typing import Any

import numpy as np
import xarray as xr

from .._identity import SOURCE_KEY, __version__
from ..config import Scene
from ..solver.diagnostics.health import HEALTH_SERIES

# name -> (units, long_name). One table for both archives, so a name means one thing everywhere.
META: dict[str, tuple[str, str]] = {
    # coordinates
    "x": ("m", "x of cell centres (streamwise)"),
    "y": ("m", "y of cell centres (spanwise)"),
    "z": ("m", "height of cell centres"),
    "z_w": ("m", "height of cell faces (w levels)"),
    "x_u": ("m", "x of x-faces (u points)"),
    "y_v": ("m", "y of y-faces (v points)"),
    "time": ("s", "time of 3-D samples since saltation activation"),
    "time_plane": ("s", "time of 2-D planes since saltation activation"),
    "time_series": ("s", "time of series records since saltation activation"),
    "time_hist": ("s", "time since the start of the spin-up"),
    "z_plane": ("m", "height of horizontal planes"),
    "d_bin": ("m", "grain diameter bin centre (geometric)"),
    "d_edges": ("m", "grain diameter bin edges"),
    # flow
    "u": ("m s-1", "streamwise velocity"),
    "v": ("m s-1", "spanwise velocity"),
    "w": ("m s-1", "vertical velocity"),
    "e": ("m2 s-2", "subgrid-scale turbulent kinetic energy"),
    "p": ("m2 s-2", "kinematic pressure p/rho (pressure over the air density: no CF standard name)"),
    "u_mean": ("m s-1", "horizontal mean of u"),
    "uw_res": ("m2 s-2", "resolved kinematic momentum flux <u'w'>"),
    "uw_sgs": ("m2 s-2", "subgrid-scale kinematic momentum flux"),
    "tke_res": ("m2 s-2", "resolved turbulent kinetic energy 1/2<u_i'u_i'>"),
    "e_sgs": ("m2 s-2", "horizontal mean of subgrid-scale TKE"),
    "eps_sgs": ("m2 s-3", "subgrid-scale dissipation rate"),
    "sgs_transfer": ("m2 s-3", "resolved to subgrid-scale energy transfer -<tau_ij S_ij>"),
    "u_plane": ("m s-1", "u at cell centres interpolated to z_plane"),
    "u_star_hist": ("m s-1", "friction velocity during spin-up"),
    "tke_hist": ("m2 s-2", "volume-mean resolved TKE during spin-up"),
    "u_drive_hist": ("m s-1", "driving velocity during spin-up"),
    # grains, gridded
    "C_p": ("m-2", "grains per unit bed area in the column (Q-weighted parcel count / (dx dy))"),
    "C_p_s": ("m-2", "grains per unit bed area in the column at the 3-D sample times"),
    "G_col": ("kg m-1 s-1", "streamwise grain mass flux integrated over the column"),
    "C_p_above": ("m-2", "grains per unit bed area in the column above the first grid cell"),
    "pm": ("kg", "grain mass in the layer"),
    "pmu": ("kg m s-1", "grain streamwise momentum in the layer"),
    "pmv": ("kg m s-1", "grain spanwise momentum in the layer"),
    "pmw": ("kg m s-1", "grain vertical momentum in the layer"),
    "pmuu": ("kg m2 s-2", "sum of m_p u_p u_p in the layer"),
    "pmuw": ("kg m2 s-2", "sum of m_p u_p w_p in the layer"),
    "pmww": ("kg m2 s-2", "sum of m_p w_p w_p in the layer"),
    "pmvv": ("kg m2 s-2", "sum of m_p v_p v_p in the layer"),
    "pn": ("1", "number of grains in the layer (Q-weighted)"),
    "pdrag": ("kg s-1", "sum of m_p f(Re_p)/T_p in the layer"),
    "pmuf_up": ("kg m2 s-2", "sum of m_p (u_f . u_p) in the layer"),
    "pmuf": ("kg m s-1", "sum of m_p u_f (fluid streamwise velocity at the grain) in the layer"),
    "pmuf_uf": ("kg m2 s-2", "sum of m_p |u_f|^2 in the layer"),
    "pmup_up": ("kg m2 s-2", "sum of m_p |u_p|^2 in the layer"),
    "size_hist": ("1", "grains per layer and diameter bin (Q-weighted)"),
    # impacts since activation (cumulative parcel counts: a window is a difference of two samples)
    "v_imp": ("m s-1", "impact speed bin, lower edge"),
    "impact_angle": ("degree", "impact angle to the bed bin, lower edge"),
    "outcome": ("1", "0: impacts, 1: rebounds, 2: ejected parcels"),
    "hop_time": ("s", "hop flight time bin, lower edge"),
    "hop_length": ("m", "hop streamwise length bin, lower edge"),
    "impact_hist": ("1", "cumulative parcel impacts since activation by impact speed and angle"),
    "impact_outcomes": ("1", "cumulative impacts, rebounds and ejected parcels since activation by "
                        "impact speed"),
    "hop_time_hist": ("1", "cumulative hops ended since activation by flight time (hops launched "
                      "by a splash)"),
    "hop_length_hist": ("1", "cumulative hops ended since activation by streamwise length (hops "
                        "launched by a splash)"),
    # series
    "n_parcels": ("1", "computational parcels aloft"),
    "n_impacts": ("1", "cumulative parcel impacts since activation"),
    "n_rebounds": ("1", "cumulative rebounds since activation"),
    "n_ejections": ("1", "cumulative ejected parcels since activation"),
    "n_depositions": ("1", "cumulative depositions since activation"),
    "G_tot_series": ("kg m-1 s-1", "total streamwise grain mass flux per unit width"),
    "u_star_ref": ("m s-1", "friction velocity at the controller height z_ref_eff"),
    "u_drive": ("m s-1", "driving (base-state) velocity of the top damping layer"),
    "dt": ("s", "last time step"),
    "max_cfl": ("1", "largest Courant number of the last step"),
    "E_impact": ("J", "cumulative kinetic energy of impacting grains"),
    "E_splash": ("J", "cumulative kinetic energy of rebounding and ejected grains"),
    "bed_px": ("kg m s-1", "cumulative streamwise momentum the grains gave the bed (impacts minus "
               "launches)"),
    "bed_pz": ("kg m s-1", "cumulative vertical momentum the bed gave the grains (impacts' |w| plus "
               "launches' w)"),
    **HEALTH_SERIES,
}

PLANE_HEIGHTS = (0.02, 0.05, 0.1, 0.2, 0.4)

#: the study the archives reproduce (their global attribute ``references``)
REFERENCE = ("Dupont, S., G. Bergametti, B. Marticorena and S. Simoëns (2013), Modeling saltation "
             "intermittency, J. Geophys. Res. Atmos. 118, doi:10.1002/jgrd.50528")


def z_ref_eff(scene: Scene) -> float:
    """Height where u* is read (ARCHITECTURE.md, Forcing): below the damping layer, if any (the
    model's own ``z_ref``)."""
    return z_ref_below(scene.case.forcing.z_ref, scene.fidelity.grid.Lz, scene.damping_depth)


def z_ref_below(z_ref: float, Lz: float, damping_depth: float) -> float:
    """:func:`z_ref_eff` from its parts [m]: z_ref, or half the undamped column if that is lower."""
    return min(z_ref, 0.5 * (Lz - damping_depth))


def plane_heights(scene: Scene) -> np.ndarray:
    """0.02 ... 0.4 m clipped to the domain (below the damping layer); 0.1 m always present."""
    g = scene.fidelity.grid
    top = g.Lz - scene.damping_depth
    return np.array([h for h in PLANE_HEIGHTS if h < top or h == 0.1], dtype=np.float64)


def diameter_edges(scene: Scene, n_bins: int = 24) -> np.ndarray:
    """Log-spaced bin edges covering every soil mode to +-3 geometric standard deviations."""
    modes = scene.case.soil.modes
    lo = min(m.mu / m.sigma**3 for m in modes)
    hi = max(m.mu * m.sigma**3 for m in modes)
    return np.geomspace(lo, hi, n_bins + 1)


def global_attrs(scene: Scene, wall_time_s: float, key: str) -> dict[str, Any]:
    c, f = scene.case, scene.fidelity
    return {
        "title": f"saltstudy {scene.label} at fidelity {f.name}",
        "source": f"saltstudy {__version__}: large-eddy simulation of the surface layer two-way "
                  "coupled with Lagrangian sand grains",
        "references": REFERENCE,
        "case_json": scene.model_dump_json(),
        "package_version": __version__,
        "source_key": SOURCE_KEY,
        "cache_key": key,
        "fidelity": f.name,
        "seed": int(c.seed),
        "label": c.label,
        "case_number": int(c.number),
        "wall_time_s": float(wall_time_s),
        "Lx": f.grid.Lx, "Ly": f.grid.Ly, "Lz": f.grid.Lz, "dx": f.grid.dx, "dy": f.grid.dy,
        "Q": float(scene.Q), "rho": c.air.rho, "rho_p": c.soil.rho_p, "nu": c.air.nu,
        "g": c.air.g, "kappa": c.air.kappa, "z0": c.surface.z0,
        "u_star_target": c.forcing.u_star_s, "z_ref_eff": z_ref_eff(scene),
    }


def coords_for(grid) -> dict[str, xr.Variable]:
    """Dimension coordinates of a solver Grid, with units and long names."""
    vals = {"x": grid.x_c, "y": grid.y_c, "z": grid.z_c, "z_w": grid.z_f,
            "x_u": grid.x_f, "y_v": grid.y_f}
    return {k: _var((k,), np.asarray(v, dtype=np.float64), k) for k, v in vals.items()}


def _var(dims, data, name: str, dtype=None) -> xr.Variable:
    units, long_name = META[name]
    arr = np.asarray(data) if dtype is None else np.asarray(data, dtype=dtype)
    return xr.Variable(dims, arr, attrs={"units": units, "long_name": long_name})


def _compressed(v: xr.Variable) -> xr.Variable:
    # Fields of zeros (C_p away from streamers, grain profiles aloft) compress well; level 1 is
    # nearly as small as 9 at a fraction of the time.
    v.encoding.update({"zlib": True, "complevel": 1})
    return v


# ---- spinup.nc ----
#: ``flow_profiles`` name -> the spin-up archive's window-mean profile
PROFILE_NAMES = {"u": "u_mean", "uw_res": "uw_res", "uw_sgs": "uw_sgs", "tke_res": "tke_res",
                 "e_sgs": "e_sgs"}
_STAGGERED = {"u": ("x_u", "y", "z"), "v": ("x", "y_v", "z"), "w": ("x", "y", "z_w"),
              "e": ("x", "y", "z"), "p": ("x", "y", "z")}


#: a checkpoint's scalar kinds (bool before int: a bool is an int) and how each is read back
_KINDS = ((bool, np.bool_), "bool"), ((int, np.integer), "int"), ((float, np.floating), "float"), \
    (str, "str"), (type(None), "none")
SCALAR_FROM = {"bool": lambda x: bool(int(x)), "int": int, "float": float, "str": str,
               "none": lambda _: None}


def scalar_kind(v: Any) -> str | None:
    return next((kind for types, kind in _KINDS if isinstance(v, types)), None)


def _nc_name(name: str, taken: set[str]) -> str:
    """A NetCDF-safe, unique name for a checkpoint entry ('controller/x' -> 'restart__controller_x')."""
    base = "restart__" + re.sub(r"[^A-Za-z0-9_]", "_", name)
    out, i = base, 1
    while out in taken:
        out, i = f"{base}_{i}", i + 1
    taken.add(out)
    return out


def spinup_dataset(scene: Scene, grid, checkpoint: dict[str, Any], profiles: dict[str, np.ndarray],
                   history: dict[str, np.ndarray], converged: bool, reason: str, u_drive: float,
                   t_end: float, wall_time_s: float, key: str,
                   profile_window: tuple[float, float, int]) -> xr.Dataset:
    """The spin-up archive: restart checkpoint, ``flow_profiles`` averaged over ``profile_window =
    (t0, t1, n_samples)``, history of u* and TKE."""
    coords = coords_for(grid)
    data: dict[str, xr.Variable] = {}
    attrs: dict[str, Any] = {}
    manifest: dict[str, dict[str, Any]] = {}
    taken: set[str] = set()
    for name, val in checkpoint.items():
        kind = scalar_kind(val)
        if kind is not None:
            attr = _nc_name(name, taken)
            attrs[attr] = {"bool": int, "none": lambda _: ""}.get(kind, lambda x: x)(val)
            manifest[name] = {"kind": kind, "attr": attr}
            continue
        arr = np.asarray(val)
        if name in _STAGGERED and arr.shape == tuple(coords[d].size for d in _STAGGERED[name]):
            data[name] = _var(_STAGGERED[name], arr, name)
            manifest[name] = {"kind": "array", "var": name, "dtype": arr.dtype.str}
        else:
            var = _nc_name(name, taken)
            dims = tuple(f"{var}_dim{i}" for i in range(arr.ndim))
            if arr.dtype.kind == "b":
                arr = arr.astype(np.int8)
            data[var] = xr.Variable(dims, arr, attrs={
                "units": "1", "long_name": f"solver restart entry '{name}' (opaque to analysis)"})
            manifest[name] = {"kind": "array", "var": var, "dtype": np.asarray(val).dtype.str}
    for src, dst in PROFILE_NAMES.items():
        arr = np.asarray(profiles[src], dtype=np.float64)
        dim = "z_w" if arr.shape[0] == grid.nz + 1 else "z"
        data[dst] = _var((dim,), arr, dst)
    data.update(_history_vars(history))
    attrs.update(global_attrs(scene, wall_time_s, key))
    attrs.update({"converged": int(bool(converged)), "spinup_reason": str(reason),
                  "u_drive": float(u_drive), "t_end": float(t_end),
                  "profile_window_start": float(profile_window[0]),
                  "profile_window_end": float(profile_window[1]),
                  "profile_window_samples": int(profile_window[2]),
                  "restart_manifest": json.dumps(manifest, sort_keys=True)})
    return xr.Dataset(data, coords=coords, attrs=attrs)


def _history_vars(history: dict[str, np.ndarray]) -> dict[str, xr.Variable]:
    """Spin-up history ({"t": times, name: series}) -> ``time_hist``, ``<name>_hist``."""
    names = {k: "time_hist" if k == "t" else f"{k}_hist" for k in history}
    return {names[k]: _var(("time_hist",), v, names[k], np.float64) for k, v in history.items()}


def start_restart(ds: xr.Dataset, scene: Scene) -> dict[str, Any]:
    """The restart a saltation run of ``scene`` starts from: spinup.nc's, rescaled to the case's
    u*s when the spin-up ran at another u* (solver.similarity), tiled onto the scene's grid when
    it ran on ``scene.spinup_fidelity``'s (solver.tiling; project it before the first step), and
    lowered to the level of the saltating column with ``spinup.equilibrium_roughness``."""
    from ..solver.similarity import rescale_restart

    case = scene.case
    u_spin = float(ds.attrs.get("u_star_target", case.forcing.u_star_s))
    restart = rescale_restart(restart_from_dataset(ds), case.forcing.u_star_s / u_spin)
    if scene.spinup_fidelity is not None:
        from ..solver.grid import Grid
        from ..solver.tiling import tile_restart
        source = scene.spinup_scene()
        src, dst = Grid.from_spec(source.fidelity.grid), Grid.from_spec(scene.fidelity.grid)
        restart = tile_restart(restart, src, dst, src.Lz - source.damping_depth,
                               case.forcing.u_star_s, case.air.kappa)
    if scene.fidelity.spinup.equilibrium_roughness:
        from ..config import equilibrium_roughness
        from ..solver.similarity import shift_restart
        z0s = equilibrium_roughness(case)
        restart = shift_restart(restart, case.forcing.u_star_s / case.air.kappa
                                * math.log(z0s / case.surface.z0))
    return restart


def restart_from_dataset(ds: xr.Dataset) -> dict[str, Any]:
    """Rebuild the solver checkpoint dict stored in a spinup.nc (bit-for-bit)."""
    manifest = json.loads(ds.attrs["restart_manifest"])
    out: dict[str, Any] = {}
    for name, m in manifest.items():
        kind = m["kind"]
        if kind == "array":
            out[name] = np.ascontiguousarray(ds[m["var"]].values.astype(np.dtype(m["dtype"])))
        else:
            raw = ds.attrs[m["attr"]]
            out[name] = SCALAR_FROM[kind](raw.item() if hasattr(raw, "item") else raw)
    return out


# ---- samples.nc ----
_SERIES_NAMES = ("n_parcels", "n_impacts", "n_rebounds", "n_ejections", "n_depositions",
                 "G_tot_series", "u_star_ref", "u_drive", "dt", "max_cfl", "E_impact", "E_splash",
                 "bed_px", "bed_pz", *HEALTH_SERIES)
GRAIN_PROFILES = ("pm", "pmu", "pmv", "pmw", "pmuu", "pmuw", "pmww", "pmvv", "pn", "pdrag", "pmuf_up",
                  "pmuf", "pmuf_uf", "pmup_up")
_PROFILE_Z = ("u_mean", "tke_res", "e_sgs", "eps_sgs", "sgs_transfer") + GRAIN_PROFILES
_FIELDS_3D = ("u", "v", "w", "e", "p")


def samples_dataset(scene: Scene, grid, records: dict[str, tuple[np.ndarray, dict[str, np.ndarray]]],
                    z_plane: np.ndarray, d_edges: np.ndarray, t_activation: float,
                    wall_time_s: float, key: str, n_steps: int) -> xr.Dataset:
    """The saltation archive from the recorder's stacked groups, ``records[group] = (times,
    {name: stacked array})`` (driver.Recorder)."""
    coords = coords_for(grid)
    del coords["x_u"], coords["y_v"]  # samples are cell-centred
    t_s, series = records["series"]
    t_p, planes = records["plane"]
    t_3, samples = records["sample"]
    for name, values in (("time", t_3), ("time_plane", t_p), ("time_series", t_s),
                         ("z_plane", z_plane), ("d_bin", np.sqrt(d_edges[1:] * d_edges[:-1]))):
        coords[name] = _var((name,), values, name)
    data: dict[str, xr.Variable] = {"d_edges": _var(("d_edge",), d_edges, "d_edges")}
    for name in _SERIES_NAMES:
        data[name] = _var(("time_series",), series[name], name, np.float64)
    for name in ("C_p", "G_col", "C_p_above"):
        data[name] = _compressed(_var(("time_plane", "x", "y"), planes[name], name, np.float64))
    data["u_plane"] = _compressed(_var(("time_plane", "x", "y", "z_plane"), planes["u_plane"],
                                       "u_plane", np.float64))
    for name in _FIELDS_3D:
        if name in samples:  # p only with outputs.full_snapshots
            # float32: the 3-D fields are for spectra and pictures, not budgets (contract)
            data[name] = _compressed(_var(("time", "x", "y", "z"), samples[name], name, np.float32))
    data["C_p_s"] = _compressed(_var(("time", "x", "y"), samples["C_p_s"], "C_p_s", np.float64))
    for name in ("uw_res", "uw_sgs"):
        data[name] = _var(("time", "z_w"), samples[name], name, np.float64)
    for name in _PROFILE_Z:
        data[name] = _var(("time", "z"), samples[name], name, np.float64)
    data["size_hist"] = _var(("time", "z", "d_bin"), samples["size_hist"], "size_hist", np.float64)
    if "impact_hist" in samples:
        from ..solver.diagnostics.grains import impact_bins
        bins = impact_bins()
        for name, values in (("v_imp", bins["v_imp_edges"][:-1]),
                             ("impact_angle", bins["angle_edges"][:-1]), ("outcome", np.arange(3)),
                             ("hop_time", bins["hop_time_edges"][:-1]),
                             ("hop_length", bins["hop_length_edges"][:-1])):
            coords[name] = _var((name,), values, name)
        for name, dims in (("impact_hist", ("v_imp", "impact_angle")),
                           ("impact_outcomes", ("v_imp", "outcome")),
                           ("hop_time_hist", ("hop_time",)), ("hop_length_hist", ("hop_length",))):
            data[name] = _var(("time", *dims), samples[name], name, np.int64)
    attrs = global_attrs(scene, wall_time_s, key)
    attrs.update({"t_activation": float(t_activation), "n_steps": int(n_steps),
                  "planes_cover": "whole run" if scene.fidelity.outputs.animation
                  else "sampling window [sampling.start, sampling.end]"})
    return xr.Dataset(data, coords=coords, attrs=attrs)
