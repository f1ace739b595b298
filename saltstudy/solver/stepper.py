"""The flow time step: Wicker & Skamarock (2002, Mon. Wea. Rev. 130, 2088) RK3 with a projection per
stage.

    phi(1) = phi(n) + dt/3 F(phi(n)),  phi(2) = phi(n) + dt/2 F(phi(1)),  phi(n+1) = phi(n) + dt F(phi(2))

for phi = (u, v, w, e), each stage followed by the pressure projection of (u, v, w) (pressure.py).
Per stage: boundary (bed stress, eddy viscosity from the stage's e) -> one fused kernel for
advection + SGS diffusion + Rayleigh damping + drive (u_drive through the damping layer, or a
uniform body force G) of u, v, w -> one fused kernel for the SGS TKE
equation (advection, production, transport, dissipation) -> projection. The particle sink of e (paper
eq. A1, rates in ``state.tke_sink`` [s^-1]) is applied once per step, implicitly:
e <- e / (1 + rate dt), which is unconditionally stable for any rate.

With the dynamic closure (dynamic_sgs.py) e is not prognostic: the coefficient (C_s Delta)^2(z) is
refreshed at the start of every ``dynamic_interval``-th step, nu_t comes from each stage's strain,
there is no TKE kernel, and e (with the grain sink inside its equilibrium) is diagnosed from the
new state at the end of the step.

Memory: the base fields phi(n) stay in the state arrays (stage 3 writes them point by point after
reading them), so two extra sets of (u, v, w, e) suffice; no array is allocated inside a step.
"""
from __future__ import annotations

import math

import numpy as np
from numba import prange

from .._jit import jit_with, pjit
from .advection import adv_scalar_at, adv_u_at, adv_v_at, adv_w_at
from .damping import damping_profiles
from .pressure import PressureSolver
from .sgs import (C_M, E_MIN, c_eps_profile, compute_nu, diff_u_at, diff_v_at, diff_w_at,
                  length_scale, tke_tendency_at, viscosity_lengths)
from .wall import drag_coefficient, surface_stress_into

__all__ = ["Stepper", "RK3_COEFFS", "CLOSURES"]

RK3_COEFFS = (1.0 / 3.0, 0.5, 1.0)
#: the SGS closures a stepper can carry
CLOSURES = ("deardorff", "dynamic")

device = jit_with(inline="always")


@device
def _uv_point(u, v, w, nu, rv, taux, tauy, ub, vb, uo, vo, i, j, k, im, ip, jm, jp, top, bot, cdt,
              rdx, rdy, dzc, dzf, fck, fcuk, srck, with_adv, with_diff):
    # srck = gx + fcuk u_drive (drive and damping target folded: CPython passes calls of more
    # than 30 arguments as a tuple, which numba cannot inline)
    r = 1.0 / dzc[k]
    tu = srck - fcuk * u[i, j, k]
    tv = -fck * v[i, j, k]
    if with_adv:
        tu += adv_u_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, r)
        tv += adv_v_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, r)
    if with_diff:
        tu += diff_u_at(u, v, w, nu, rv, taux, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, dzc, dzf)
        tv += diff_v_at(u, v, w, nu, rv, tauy, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, dzc, dzf)
    uo[i, j, k] = ub[i, j, k] + cdt * tu
    vo[i, j, k] = vb[i, j, k] + cdt * tv


@pjit
def _momentum_stage(u, v, w, nu, rv, taux, tauy, ub, vb, wb, uo, vo, wo, cdt, rdx, rdy, dzc, dzf,
                    fc, fcu, ff, u_drive, gx, with_adv, with_diff):
    """uo = ub + cdt (advection + SGS diffusion + damping + drive)(u) for u, v, w (interior w only).

    Damping rates: fcu for u (towards u_drive), fc for v (towards 0) at the centres, ff for w at the
    faces; gx [m s^-2] a uniform streamwise body force (mean pressure gradient, -1/rho dP/dx).

    The first and last levels are peeled off with literal top/bot flags, so that the interior
    k loop is branch-free.
    """
    nx, ny, nz = u.shape
    for i in prange(nx):
        im = (i - 1) % nx
        ip = (i + 1) % nx
        for j in range(ny):
            jm = (j - 1) % ny
            jp = (j + 1) % ny
            _uv_point(u, v, w, nu, rv, taux, tauy, ub, vb, uo, vo, i, j, 0, im, ip, jm, jp, True, False,
                      cdt, rdx, rdy, dzc, dzf, fc[0], fcu[0], gx + fcu[0] * u_drive, with_adv, with_diff)
            for k in range(1, nz - 1):
                _uv_point(u, v, w, nu, rv, taux, tauy, ub, vb, uo, vo, i, j, k, im, ip, jm, jp, True,
                          True, cdt, rdx, rdy, dzc, dzf, fc[k], fcu[k], gx + fcu[k] * u_drive, with_adv,
                          with_diff)
            _uv_point(u, v, w, nu, rv, taux, tauy, ub, vb, uo, vo, i, j, nz - 1, im, ip, jm, jp, False,
                      True, cdt, rdx, rdy, dzc, dzf, fc[nz - 1], fcu[nz - 1], gx + fcu[nz - 1] * u_drive,
                      with_adv, with_diff)
            wo[i, j, 0] = 0.0
            wo[i, j, nz] = 0.0
            for k in range(1, nz):
                tw = -ff[k] * w[i, j, k]
                if with_adv:
                    hzm = 0.5 * dzc[k - 1] / dzf[k]
                    hzp = 0.5 * dzc[k] / dzf[k]
                    tw += adv_w_at(u, v, w, i, j, k, im, ip, jm, jp, rdx, rdy, hzm, hzp, 1.0 / dzf[k])
                if with_diff:
                    tw += diff_w_at(u, v, w, nu, rv, i, j, k, im, ip, jm, jp, rdx, rdy, dzc, dzf)
                wo[i, j, k] = wb[i, j, k] + cdt * tw


@device
def _e_point(e, u, v, w, nu, rv, eb, eo, i, j, k, im, ip, jm, jp, top, bot, cdt, rdx, rdy, rdzc,
             rdzf, rlog, ceps_lk, e_min, mdu, mdv):
    te = adv_scalar_at(e, u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc[k])
    te += tke_tendency_at(e, u, v, w, nu, rv, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc, rdzf,
                          rlog, ceps_lk, mdu, mdv)
    val = eb[i, j, k] + cdt * te
    eo[i, j, k] = val if val > e_min else e_min


@pjit
def _tke_stage(e, u, v, w, nu, rv, eb, eo, cdt, rdx, rdy, rdzc, rdzf, rlog, ceps_l, e_min, mdu, mdv):
    """eo = max(eb + cdt (advection + P + transport - eps), e_min) (levels peeled as above);
    rdzc, rdzf: 1/dz_c, 1/dz_f."""
    nx, ny, nz = e.shape
    for ii in prange(nx):
        i = np.int64(ii)  # signed: strain_sq_at indexes with i directly
        im = (i - 1) % nx
        ip = (i + 1) % nx
        for j in range(ny):
            jm = (j - 1) % ny
            jp = (j + 1) % ny
            _e_point(e, u, v, w, nu, rv, eb, eo, i, j, 0, im, ip, jm, jp, True, False, cdt, rdx, rdy,
                     rdzc, rdzf, rlog, ceps_l[0], e_min, mdu, mdv)
            for k in range(1, nz - 1):
                _e_point(e, u, v, w, nu, rv, eb, eo, i, j, k, im, ip, jm, jp, True, True, cdt, rdx, rdy,
                         rdzc, rdzf, rlog, ceps_l[k], e_min, mdu, mdv)
            _e_point(e, u, v, w, nu, rv, eb, eo, i, j, nz - 1, im, ip, jm, jp, False, True, cdt, rdx,
                     rdy, rdzc, rdzf, rlog, ceps_l[nz - 1], e_min, mdu, mdv)


@pjit
def _apply_sink(e, rate, dt, e_min):
    nx, ny, nz = e.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                val = e[i, j, k] / (1.0 + rate[i, j, k] * dt)
                e[i, j, k] = val if val > e_min else e_min


class Stepper:
    """RK3 flow stepper for one grid and one scene's flow parameters (work arrays preallocated)."""

    def __init__(self, grid, *, z0: float, kappa: float, nu_mol: float, damping_depth: float,
                 damping_timescale: float, workers: int | None = None, advection: bool = True,
                 sgs: bool = True, wall: bool = True, damp_u: bool = True, body_force: float = 0.0,
                 near_wall_layer: tuple[float, float] | None = None, delta: str = "scotti",
                 viscosity: str = "isotropic", closure: str = "deardorff", dynamic_interval: int = 5,
                 two_part: bool = False):
        """``damp_u``: the Rayleigh layer acts on u (towards ``state.u_drive``; the top drive) or
        not (v and w only); ``body_force`` G [m s^-2]: uniform streamwise acceleration added to u
        everywhere (the mean pressure gradient drive, forcing.py); ``near_wall_layer`` (a, b): the
        near-wall mean-field eddy viscosity of nearwall.py over that layer (in dx), None: none;
        ``delta``: the SGS filter width, "scotti" or "geometric" (sgs.delta_profile);
        ``viscosity``: one eddy viscosity ("isotropic") or separate horizontal and vertical ones
        ("anisotropic", sgs.viscosity_lengths); ``closure``: the SGS model, "deardorff" (the
        paper's prognostic TKE, sgs.py) or "dynamic" (the plane-averaged scale-dependent dynamic
        Smagorinsky model with e diagnosed, dynamic_sgs.py; its coefficient recomputed every
        ``dynamic_interval`` steps); ``two_part``: the isotropy factor and mean-field viscosity of
        Sullivan et al. (1994) on top of either closure (twopart.py; not with ``near_wall_layer``)."""
        if closure not in CLOSURES:
            raise ValueError(f"closure must be one of {CLOSURES} (got {closure!r})")
        if closure == "dynamic" and viscosity != "isotropic":
            raise ValueError("the dynamic closure has one eddy viscosity: viscosity must be 'isotropic'")
        if two_part and near_wall_layer is not None:
            raise ValueError("the two-part model carries its own mean-field viscosity: no near-wall layer")
        self.grid = grid
        nx, ny, nz = grid.shape
        self.z0, self.kappa, self.nu_mol = float(z0), float(kappa), float(nu_mol)
        self.advection, self.sgs, self.wall = bool(advection), bool(sgs), bool(wall)
        self.l = length_scale(grid, kappa, delta=delta)   # the dissipation length
        l_h, l_v = viscosity_lengths(grid, kappa, viscosity, delta)
        self.cml = np.ascontiguousarray(C_M * l_h)          # nu_h = cml sqrt(e) (+ nu_mol)
        self.cml_v = np.ascontiguousarray(C_M * l_v)        # nu_v = cml_v sqrt(e)
        # the vertical viscosity is nu rv: the kernels carry one field (nu_mol rides along, a
        # relative 1e-5 - 1e-3 of nu_t)
        self.rv = np.ascontiguousarray(l_v / l_h)
        self.ceps_l = np.ascontiguousarray(c_eps_profile(grid, self.l, delta) / self.l)
        z1 = float(grid.z_c[0])
        self.cd = drag_coefficient(z1, self.z0, self.kappa) if self.wall else 0.0
        # log-law shear at the first level per unit first-level velocity: 1/(z1 ln(z1/z0)) [m^-1]
        self.rlog = 1.0 / (z1 * math.log(z1 / self.z0)) if self.wall else 0.0
        self.closure = closure
        self.dynamic = None
        if closure == "dynamic" and self.sgs:
            from .dynamic_sgs import DynamicSmagorinsky
            self.dynamic = DynamicSmagorinsky(grid, self.kappa, self.rlog, delta, dynamic_interval)
            # nu = C_K l sqrt(e) with the diagnosed e, so every reader of (cml, e) gets the acting
            # viscosity; c_eps/l follows the coefficient (shared arrays, updated in place)
            self.cml = self.dynamic.ckl
            self.cml_v = self.dynamic.ckl
            self.ceps_l = self.dynamic.ceps_l
        self.f_c, self.f_f = damping_profiles(grid, damping_depth, damping_timescale)
        self.f_cu = self.f_c if damp_u else np.zeros_like(self.f_c)
        self.body_force = float(body_force)
        self.pressure = PressureSolver(grid, workers=workers)
        shp, shw = (nx, ny, nz), (nx, ny, nz + 1)
        self.buf = [dict(u=np.zeros(shp), v=np.zeros(shp), w=np.zeros(shw), e=np.zeros(shp))
                    for _ in range(2)]
        self.nu = np.zeros(shp)
        #: the grain sink rate of eq. A1 [s^-1] seen by the dynamic closure's e (set per step)
        self._sink = None
        self._e_stage = np.zeros(shp) if self.dynamic is not None else None
        self.taux = np.zeros((nx, ny))
        self.tauy = np.zeros((nx, ny))
        self.near_wall = None
        if near_wall_layer is not None and self.sgs and self.wall:
            from .nearwall import NearWallMeanViscosity
            self.near_wall = NearWallMeanViscosity(grid, self.kappa, near_wall_layer)
        #: plane-mean shears on the faces that the TKE production takes out (two-part model only)
        self.mdu = np.zeros(nz + 1)
        self.mdv = np.zeros(nz + 1)
        self.two_part = None
        if two_part and self.sgs and self.wall:
            from .twopart import TwoPartModel
            self.two_part = TwoPartModel(grid, self.kappa, self.rlog)
            self.mdu, self.mdv = self.two_part.mdu, self.two_part.mdv
            if self.dynamic is None:
                # the acting c_m l is gamma times the closure's own (updated in place every step)
                self._cml_base = self.cml.copy()
                self.cml = self._cml_base.copy()
                self.cml_v = self.cml

    # ---- pieces ----------------------------------------------------------------------------
    def boundary(self, u, v, w, e) -> None:
        """Bed stress from the first level and nu_t (from e, or from the strain with the dynamic
        closure) for one stage input."""
        if self.wall:
            surface_stress_into(u, v, self.cd, self.taux, self.tauy)
        else:
            self.taux[...] = 0.0
            self.tauy[...] = 0.0
        if self.dynamic is not None:
            self.dynamic.viscosity(u, v, w, self._sink, self.nu_mol, self.nu, self._e_stage)
        elif self.sgs:
            compute_nu(e, self.cml, self.nu_mol, self.nu)
        else:
            self.nu[...] = 0.0

    def stage(self, inp, base, out, cdt: float, u_drive: float, p=None) -> None:
        """out = base + cdt F(inp), then projected (inp/base/out: objects or dicts with u, v, w, e)."""
        g = self.grid
        gu, gv, gw, ge = (_get(inp, n) for n in "uvwe")
        bu, bv, bw, be = (_get(base, n) for n in "uvwe")
        ou, ov, ow, oe = (_get(out, n) for n in "uvwe")
        self.boundary(gu, gv, gw, ge)
        rdx, rdy = 1.0 / g.dx, 1.0 / g.dy
        _momentum_stage(gu, gv, gw, self.nu, self.rv, self.taux, self.tauy, bu, bv, bw, ou, ov, ow, cdt, rdx,
                        rdy, g.dz_c, g.dz_f, self.f_c, self.f_cu, self.f_f, u_drive, self.body_force,
                        self.advection, self.sgs)
        if self.near_wall is not None:
            self.near_wall.apply(ou, ov, cdt)
        if self.two_part is not None:
            self.two_part.apply(ou, ov, cdt)
        if self.dynamic is not None:
            pass                # e is diagnosed from the new state at the end of the step
        elif self.sgs:
            _tke_stage(ge, gu, gv, gw, self.nu, self.rv, be, oe, cdt, rdx, rdy, g.rdz_c, g.rdz_f, self.rlog,
                       self.ceps_l, E_MIN, self.mdu, self.mdv)
        elif oe is not be:
            oe[...] = be
        self.pressure.project(ou, ov, ow, p, cdt)

    def step(self, state, dt: float) -> None:
        """Advance (u, v, w, e) of ``state`` by dt in place (clock untouched)."""
        a, b = self.buf
        c1, c2, c3 = RK3_COEFFS
        if self.dynamic is not None:
            self.dynamic.maybe_update(state)
            self._sink = state.tke_sink
        if self.near_wall is not None:  # held over the stages (a slow mean-field term)
            self.near_wall.update(state, self.cml_v, self.nu_mol, dt)
        if self.two_part is not None:   # likewise: gamma, the mean shear and nu_T of this step
            self._update_two_part(state, dt)
        self.stage(state, state, a, c1 * dt, state.u_drive)
        self.stage(a, state, b, c2 * dt, state.u_drive)
        self.stage(b, state, state, c3 * dt, state.u_drive, p=state.p)
        if self.dynamic is not None:
            # e of the new state, in equilibrium with its strain and the grains' sink
            self.dynamic.viscosity(state.u, state.v, state.w, self._sink, self.nu_mol, self.nu,
                                   state.e)
        elif state.tke_sink is not None:
            _apply_sink(state.e, state.tke_sink, dt, E_MIN)

    def _update_two_part(self, state, dt: float) -> None:
        from .twopart import wall_friction_velocity
        tp = self.two_part
        tp.update_gamma(state)
        if self.dynamic is not None:
            self.dynamic.set_scale(tp.gamma)
        else:
            np.multiply(self._cml_base, tp.gamma, out=self.cml)
        # the plane mean of the gamma-scaled viscosity on face 1 (nu = c l sqrt(e) for both
        # closures: the dynamic model's e is diagnosed from its viscosity)
        e = state.e
        nu1 = 0.5 * (self.cml[0] * float(np.sqrt(np.maximum(e[:, :, 0], 0.0)).mean())
                     + self.cml[1] * float(np.sqrt(np.maximum(e[:, :, 1], 0.0)).mean()))
        surface_stress_into(state.u, state.v, self.cd, self.taux, self.tauy)
        tp.update_mean_viscosity(nu1, wall_friction_velocity(self.taux, self.tauy), dt)

    def close(self) -> None:
        self.pressure.close()


def _get(obj, name):
    return obj[name] if isinstance(obj, dict) else getattr(obj, name)
