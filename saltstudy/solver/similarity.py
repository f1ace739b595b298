"""Reynolds-number similarity of the particle-free neutral surface layer over a rough bed
(docs/ARCHITECTURE.md, "Shared spin-up by similarity"): with no velocity scale of its own, the
LES solved by (u, e, p)(x, t) at u*1 is solved by (a u, a^2 e, a^2 p)(x, a t) at a u*1, so one
flow spun up at ``fidelity.spinup.u_star_ref`` serves every case's u*s. The molecular viscosity,
the fixed time constants and a binding dt_max break it slightly, decaying in seconds.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

# Restart entries that scale like a velocity [m s^-1] and like a velocity squared
# ([m^2 s^-2]: SGS TKE, kinematic pressure, kinematic stresses held by the drive controller).
VELOCITY_ENTRIES = ("u", "v", "w", "u_drive")
SQUARED_ENTRIES = ("e", "p", "controller/tau_ref_filtered", "controller/tau_ref_last")
#: entries of the flow's own parts that carry no velocity scale: the dynamic closure's
#: (C_s Delta)^2 [m^2] and beta [-] are lengths and ratios of the resolved field, unchanged
#: by a uniform rescaling of the velocities
INVARIANT_PREFIXES = ("controller/", "closure/")


def rescale_restart(ck: dict[str, Any], a: float) -> dict[str, Any]:
    """The particle-free restart ``ck`` with velocities times ``a``, their squares times a**2;
    ValueError for a non-positive ``a`` or a checkpoint with grain state (not self-similar)."""
    if not (math.isfinite(a) and a > 0):
        raise ValueError(f"rescale_restart: the scale factor must be positive and finite (got {a!r})")
    bad = sorted(k for k in ck if "/" in k and not k.startswith(INVARIANT_PREFIXES))
    if bad:
        raise ValueError(f"rescale_restart: only a particle-free state is self-similar; this "
                         f"checkpoint carries component entries {bad[:3]}")
    out = dict(ck)
    if a == 1.0:
        return out
    for names, factor in ((VELOCITY_ENTRIES, a), (SQUARED_ENTRIES, a * a)):
        for k in names:
            if k not in out:
                continue
            v = out[k]
            out[k] = np.asarray(v, dtype=np.float64) * factor if isinstance(v, np.ndarray) \
                else float(v) * factor
    return out


def shift_restart(ck: dict[str, Any], du: float) -> dict[str, Any]:
    """The restart ``ck`` with its streamwise wind and drive target lowered by ``du`` [m s^-1].

    Over a rougher bed (z0s > z0) the same stress holds the same shear with the mean wind lower by
    du = (u*s / kappa) ln(z0s / z0) at every height of the log layer; lowering u and u_drive alike
    leaves the Rayleigh layer's force, the turbulence and the divergence as they were."""
    if not math.isfinite(du):
        raise ValueError(f"shift_restart: the shift must be finite (got {du!r})")
    out = dict(ck)
    out["u"] = np.asarray(ck["u"], dtype=np.float64) - du
    out["u_drive"] = float(ck["u_drive"]) - du
    return out
