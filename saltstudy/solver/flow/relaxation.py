"""Column relaxation after saltation activation: a cost knob that shortens the transient, not
physics (docs/ARCHITECTURE.md, "Column relaxation").

The grains remove the smooth-bed column's excess momentum only through the bed, as fast as the
turbulence carries the deficit up (quick grid, case 2: 0.4-0.5 m^2 s^-2 drawn against u*s^2 =
0.29 after 50 s). While active, a uniform body force on u,

    B(t) = -K (tau_bed_f(t) - u*s^2) / Lz            [m s^-2],

tau_bed_f the bed's total kinematic x-stress filtered over T_f, gives Lz d<U>/dt = (1 + K)(u*s^2
- tau_bed): the same fixed point, (1 + K) times faster. It stops ``until`` s after activation,
before sampling. With the top drive ``state.u_drive`` gets the same increment, else the Rayleigh
layer pushes the column back after the switch-off (quick grid, case 2, K = 10: the grain stress
climbed back to 0.4-0.5 m^2 s^-2 without the shift, stayed at 0.25-0.31 with it).
"""
from __future__ import annotations

import math

import numpy as np


class ColumnRelaxation:
    """Uniform body force that speeds the column towards tau_bed = u*s^2 (see module docstring)."""

    name = "relaxation"

    def __init__(self, u_star_s: float, Lz: float, gain: float, timescale: float, until: float,
                 area: float, rho: float):
        self.target = float(u_star_s) ** 2      # u*s^2 [m^2 s^-2]
        self.Lz = float(Lz)                     # [m]
        self.gain = float(gain)                 # K [-]
        self.timescale = float(timescale)       # T_f [s]
        self.until = float(until)               # active for t - t_activation < until [s]
        self.area = float(area)                 # Lx Ly [m^2]
        self.rho = float(rho)                   # [kg m^-3]
        self.tau_bed_filtered = math.nan        # [m^2 s^-2]
        self.force = 0.0                        # B of the last step [m s^-2]
        self._p_last = 0.0   # the grains' cumulative x-momentum given to the air [kg m s^-1]

    def active(self, t_since_activation: float) -> bool:
        return self.gain > 0.0 and t_since_activation < self.until

    def bed_stress(self, taux: np.ndarray, p_to_air: float, dt: float) -> float:
        """Total kinematic x-stress at the bed this step [m^2 s^-2], positive for a drag: minus the
        mean of ``taux`` (u'w') plus the x-momentum the air lost to the grains per area and time."""
        dp = p_to_air - self._p_last
        self._p_last = p_to_air
        return -float(np.mean(taux, dtype=np.float64)) - dp / (dt * self.area * self.rho)

    def update(self, u: np.ndarray, taux: np.ndarray, p_to_air: float, dt: float,
               t_since_activation: float) -> float:
        """While active, apply B dt to u and return it [m s^-1] (a top drive adds it to u_drive)."""
        if not self.active(t_since_activation):
            self.force = 0.0
            return 0.0
        tau = self.bed_stress(taux, p_to_air, dt)
        if math.isnan(self.tau_bed_filtered):
            self.tau_bed_filtered = tau
        else:
            self.tau_bed_filtered += min(1.0, dt / self.timescale) * (tau - self.tau_bed_filtered)
        self.force = -self.gain * (self.tau_bed_filtered - self.target) / self.Lz
        u += self.force * dt
        return self.force * dt

    def checkpoint(self) -> dict:
        return {"tau_bed_filtered": float(self.tau_bed_filtered), "p_last": float(self._p_last)}

    def restore(self, data: dict) -> None:
        self.tau_bed_filtered = float(data["tau_bed_filtered"])
        self._p_last = float(data["p_last"])
