"""The SGS closure as one object, built by ``make_closure`` from a case's ``closure`` section:
``DeardorffClosure`` (the paper's prognostic TKE, sgs.py), ``DynamicClosure`` (dynamic.py) or
``NoClosure``. The stepper reads ``nu_mol``, per level ``l``, ``cml``, ``cml_v`` (c_m times the
horizontal and vertical viscosity lengths: nu_h = cml sqrt(e) + nu_mol), ``rv`` (vertical over
horizontal viscosity), ``ceps_l`` (c_eps / l), and ``rlog`` (1/(z_1 ln(z_1/z0)) [m^-1], the
log-law shear per unit first-level velocity); and calls ``begin_step``, ``viscosity``,
``end_step``.
"""
from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..._jit import pjit
from .sgs import (C_M, E_MIN, c_eps_profile, compute_nu, length_scale, viscosity_lengths)

#: the SGS models a case can name (config.Closure.model)
CLOSURES = ("deardorff", "dynamic")


@pjit
def apply_sink(e, rate, dt, e_min):
    """e <- max(e / (1 + rate dt), e_min): the grain sink of eq. A1, implicit (stable for any rate)."""
    nx, ny, nz = e.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                val = e[i, j, k] / (1.0 + rate[i, j, k] * dt)
                e[i, j, k] = val if val > e_min else e_min


def log_shear_factor(grid, z0: float) -> float:
    """1 / (z_1 ln(z_1 / z0)) [m^-1]: the log-law shear at the first level per unit velocity."""
    z1 = float(grid.z_c[0])
    return 1.0 / (z1 * math.log(z1 / z0))


class NoClosure:
    """No SGS stress and no SGS TKE (nu = 0 everywhere)."""

    prognostic_e = False
    #: whether it carries an SGS stress (False: the stepper integrates no diffusion)
    diffuses = False
    dynamic = None

    def __init__(self, grid, nu_mol: float = 0.0, rlog: float = 0.0):
        nz = grid.nz
        self.nu_mol = float(nu_mol)
        self.rlog = float(rlog)
        self.l = np.zeros(nz)
        self.cml = np.zeros(nz)
        self.cml_v = np.zeros(nz)
        self.rv = np.ones(nz)
        self.ceps_l = np.zeros(nz)

    def begin_step(self, state, dt: float) -> None:
        pass

    def viscosity(self, u, v, w, e, nu) -> None:
        nu[...] = 0.0

    def end_step(self, state, dt: float, nu) -> None:
        pass

    def checkpoint(self) -> dict:
        return {}

    def restore(self, data: dict) -> None:
        pass


class _EddyViscosityClosure(NoClosure):
    """What both SGS models share: the lengths."""

    diffuses = True

    def __init__(self, grid, spec, kappa: float, nu_mol: float, rlog: float, dtype=np.float64):
        super().__init__(grid, nu_mol, rlog)
        self.kappa = float(kappa)
        #: the floating type of the flow's fields (the stepper's)
        self.dtype = np.dtype(dtype)
        self.l = length_scale(grid, kappa, delta=spec.delta)
        l_h, l_v = viscosity_lengths(grid, kappa, spec.viscosity, spec.delta)
        self.cml = np.ascontiguousarray(C_M * l_h)
        self.cml_v = np.ascontiguousarray(C_M * l_v)
        # the vertical viscosity is nu rv (nu_mol rides along: 1e-5 - 1e-3 of nu_t)
        self.rv = np.ascontiguousarray(l_v / l_h)
        self.ceps_l = np.ascontiguousarray(c_eps_profile(grid, self.l, spec.delta) / self.l)
        # c_m l in the fields' type for the viscosity kernel
        self._cml_t = np.asarray(self.cml, self.dtype)


class DeardorffClosure(_EddyViscosityClosure):
    """The paper's closure: nu_t = c_m l sqrt(e), e prognostic, the grain sink implicit."""

    prognostic_e = True

    def viscosity(self, u, v, w, e, nu) -> None:
        compute_nu(e, self._cml_t, self.dtype.type(self.nu_mol), nu)

    def end_step(self, state, dt: float, nu) -> None:
        if state.tke_sink is not None:
            apply_sink(state.e, state.tke_sink, dt, E_MIN)


class DynamicClosure(_EddyViscosityClosure):
    """The scale-dependent dynamic Smagorinsky model (dynamic.py)."""

    def __init__(self, grid, spec, kappa: float, nu_mol: float, rlog: float, dtype=np.float64):
        super().__init__(grid, spec, kappa, nu_mol, rlog, dtype)
        from .dynamic import DynamicSmagorinsky
        self.dynamic = DynamicSmagorinsky(grid, self.kappa, self.rlog, spec.delta,
                                          spec.dynamic_interval)
        # nu = C_K l sqrt(e) with the diagnosed e, so every reader of (cml, e) gets the acting
        # viscosity; c_eps/l follows the coefficient (shared arrays, updated in place)
        self.cml = self.dynamic.ckl
        self.cml_v = self.dynamic.ckl
        self.ceps_l = self.dynamic.ceps_l
        #: the grain sink rate of eq. A1 [s^-1] seen by the diagnosed e (set per step)
        self._sink = None
        self._e_stage = np.zeros(grid.shape, self.dtype)

    def begin_step(self, state, dt: float) -> None:
        self.dynamic.maybe_update(state)
        self._sink = state.tke_sink

    def viscosity(self, u, v, w, e, nu) -> None:
        self.dynamic.viscosity(u, v, w, self._sink, self.nu_mol, nu, self._e_stage)

    def end_step(self, state, dt: float, nu) -> None:
        # e of the new state, in equilibrium with its strain and the grains' sink
        self.dynamic.viscosity(state.u, state.v, state.w, self._sink, self.nu_mol, nu, state.e)

    def checkpoint(self) -> dict:
        return self.dynamic.checkpoint()

    def restore(self, data: dict) -> None:
        if data:
            self.dynamic.restore(data)


def make_closure(grid, spec=None, *, kappa: float = 0.4, z0: float = 1e-5, nu_mol: float = 1.5e-5,
                 wall: bool = True, enabled: bool = True, dtype=np.float64):
    """The closure of a case's ``closure`` section (None: the defaults; ``enabled`` False: none)."""
    if spec is None:
        from ...config import Closure
        spec = Closure()
    rlog = log_shear_factor(grid, z0) if wall else 0.0
    if not enabled:
        return NoClosure(grid, nu_mol, rlog)
    cls = DynamicClosure if spec.model == "dynamic" else DeardorffClosure
    return cls(grid, spec, kappa, nu_mol, rlog, dtype)
