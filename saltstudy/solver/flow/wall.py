"""Bed boundary condition: local log-law stress at the first u, v level (Moeng 1984, J. Atmos. Sci.
41, 2052; Bou-Zeid et al. 2005, Phys. Fluids 17, 025105):

    tau_s,x = -C_d |U_1| u_1,   tau_s,y = -C_d |U_1| v_1,   C_d = [kappa / ln(z_1/z0)]^2,

|U_1| the horizontal speed at the first level z_1 = z_c[0] at the u (v) point (the other
component the four-point mean). tau_s are u'w', v'w' at the bed [m^2 s^-2]; w = 0 there.
"""
from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..._jit import pjit


def drag_coefficient(z1: float, z0: float, kappa: float) -> float:
    """C_d = [kappa / ln(z1/z0)]^2 [-] for the first level z1 [m] and roughness z0 [m]."""
    if z1 <= z0:
        raise ValueError(f"first level z1 = {z1:g} m must lie above the roughness length z0 = {z0:g} m")
    return (kappa / math.log(z1 / z0)) ** 2


@pjit
def surface_stress_into(u, v, cd, taux, tauy):
    """taux, tauy (nx, ny) = local log-law kinematic stress at the bed [m^2 s^-2]."""
    nx, ny, nz = u.shape
    for i in prange(nx):
        im = (i - 1) % nx
        ip = (i + 1) % nx
        for j in range(ny):
            jm = (j - 1) % ny
            jp = (j + 1) % ny
            uc = u[i, j, 0]
            vbar = 0.25 * (v[im, j, 0] + v[im, jp, 0] + v[i, j, 0] + v[i, jp, 0])
            taux[i, j] = -cd * math.sqrt(uc * uc + vbar * vbar) * uc
            vc = v[i, j, 0]
            ubar = 0.25 * (u[i, jm, 0] + u[ip, jm, 0] + u[i, j, 0] + u[ip, j, 0])
            tauy[i, j] = -cd * math.sqrt(vc * vc + ubar * ubar) * vc


def surface_stress(u, v, cd):
    """(taux, tauy) arrays (nx, ny) [m^2 s^-2]."""
    taux = np.empty(u.shape[:2])
    tauy = np.empty(u.shape[:2])
    surface_stress_into(u, v, cd, taux, tauy)
    return taux, tauy
