"""Column relaxation after saltation activation: a cost knob that shortens the transient, not physics.

Why. Saltation starts on a particle-free flow whose whole column carries the momentum of a smooth bed
(z0). The saltation layer's equilibrium is a rougher bed (z0s), i.e. the same stress with the mean
wind lower by about (u*s / kappa) ln(z0s / z0) at every height above the layer. The grains can only
remove that excess momentum through the bed stress excess tau_bed - u*s^2, and only as fast as the
turbulence carries the deficit up the column: measured on the quick grid (case 2, 4 m column), the
grains still drew 0.4-0.5 m^2 s^-2 against a supply of u*s^2 = 0.29 m^2 s^-2 after 50 s, with
2-5x the equilibrium number of parcels in the air. The paper lets its 12 m column relax for 200 s
before sampling; a laptop study cannot.

What. While active, a horizontally uniform body force

    B(t) = -K (tau_bed_f(t) - u*s^2) / Lz            [m s^-2]

acts on u everywhere, where tau_bed_f is the bed's total kinematic x-stress (air surface stress
plus the momentum the air gives to the grains, per unit area) filtered with an exponential running
mean of time scale T_f. The column's mean momentum then obeys Lz d<U>/dt = (1 + K)(u*s^2 - tau_bed):
the same fixed point (B = 0 exactly when the bed stress equals the supply) reached about (1 + K)
times faster. A uniform force has no divergence and no horizontal structure: it does not act on the
turbulence directly. It is switched off at ``until`` seconds after activation, before sampling, so
the sampled flow runs free; the fidelity's ``relaxation`` block documents the knob and
``paper`` leaves it off.

With the top drive the same increment is added to ``state.u_drive``: the Rayleigh layer relaxes u
towards u_drive, and a column shifted without its drive target would be pushed back up by the layer
and its slow controller for ~20 s after the force stops. Measured on the quick grid (case 2, K = 10,
until 12 s): without the shift the grain stress climbed from 0.3 back to 0.4-0.5 m^2 s^-2 after the
switch-off (and to 0.5 in the reduced grid's case 9, sampled out of equilibrium); with it the bed
stress stayed at 0.25-0.31 m^2 s^-2 (u*s^2 = 0.29) from 3 s to 29 s.

Profile target (``relaxation.target = "profile"``, ``ProfileRelaxation``)
-------------------------------------------------------------------------

The bed stress is the wrong measure of the column: it settles with the wind of the saltation layer
within seconds while the air above still carries the smooth bed's momentum (the reduced study, 12-42
s: the column above 2 m gives up 0.18 u*s^2 on average, 0.39 in case 1; reports/reduced/FINDINGS.md).
The saltation equilibrium above the layer is the particle-free flow at the same stress with the
mean wind lower by a constant, (u*s / kappa) ln(z0s / z0) in log-law terms: the outer flow keeps its
shape (the same stress, hence the same shear) and only its level is set by the rougher bed. The
profile target imposes that while it is active: the horizontal mean of u at each level above the
anchor height z_a is nudged, with time scale T, towards

    U_t(z) = U(z_a) + S(z) - S(z_a),                                        [m s^-1]

S the particle-free mean profile of the spin-up rescaled to u*s (its window mean, the shape with the
stress u*s^2 at every height) and U(z_a) the present horizontal mean at z_a. The air below z_a and
the grains run free, so the saltation layer sets its own wind, hence z0s (z0s = z_a exp(-kappa
U(z_a) / u*s) in log-law terms), and the column above follows it; no z0s is assumed. The force is
applied with the weight w(z) = min(1, log2(z / z_a)) above z_a (0 below; full from 2 z_a up), is
horizontally uniform on each level (no divergence, no action on the turbulence), and is zero
exactly when the mean profile above z_a has the particle-free shape. With the top drive, u_drive is
nudged with the same T towards the feed-forward of U_t (forcing.py), the value at which the
Rayleigh layer feeds u*s^2 into a column of that profile, so that the drive does not push the
column back once the nudging stops. The paper's column reaches that state by itself after minutes
(it samples from 200 s); this one is put there in the first ``until`` seconds.
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["ColumnRelaxation", "ProfileRelaxation", "make_relaxation"]


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
        # the grains' cumulative x-momentum given to the air [kg m s^-1] at the last step (their
        # counter starts at 0 on activation)
        self._p_last = 0.0

    def active(self, t_since_activation: float) -> bool:
        return self.gain > 0.0 and t_since_activation < self.until

    def bed_stress(self, taux: np.ndarray, p_to_air: float, dt: float) -> float:
        """Total kinematic x-stress at the bed this step [m^2 s^-2], positive for a drag: the mean
        air surface stress (``taux`` is the flux u'w', negative for a drag) plus the x-momentum the
        air lost to the grains (``p_to_air`` falls) per unit area and time."""
        dp = p_to_air - self._p_last
        self._p_last = p_to_air
        return -float(np.mean(taux)) - dp / (dt * self.area * self.rho)

    def update(self, u: np.ndarray, taux: np.ndarray, p_to_air: float, dt: float,
               t_since_activation: float) -> float:
        """While active, filter the bed stress over the step just taken and apply B dt to u.
        Returns the increment B dt [m s^-1] (0 when inactive, and the filter then stops: nothing
        reads it after the switch-off): a top drive must shift its ``u_drive`` by it too (see the
        module docstring)."""
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

    def start(self, model, reference_profile: np.ndarray | None = None) -> None:
        """At activation: nothing to set (the bed stress needs no reference)."""

    def step(self, model, dt: float) -> None:
        """The step of ``model`` (after its flow step): B dt on u and, with the top drive, on u_drive."""
        du = self.update(model.state.u, model.stepper.taux,
                         float(model.components[0].momentum_to_air[0]), dt,
                         model.state.t - model.t_activation)
        if model.drive == "top":
            model.state.u_drive += du

    def checkpoint(self) -> dict:
        return {"tau_bed_filtered": float(self.tau_bed_filtered), "p_last": float(self._p_last)}

    def restore(self, data: dict) -> None:
        self.tau_bed_filtered = float(data["tau_bed_filtered"])
        self._p_last = float(data["p_last"])


class ProfileRelaxation:
    """Nudges the mean profile above the anchor towards the particle-free shape offset to the
    saltation layer's own wind (module docstring, "Profile target")."""

    name = "relaxation"

    def __init__(self, z_c: np.ndarray, anchor: float, timescale: float, until: float):
        z_c = np.asarray(z_c, dtype=np.float64)
        if not z_c[0] < anchor < z_c[-1]:
            raise ValueError(f"ProfileRelaxation: the anchor height {anchor:g} m must lie between "
                             f"the first and the last level ({z_c[0]:g}, {z_c[-1]:g} m)")
        self.anchor = float(anchor)              # z_a [m]
        self.timescale = float(timescale)        # T [s]
        self.until = float(until)                # active for t - t_activation < until [s]
        # the levels bracketing z_a and the linear weight between them
        k = int(np.searchsorted(z_c, self.anchor)) - 1
        self._k, self._w = k, float((self.anchor - z_c[k]) / (z_c[k + 1] - z_c[k]))
        self.weight = np.clip(np.log2(np.maximum(z_c, 1e-300) / self.anchor), 0.0, 1.0)
        #: S(z) - S(z_a) [m s^-1], set at activation (``start``)
        self.shape: np.ndarray | None = None
        self.force = np.zeros_like(z_c)          # B(z) of the last step [m s^-2]

    def active(self, t_since_activation: float) -> bool:
        return t_since_activation < self.until

    def anchor_wind(self, u_mean: np.ndarray) -> float:
        """U(z_a): the horizontal-mean profile ``u_mean`` (nz,) interpolated at the anchor [m s^-1]."""
        k, w = self._k, self._w
        return float((1.0 - w) * u_mean[k] + w * u_mean[k + 1])

    def start(self, model, reference_profile: np.ndarray | None = None) -> None:
        """Set S from ``reference_profile`` (nz,) [m s^-1], the particle-free mean profile at this
        case's u*s (the spin-up's window mean rescaled), or, without one, the horizontal mean of u
        at activation (one instant of the particle-free flow: its phase of the box's swings)."""
        prof = (model.state.u.mean(axis=(0, 1)) if reference_profile is None
                else np.asarray(reference_profile, dtype=np.float64))
        if prof.shape != self.weight.shape:
            raise ValueError(f"ProfileRelaxation: the reference profile has shape {prof.shape}, "
                             f"the grid has {self.weight.shape[0]} levels")
        self.shape = prof - self.anchor_wind(prof)

    def target(self, u_mean: np.ndarray) -> np.ndarray:
        """U_t(z) [m s^-1] for the present horizontal-mean profile ``u_mean`` (nz,)."""
        if self.shape is None:
            raise RuntimeError("ProfileRelaxation: no reference profile (start() sets it at activation)")
        return self.anchor_wind(u_mean) + self.shape

    def update(self, u: np.ndarray, dt: float, t_since_activation: float) -> np.ndarray | None:
        """While active, nudge each level of ``u`` (nx, ny, nz) towards U_t over dt; returns U_t
        (None when inactive)."""
        if not self.active(t_since_activation):
            self.force[...] = 0.0
            return None
        u_mean = u.mean(axis=(0, 1))
        tgt = self.target(u_mean)
        a = min(1.0, dt / self.timescale)
        self.force = -self.weight * a * (u_mean - tgt) / dt
        u += (self.force * dt)[None, None, :]
        return tgt

    def step(self, model, dt: float) -> None:
        """The step of ``model``: the nudge on u and, with the top drive, on u_drive (towards the
        controller's feed-forward of U_t)."""
        tgt = self.update(model.state.u, dt, model.state.t - model.t_activation)
        if tgt is not None and model.drive == "top":
            a = min(1.0, dt / self.timescale)
            s = model.state
            s.u_drive += a * (model.controller.feed_forward(tgt) - s.u_drive)

    def checkpoint(self) -> dict:
        return {} if self.shape is None else {"shape": np.array(self.shape, copy=True)}

    def restore(self, data: dict) -> None:
        if "shape" in data:
            self.shape = np.asarray(data["shape"], dtype=np.float64).copy()


def make_relaxation(scene, grid):
    """The relaxation ``scene.fidelity.relaxation`` asks for, or None (off, or no grains)."""
    rl, case = scene.fidelity.relaxation, scene.case
    if not rl.on:
        return None
    if rl.target == "profile":
        return ProfileRelaxation(grid.z_c, rl.anchor, rl.timescale, rl.until)
    return ColumnRelaxation(case.forcing.u_star_s, grid.Lz, rl.gain, rl.timescale, rl.until,
                            grid.Lx * grid.Ly, case.air.rho)
