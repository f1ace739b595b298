"""The flow time step: Wicker & Skamarock (2002, Mon. Wea. Rev. 130, 2088) RK3 with a projection per
stage.

    phi(1) = phi(n) + dt/3 F(phi(n)),  phi(2) = phi(n) + dt/2 F(phi(1)),  phi(n+1) = phi(n) + dt F(phi(2))

for phi = (u, v, w, e). Per stage: the bed stress and the closure's viscosity of the stage
input, one fused kernel for advection, SGS diffusion, damping and drive of u, v, w, one for the
SGS TKE, the projection (pressure.py); then the closure's ``end_step`` (the grain sink of e, or
the diagnosed e). The vertical diffusion is explicit or implicit (vertical_diffusion.py). The
base fields stay in the state (stage 3 writes them after reading them): two extra sets suffice.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import prange

from ..._jit import device, jit, like, pjit
from .advection import (ADVECTION_ORDERS, adv_scalar4_at, adv_scalar_at, adv_u4_at, adv_u_at,
                        adv_v4_at, adv_v_at, adv_w4_at, adv_w_at)
from ..closures.closure import NoClosure
from .damping import damping_profiles
from .pressure import PressureSolver
from ..closures.sgs import (E_MIN, diff_u_split_at, diff_v_split_at, diff_w_split_at, tke_split_at,
                            vertical_coupling)
from .vertical_diffusion import VERTICAL_DIFFUSION, momentum_stage_implicit, tke_stage_implicit
from .wall import drag_coefficient, surface_stress_into

RK3_COEFFS = (1.0 / 3.0, 0.5, 1.0)

#: the floating types a fidelity can name (config.TimeStepping.precision)
PRECISIONS = {"double": np.float64, "single": np.float32}


@dataclass(frozen=True)
class FlowNumerics:
    """How the flow is integrated (the fidelity's ``time``): the vertical diffusion and its theta
    (1/2 Crank-Nicolson, 1 backward Euler); the advection (off in tests) and its order, 2 or 4
    (the projection's too); "single" precision: u, v, w, e, p, nu and the stencils in float32."""
    vertical_diffusion: str = "implicit"
    implicit_weight: float = 0.5
    advection: bool = True
    advection_order: int = 2
    precision: str = "double"

    def __post_init__(self):
        if self.vertical_diffusion not in VERTICAL_DIFFUSION:
            raise ValueError(f"vertical_diffusion must be one of {VERTICAL_DIFFUSION} "
                             f"(got {self.vertical_diffusion!r})")
        if not 0.5 <= self.implicit_weight <= 1.0:
            raise ValueError(f"implicit_weight must lie in [0.5, 1] (got {self.implicit_weight!r})")
        if self.advection_order not in ADVECTION_ORDERS:
            raise ValueError(f"advection_order must be one of {ADVECTION_ORDERS} "
                             f"(got {self.advection_order!r})")
        if self.precision not in PRECISIONS:
            raise ValueError(f"precision must be one of {tuple(PRECISIONS)} (got {self.precision!r})")

    @property
    def dtype(self) -> np.dtype:
        """The floating type of the flow's fields."""
        return np.dtype(PRECISIONS[self.precision])

    @classmethod
    def from_time(cls, ts) -> "FlowNumerics":
        """From a fidelity's ``time`` section (config.TimeStepping)."""
        return cls(vertical_diffusion=ts.vertical_diffusion, implicit_weight=ts.implicit_weight,
                   advection_order=ts.advection_order, precision=ts.precision)


@dataclass(frozen=True)
class Boundaries:
    """The bed (log-law, roughness z0 [m]; ``wall`` False: free slip), the Rayleigh layer (on u
    too with ``damp_u``, the top drive) and the body force G [m s^-2] (forcing.py)."""
    z0: float = 1.0e-5
    kappa: float = 0.4
    wall: bool = True
    damping_depth: float = 0.0
    damping_timescale: float = 5.0
    damp_u: bool = True
    body_force: float = 0.0


@device
def _uv_point(u, v, w, nu, rv, taux, tauy, ub, vb, uo, vo, i, j, k, im, ip, jm, jp, top, bot, cdt,
              rdx, rdy, dzc, dzf, fck, fcuk, srck, adv, with_diff):
    # srck = gx + fcuk u_drive; adv: the advection's horizontal order, 2 or 4, 0 for none
    one = like(u, 1.0)
    r = one / dzc[k]
    tu = srck - fcuk * u[i, j, k]
    tv = -fck * v[i, j, k]
    if adv == 4:
        tu += adv_u4_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, r)
        tv += adv_v4_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, r)
    elif adv == 2:
        tu += adv_u_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, r)
        tv += adv_v_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, r)
    if with_diff:  # the split diffusion of sgs.py, all explicit
        x, a, c = diff_u_split_at(u, v, w, nu, rv, taux, i, j, k, im, ip, jm, jp, top, bot, rdx,
                                  rdy, dzc, dzf)
        tu += x + vertical_coupling(u, i, j, k, a, c, top, bot)
        x, a, c = diff_v_split_at(u, v, w, nu, rv, tauy, i, j, k, im, ip, jm, jp, top, bot, rdx,
                                  rdy, dzc, dzf)
        tv += x + vertical_coupling(v, i, j, k, a, c, top, bot)
    uo[i, j, k] = ub[i, j, k] + cdt * tu
    vo[i, j, k] = vb[i, j, k] + cdt * tv


@device
def _uvw_column(u, v, w, nu, rv, taux, tauy, ub, vb, wb, uo, vo, wo, i, j, im, ip, cdt, rdx, rdy, dzc,
                dzf, fc, fcu, ff, u_drive, gx, adv, with_diff):
    # one column of _momentum_stage, called with a literal adv = 4 so that each k loop is
    # compiled for one order: tested inside the loops, the step cost 150 against 116 ns per
    # cell-step (reduced grid, one thread, `saltstudy bench flow --no-big`)
    half = like(w, 0.5)
    one = like(w, 1.0)
    ny, nz = u.shape[1], u.shape[2]
    jm = j - 1 if j > 0 else ny - 1
    jp = j + 1 if j + 1 < ny else 0
    _uv_point(u, v, w, nu, rv, taux, tauy, ub, vb, uo, vo, i, j, 0, im, ip, jm, jp, True, False,
              cdt, rdx, rdy, dzc, dzf, fc[0], fcu[0], gx + fcu[0] * u_drive, adv, with_diff)
    for k in range(1, nz - 1):
        _uv_point(u, v, w, nu, rv, taux, tauy, ub, vb, uo, vo, i, j, k, im, ip, jm, jp, True,
                  True, cdt, rdx, rdy, dzc, dzf, fc[k], fcu[k], gx + fcu[k] * u_drive, adv,
                  with_diff)
    _uv_point(u, v, w, nu, rv, taux, tauy, ub, vb, uo, vo, i, j, nz - 1, im, ip, jm, jp, False,
              True, cdt, rdx, rdy, dzc, dzf, fc[nz - 1], fcu[nz - 1], gx + fcu[nz - 1] * u_drive,
              adv, with_diff)
    wo[i, j, 0] = 0.0
    wo[i, j, nz] = 0.0
    for k in range(1, nz):
        tw = -ff[k] * w[i, j, k]
        hzm = half * dzc[k - 1] / dzf[k]
        hzp = half * dzc[k] / dzf[k]
        if adv == 4:
            tw += adv_w4_at(u, v, w, i, j, k, im, ip, jm, jp, rdx, rdy, hzm, hzp, one / dzf[k])
        elif adv == 2:
            tw += adv_w_at(u, v, w, i, j, k, im, ip, jm, jp, rdx, rdy, hzm, hzp, one / dzf[k])
        if with_diff:
            x, a, c = diff_w_split_at(u, v, w, nu, rv, i, j, k, im, ip, jm, jp, rdx, rdy, dzc, dzf)
            tw += x + vertical_coupling(w, i, j, k, a, c, True, True)
        wo[i, j, k] = wb[i, j, k] + cdt * tw


@pjit
def _momentum_stage(u, v, w, nu, rv, taux, tauy, ub, vb, wb, uo, vo, wo, cdt, rdx, rdy, dzc, dzf,
                    fc, fcu, ff, u_drive, gx, with_adv, with_diff, order):
    """uo = ub + cdt (advection + SGS diffusion + damping + drive) for u, v, w (interior w), the
    first and last levels peeled (literal top/bot: a branch-free interior loop)."""
    nx = u.shape[0]
    adv = order if with_adv else 0
    for i in prange(nx):
        _uvw_slab(u, v, w, nu, rv, taux, tauy, ub, vb, wb, uo, vo, wo, i, (i - 1) % nx, (i + 1) % nx,
                  cdt, rdx, rdy, dzc, dzf, fc, fcu, ff, u_drive, gx, adv, with_diff)


@jit
def _uvw_slab(u, v, w, nu, rv, taux, tauy, ub, vb, wb, uo, vo, wo, i, im, ip, cdt, rdx, rdy, dzc,
              dzf, fc, fcu, ff, u_drive, gx, adv, with_diff):
    # one x-slab, serial: the parallel region's body stays one call (quick for numba's parfor
    # passes), and LLVM inlines the columns here with their literal order
    for j in range(u.shape[1]):
        if adv == 4:
            _uvw_column(u, v, w, nu, rv, taux, tauy, ub, vb, wb, uo, vo, wo, i, j, im, ip, cdt,
                        rdx, rdy, dzc, dzf, fc, fcu, ff, u_drive, gx, 4, with_diff)
        else:
            _uvw_column(u, v, w, nu, rv, taux, tauy, ub, vb, wb, uo, vo, wo, i, j, im, ip, cdt,
                        rdx, rdy, dzc, dzf, fc, fcu, ff, u_drive, gx, adv, with_diff)


@device
def _e_point(e, u, v, w, nu, rv, eb, eo, i, j, k, im, ip, jm, jp, top, bot, cdt, rdx, rdy, rdzc,
             rdzf, rlog, ceps_lk, e_min, order):
    zero = like(e, 0.0)
    if order == 4:
        te = adv_scalar4_at(e, u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc[k])
    else:
        te = adv_scalar_at(e, u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc[k])
    x, a, c, r = tke_split_at(e, u, v, w, nu, rv, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc,
                              rdzf, rlog, ceps_lk)
    ec = e[i, j, k]
    te += x + vertical_coupling(e, i, j, k, a, c, top, bot) - r * (ec if ec > zero else zero)
    val = eb[i, j, k] + cdt * te
    eo[i, j, k] = val if val > e_min else e_min


@device
def _e_column(e, u, v, w, nu, rv, eb, eo, i, j, im, ip, jm, jp, cdt, rdx, rdy, rdzc, rdzf, rlog,
              ceps_l, e_min, order):
    # one column, levels peeled; the stage kernel calls it with a literal order (as _uvw_column)
    nz = e.shape[2]
    _e_point(e, u, v, w, nu, rv, eb, eo, i, j, 0, im, ip, jm, jp, True, False, cdt, rdx, rdy, rdzc,
             rdzf, rlog, ceps_l[0], e_min, order)
    for k in range(1, nz - 1):
        _e_point(e, u, v, w, nu, rv, eb, eo, i, j, k, im, ip, jm, jp, True, True, cdt, rdx, rdy, rdzc,
                 rdzf, rlog, ceps_l[k], e_min, order)
    _e_point(e, u, v, w, nu, rv, eb, eo, i, j, nz - 1, im, ip, jm, jp, False, True, cdt, rdx, rdy,
             rdzc, rdzf, rlog, ceps_l[nz - 1], e_min, order)


@pjit
def _tke_stage(e, u, v, w, nu, rv, eb, eo, cdt, rdx, rdy, rdzc, rdzf, rlog, ceps_l, e_min, order):
    """eo = max(eb + cdt (advection + P + transport - eps), e_min), levels peeled as above."""
    nx, ny, nz = e.shape
    for ii in prange(nx):
        i = np.int64(ii)  # signed: strain_sq_at indexes with i directly
        im = (i - 1) % nx
        ip = (i + 1) % nx
        for j in range(ny):
            jm = (j - 1) % ny
            jp = (j + 1) % ny
            if order == 4:
                _e_column(e, u, v, w, nu, rv, eb, eo, i, j, im, ip, jm, jp, cdt, rdx, rdy, rdzc, rdzf,
                          rlog, ceps_l, e_min, 4)
            else:
                _e_column(e, u, v, w, nu, rv, eb, eo, i, j, im, ip, jm, jp, cdt, rdx, rdy, rdzc, rdzf,
                          rlog, ceps_l, e_min, 2)


class Stepper:
    """RK3 flow stepper: ``Stepper(grid, closure, boundaries, numerics)``."""

    def __init__(self, grid, closure=None, boundaries: Boundaries = Boundaries(),
                 numerics: FlowNumerics = FlowNumerics(), workers: int | None = None):
        self.grid = grid
        nx, ny, nz = grid.shape
        self.closure = closure if closure is not None else NoClosure(grid)
        self.bounds = boundaries
        self.numerics = numerics
        #: the floating type of the flow's fields and of the stencils' arithmetic
        self.dtype = numerics.dtype
        self.z0, self.kappa = float(boundaries.z0), float(boundaries.kappa)
        self.wall = bool(boundaries.wall)
        self.cd = drag_coefficient(float(grid.z_c[0]), self.z0, self.kappa) if self.wall else 0.0
        self.f_c, self.f_f = damping_profiles(grid, boundaries.damping_depth,
                                              boundaries.damping_timescale)
        self.f_cu = self.f_c if boundaries.damp_u else np.zeros_like(self.f_c)
        self.body_force = float(boundaries.body_force)
        self.order = int(numerics.advection_order)
        self.pressure = PressureSolver(grid, workers=workers, order=self.order)
        self.diffusing = bool(self.closure.diffuses)
        self.implicit = self.diffusing and numerics.vertical_diffusion == "implicit"
        self.theta = float(numerics.implicit_weight)
        shp, shw = (nx, ny, nz), (nx, ny, nz + 1)
        dt_ = self.dtype
        self.buf = [dict(u=np.zeros(shp, dt_), v=np.zeros(shp, dt_), w=np.zeros(shw, dt_),
                         e=np.zeros(shp, dt_)) for _ in range(2)]
        self.nu = np.zeros(shp, dt_)
        self.taux = np.zeros((nx, ny), dt_)
        self.tauy = np.zeros((nx, ny), dt_)
        # the per-level arrays the stage kernels read, in the fields' type
        clo = self.closure
        self._k = {name: np.asarray(a, dt_) for name, a in (
            ("dz_c", grid.dz_c), ("dz_f", grid.dz_f), ("rdz_c", grid.rdz_c), ("rdz_f", grid.rdz_f),
            ("f_c", self.f_c), ("f_cu", self.f_cu), ("f_f", self.f_f), ("rv", clo.rv),
            ("ceps_l", clo.ceps_l))}
        self._f = dt_.type

    def bed_stress_into(self, u, v, taux, tauy) -> None:
        """taux, tauy (nx, ny): the kinematic bed stress [m^2 s^-2] (wall.py); 0 if free slip."""
        if self.wall:
            surface_stress_into(u, v, self.cd, taux, tauy)
        else:
            taux[...] = 0.0
            tauy[...] = 0.0

    def boundary(self, u, v, w, e) -> None:
        """Bed stress and the closure's nu_t for one stage input."""
        self.bed_stress_into(u, v, self.taux, self.tauy)
        self.closure.viscosity(u, v, w, e, self.nu)

    def stage(self, inp, base, out, cdt: float, u_drive: float, p, store_p: bool = False) -> None:
        """out = base + cdt F(inp), projected; ``p`` [m^2 s^-2] the last step's pressure, whose
        gradient the implicit stages carry; ``store_p``: the stage's pressure written into it."""
        g, clo, K, f = self.grid, self.closure, self._k, self._f
        gu, gv, gw, ge = (_get(inp, n) for n in "uvwe")
        bu, bv, bw, be = (_get(base, n) for n in "uvwe")
        ou, ov, ow, oe = (_get(out, n) for n in "uvwe")
        self.boundary(gu, gv, gw, ge)
        rdx, rdy = f(1.0 / g.dx), f(1.0 / g.dy)
        fdt, fdrive, fbody = f(cdt), f(u_drive), f(self.body_force)
        adv = self.numerics.advection
        if self.implicit:
            momentum_stage_implicit(gu, gv, gw, self.nu, K["rv"], self.taux, self.tauy, bu, bv, bw,
                                    ou, ov, ow, p, fdt, f(self.theta), rdx, rdy, K["dz_c"],
                                    K["dz_f"], K["f_c"], K["f_cu"], K["f_f"], fdrive, fbody, adv,
                                    self.order)
        else:
            _momentum_stage(gu, gv, gw, self.nu, K["rv"], self.taux, self.tauy, bu, bv, bw, ou, ov,
                            ow, fdt, rdx, rdy, K["dz_c"], K["dz_f"], K["f_c"], K["f_cu"], K["f_f"],
                            fdrive, fbody, adv, self.diffusing, self.order)
        if clo.prognostic_e and self.implicit:
            tke_stage_implicit(ge, gu, gv, gw, self.nu, K["rv"], be, oe, fdt, f(self.theta), rdx,
                               rdy, K["rdz_c"], K["rdz_f"], f(clo.rlog), K["ceps_l"], f(E_MIN),
                               self.order)
        elif clo.prognostic_e:
            _tke_stage(ge, gu, gv, gw, self.nu, K["rv"], be, oe, fdt, rdx, rdy, K["rdz_c"],
                       K["rdz_f"], f(clo.rlog), K["ceps_l"], f(E_MIN), self.order)
        elif oe is not be and self.closure.dynamic is None:
            oe[...] = be
        self.pressure.project(ou, ov, ow, p if store_p else None, cdt, increment=self.implicit)

    def step(self, state, dt: float) -> None:
        """Advance (u, v, w, e) by dt in place (clock untouched); p becomes the step's."""
        a, b = self.buf
        c1, c2, c3 = RK3_COEFFS
        self.closure.begin_step(state, dt)
        self.stage(state, state, a, c1 * dt, state.u_drive, state.p)
        self.stage(a, state, b, c2 * dt, state.u_drive, state.p)
        self.stage(b, state, state, c3 * dt, state.u_drive, state.p, store_p=True)
        self.closure.end_step(state, dt, self.nu)

    def close(self) -> None:
        self.pressure.close()


def _get(obj, name):
    return obj[name] if isinstance(obj, dict) else getattr(obj, name)
