"""Rayleigh damping layer below the free-slip lid (Klemp & Lilly 1978, J. Atmos. Sci. 35, 78).

In the top ``damping_depth`` D, du_i/dt += -f(z) (u_i - u_i,ref) with

    f(z) = (1/T) sin^2( (pi/2) (z - z_d) / D ),  z_d = Lz - D,  f = 0 below z_d,

T = ``damping_timescale`` [s]; u relaxes to state.u_drive (the top drive, forcing.py), v, w to
0. The ramp starts with zero slope, so the layer reflects little. The pressure-gradient drive
builds no layer: a neutral flow has no gravity waves to absorb, relaxing u would break
tau = G (H - z), and damping v, w would suppress the resolved stress under the lid.
"""
from __future__ import annotations

import numpy as np


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
