"""Rayleigh damping layer below the free-slip lid (Klemp & Lilly 1978, J. Atmos. Sci. 35, 78).

In the top ``damping_depth`` D of the domain, du_i/dt += -f(z) (u_i - u_i,ref) with

    f(z) = (1/T) sin^2( (pi/2) (z - z_d) / D ),  z_d = Lz - D,  f = 0 below z_d,

T = ``damping_timescale`` [s] the relaxation time at the lid. References: u -> state.u_drive (the
base-state wind that drives the flow, set by forcing.py), v, w -> 0. The sin^2 ramp starts with zero
slope so that the layer reflects little of the upward-travelling disturbances.

Only the top drive (``forcing.drive = "top"``) uses the layer. With the pressure-gradient drive the
model builds no damping layer at all (the fidelity's ``damping_depth`` is ignored): the flow is
neutral, so there are no gravity waves to absorb, and the free-slip lid (w = 0, no stress) is the
standard open-channel top; relaxing u there would add a drag that breaks tau = G (H - z), and
damping v, w would suppress the resolved stress under the lid.
"""
from __future__ import annotations

import numpy as np

__all__ = ["rayleigh_profile", "damping_profiles"]


def rayleigh_profile(z: np.ndarray, Lz: float, depth: float, timescale: float) -> np.ndarray:
    """f(z) [s^-1] (see module docstring); zero everywhere for depth = 0."""
    z = np.asarray(z, dtype=np.float64)
    if depth <= 0.0:
        return np.zeros_like(z)
    s = np.clip((z - (Lz - depth)) / depth, 0.0, 1.0)
    return np.sin(0.5 * np.pi * s) ** 2 / timescale


def damping_profiles(grid, depth: float, timescale: float) -> tuple[np.ndarray, np.ndarray]:
    """f at the centres (nz,) and at the faces (nz+1,) [s^-1]."""
    return (rayleigh_profile(grid.z_c, grid.Lz, depth, timescale),
            rayleigh_profile(grid.z_f, grid.Lz, depth, timescale))
