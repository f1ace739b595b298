"""What a saltation run records at one time, by group (no I/O; the workflow stacks them into
samples.nc, docs/ARCHITECTURE.md): ``series`` (counters, u*, the drive, the step and its limits,
``health``), ``planes`` (C_p, G_col, u on the plane heights) and ``sample`` (the 3-D fields in
float32, the mean profiles, the size histogram, the impact record).
"""
from __future__ import annotations

import numpy as np

from . import flow as dflow
from . import grains as dgrains
from . import health


def series(model, z_ref: float, n_released: int, last_dt: float, last_cfl: float) -> dict:
    """One record of the time series; ``n_released``: parcels released at activation."""
    c = dgrains.grain_counters(model)
    return {
        "n_parcels": c["n_parcels"], "n_impacts": c["n_impacts"],
        "n_rebounds": c["n_rebounds"], "n_ejections": c["n_ejections"],
        "n_depositions": c["n_depositions"], "G_tot_series": c["G_tot"],
        "u_star_ref": dflow.u_star_at(model, z_ref), "u_drive": model.state.u_drive,
        "dt": last_dt, "max_cfl": last_cfl, "E_impact": c["E_impact"], "E_splash": c["E_splash"],
        "bed_px": c["bed_px"], "bed_pz": c["bed_pz"],
        **health.step_limits(model), **health.coupling_stiffness(model),
        "parcel_balance": health.parcel_balance(c, n_released)}


def planes(model, z_plane: np.ndarray) -> dict:
    """One record of the planes on the heights ``z_plane`` [m]."""
    gp = dgrains.grain_planes(model)
    fp = dflow.flow_planes(model, z_plane)
    return {"C_p": gp["C_p"], "C_p_above": gp["C_p_above"], "G_col": gp["G_col"],
            "u_plane": fp["u_plane"]}


def sample(model, d_edges: np.ndarray, full: bool = False) -> dict:
    """One 3-D sample; ``d_edges``: the size histogram's edges [m]; ``full``: with p."""
    uc, vc, wc = dflow.cell_centred_velocity(model)
    fp = dflow.flow_profiles(model)
    rec = {"u": uc.astype(np.float32), "v": vc.astype(np.float32), "w": wc.astype(np.float32),
           "e": model.state.e.astype(np.float32),
           "C_p_s": dgrains.grain_planes(model)["C_p"],
           "uw_res": fp["uw_res"], "uw_sgs": fp["uw_sgs"], "u_mean": fp["u"],
           "tke_res": fp["tke_res"], "e_sgs": fp["e_sgs"], "eps_sgs": fp["eps_sgs"],
           "sgs_transfer": fp["sgs_transfer"],
           "size_hist": dgrains.grain_size_hist(model, d_edges),
           **dgrains.impact_record(model)}
    rec.update(dgrains.grain_profiles(model))
    if full:
        rec["p"] = model.state.p.astype(np.float32)
    return rec
