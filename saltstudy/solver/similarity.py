"""Reynolds-number similarity of the particle-free neutral surface layer over a rough bed.

Without grains, buoyancy or a resolved viscous layer, the LES equations (advection, pressure,
Deardorff SGS TKE, the log-law wall stress with a fixed z0, the drive) have no velocity scale of their own: if (u, e, p)(x, t) solves them at friction velocity
u*1, then (a u, a^2 e, a^2 p)(x, a t) solves them at u*2 = a u*1. One spun-up flow therefore
serves every case with the same bed, domain and closure: spin it up once at a reference u*
(``fidelity.spinup.u_star_ref``) and rescale it to each case's u*s when saltation is activated.

What breaks the symmetry is small and decays during the first seconds of saltation, long before
sampling starts: the molecular viscosity (1.5e-5 m^2 s^-1 against an SGS viscosity of ~kappa z u*
~ 1e-3 m^2 s^-1 at the first level), the fixed time constants of the top drive's controller and
of the Rayleigh layer, and dt_max if it binds. The number of time steps a spin-up needs is the
same at any u* (the eddy turnover time H/u* and the Courant-limited step both scale with 1/u*),
so the saving is the number of spin-ups: one instead of one per distinct u*s.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["rescale_restart", "VELOCITY_ENTRIES", "SQUARED_ENTRIES", "INVARIANT_PREFIXES"]

# Restart entries that scale like a velocity [m s^-1] and like a velocity squared
# ([m^2 s^-2]: SGS TKE, kinematic pressure, kinematic stresses held by the drive controller).
VELOCITY_ENTRIES = ("u", "v", "w", "u_drive")
SQUARED_ENTRIES = ("e", "p", "controller/tau_ref_filtered", "controller/tau_ref_last")
#: entries of the flow's own parts that carry no velocity scale: the dynamic closure's
#: (C_s Delta)^2 [m^2] and beta [-] are lengths and ratios of the resolved field, unchanged
#: by a uniform rescaling of the velocities
INVARIANT_PREFIXES = ("controller/", "closure/")


def rescale_restart(ck: dict[str, Any], a: float) -> dict[str, Any]:
    """A copy of the particle-free restart ``ck`` with velocities times ``a`` and squared
    velocities times ``a**2`` (the clock is left alone: only durations matter downstream).

    Raises ValueError for a non-positive or non-finite ``a`` or a checkpoint carrying grain
    state (a saltating flow has the grains' own scales and is not self-similar).
    """
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
