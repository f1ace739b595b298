"""How close a run is to the edge, recorded with the series: what sets the step (each candidate of
``Model.next_dt``), how stiff the grain-air coupling is, whether the parcel bookkeeping closes.

A grain of drag rate k_p (eqs. 3-4) in a cell of grain-to-air mass ratio phi relaxes with that
air at k_p (1 + phi), so ``tau_c_min = 1 / (k_max (1 + phi_max))`` bounds the coupled relaxation
time from below: an explicit exchange would need dt < ~tau_c_min, the point-implicit one
(grains/coupling.py) stays bounded beyond it. Re_p uses the resolved air at the parcel. Parcels
aloft = released + ejected - deposited, exactly; a residual means parcels leaked.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from .grains import grain_component

#: series the driver adds per record time: name -> (units, long_name)
HEALTH_SERIES: dict[str, tuple[str, str]] = {
    "dt_courant": ("s", "step allowed by the advective Courant limit (cfl / Courant rate)"),
    "dt_diffusion": ("s", "step allowed by the explicit diffusion limit (diffusion_number / rate)"),
    "dt_grains": ("s", "step allowed by the grain component (parcels cross at most one cell)"),
    "loading_max": ("1", "largest grain-to-air mass ratio of a grid cell"),
    "tau_c_min": ("s", "lower bound on the coupled grain-air relaxation time, "
                       "1 / (k_max (1 + loading_max))"),
    "parcel_balance": ("1", "parcels aloft minus (released + ejected - deposited)"),
}


def step_limits(model) -> dict[str, float]:
    """Candidate steps [s] of the current state; inf where a limit does not apply."""
    ts = model.scene.fidelity.time
    rate, drate = model.rates()
    out = {"dt_courant": ts.cfl / rate if rate > 0 else math.inf,
           "dt_diffusion": ts.diffusion_number / drate if drate > 0 else math.inf,
           "dt_grains": math.inf}
    for c in model.components:
        out["dt_grains"] = min(out["dt_grains"], float(c.max_dt(model.state)))
    return out


def coupling_stiffness(model) -> dict[str, float]:
    """``loading_max`` and ``tau_c_min`` (module docstring) of the current parcels; NaN if none."""
    s = grain_component(model)
    if s is None or s.n == 0:
        return {"loading_max": math.nan, "tau_c_min": math.nan}
    g = model.state.grid
    nx, ny, nz = g.shape
    x, y, z, d = s.x, s.y, s.z, s.d
    ix = np.clip((x / g.dx).astype(np.int64), 0, nx - 1)
    iy = np.clip((y / g.dy).astype(np.int64), 0, ny - 1)
    iz = np.clip(np.searchsorted(g.z_f, z, side="right") - 1, 0, nz - 1)
    grain = np.bincount((ix * ny + iy) * nz + iz, weights=s.Q * s.mass, minlength=nx * ny * nz)
    air = s.rho * np.broadcast_to(g.cell_volume, (nx, ny, nz)).ravel()
    loading_max = float(np.max(grain / air))
    uf, vf, wf = s.fluid_at_parcels(model.state)
    rel = np.sqrt((uf - s.u) ** 2 + (vf - s.v) ** 2 + (wf - s.w) ** 2)
    t_p = s.rho_p * d * d / (18.0 * s.rho * s.nu)
    k_max = float(np.max((1.0 + 0.15 * (rel * d / s.nu) ** 0.687) / t_p))
    return {"loading_max": loading_max, "tau_c_min": 1.0 / (k_max * (1.0 + loading_max))}


def parcel_balance(counters: dict[str, Any], n_released: int) -> int:
    """Parcels aloft minus (released + ejected - deposited): 0 when nothing leaks."""
    return int(counters["n_parcels"]) - (int(n_released) + int(counters["n_ejections"])
                                         - int(counters["n_depositions"]))
