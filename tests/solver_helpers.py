"""Shared helpers of the flow-solver tests (not a test module)."""
from __future__ import annotations

import saltstudy  # noqa: F401  (sets numba's cache dir and threading layer before numba loads)

import numba
import numpy as np
from numba import prange

from saltstudy.config import load_case, load_fidelity, resolve_scene
from saltstudy.solver.flow.advection import (ADVECTION_ORDERS, adv_scalar4_at, adv_scalar_at,
                                              adv_u4_at, adv_u_at, adv_v4_at, adv_v_at,
                                              adv_w4_at, adv_w_at)
from saltstudy.solver.grid import Grid, stretched_levels


def smoke_scene(case: int = 1, **grid_overrides):
    fid = load_fidelity("smoke")
    if grid_overrides:
        fid = fid.model_validate({**fid.model_dump(), "grid": {**fid.grid.model_dump(), **grid_overrides}})
    return resolve_scene(load_case(case), fid)


def with_closure(scene, **closure):
    """``scene`` with ``case.closure`` fields replaced (e.g. delta="geometric")."""
    case = scene.case.model_copy(update={"closure": scene.case.closure.model_copy(update=closure)})
    return scene.model_copy(update={"case": case})


def make_stepper(grid, *, z0=1e-5, kappa=0.4, nu_mol=1.5e-5, wall=True, sgs=True,
                 vertical_diffusion="explicit", implicit_weight=0.5, advection=True,
                 advection_order=2, precision="double", damping_depth=0.0, damping_timescale=10.0,
                 **closure):
    """A flow stepper on ``grid`` with the case closure ``closure`` fields (config.Closure) and no
    damping layer by default."""
    from saltstudy.config import Closure
    from saltstudy.solver.closures.closure import make_closure
    from saltstudy.solver.flow.stepper import Boundaries, FlowNumerics, Stepper
    clo = make_closure(grid, Closure(**closure), kappa=kappa, z0=z0, nu_mol=nu_mol, wall=wall,
                       enabled=sgs)
    return Stepper(grid, clo, Boundaries(z0=z0, kappa=kappa, wall=wall, damping_depth=damping_depth,
                                         damping_timescale=damping_timescale),
                   FlowNumerics(vertical_diffusion=vertical_diffusion,
                                implicit_weight=implicit_weight, advection=advection,
                                advection_order=advection_order, precision=precision))


def stretched_grid(nx=16, ny=12, nz=14, Lx=2.0, Ly=1.5, Lz=3.0, dz_bottom=0.02) -> Grid:
    return Grid(nx, ny, nz, Lx, Ly, stretched_levels(Lz, nz, dz_bottom))


def random_velocity(grid: Grid, seed: int = 0, mean_u: float = 0.0):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(grid.shape) + mean_u
    v = rng.standard_normal(grid.shape)
    w = rng.standard_normal(grid.shape[:2] + (grid.nz + 1,))
    w[..., 0] = 0.0
    w[..., -1] = 0.0
    return u, v, w


# ---- advection operators over a whole field, from the stepper's per-point kernels ----
@numba.njit(parallel=True, cache=True)
def _advection_kernel(u, v, w, dx, dy, dzc, dzf, au, av, aw, order):
    nx, ny, nz = u.shape
    rdx = 1.0 / dx
    rdy = 1.0 / dy
    for i in prange(nx):
        im = (i - 1) % nx
        ip = (i + 1) % nx
        for j in range(ny):
            jm = (j - 1) % ny
            jp = (j + 1) % ny
            for k in range(nz):
                r = 1.0 / dzc[k]
                if order == 4:
                    au[i, j, k] = adv_u4_at(u, v, w, i, j, k, im, ip, jm, jp, k < nz - 1, k > 0, rdx,
                                            rdy, r)
                    av[i, j, k] = adv_v4_at(u, v, w, i, j, k, im, ip, jm, jp, k < nz - 1, k > 0, rdx,
                                            rdy, r)
                else:
                    au[i, j, k] = adv_u_at(u, v, w, i, j, k, im, ip, jm, jp, k < nz - 1, k > 0, rdx,
                                           rdy, r)
                    av[i, j, k] = adv_v_at(u, v, w, i, j, k, im, ip, jm, jp, k < nz - 1, k > 0, rdx,
                                           rdy, r)
            aw[i, j, 0] = 0.0
            aw[i, j, nz] = 0.0
            for k in range(1, nz):
                hzm = 0.5 * dzc[k - 1] / dzf[k]
                hzp = 0.5 * dzc[k] / dzf[k]
                if order == 4:
                    aw[i, j, k] = adv_w4_at(u, v, w, i, j, k, im, ip, jm, jp, rdx, rdy, hzm, hzp,
                                            1.0 / dzf[k])
                else:
                    aw[i, j, k] = adv_w_at(u, v, w, i, j, k, im, ip, jm, jp, rdx, rdy, hzm, hzp,
                                           1.0 / dzf[k])


@numba.njit(parallel=True, cache=True)
def _scalar_kernel(s, u, v, w, dx, dy, dzc, out, order):
    nx, ny, nz = s.shape
    for i in prange(nx):
        im = (i - 1) % nx
        ip = (i + 1) % nx
        for j in range(ny):
            jm = (j - 1) % ny
            jp = (j + 1) % ny
            for k in range(nz):
                if order == 4:
                    out[i, j, k] = adv_scalar4_at(s, u, v, w, i, j, k, im, ip, jm, jp, k < nz - 1,
                                                  k > 0, 1.0 / dx, 1.0 / dy, 1.0 / dzc[k])
                else:
                    out[i, j, k] = adv_scalar_at(s, u, v, w, i, j, k, im, ip, jm, jp, k < nz - 1,
                                                 k > 0, 1.0 / dx, 1.0 / dy, 1.0 / dzc[k])


def _check_order(order: int) -> int:
    if order not in ADVECTION_ORDERS:
        raise ValueError(f"advection order must be one of {ADVECTION_ORDERS} (got {order!r})")
    return int(order)


def advection_tendencies(grid, u, v, w, order: int = 2):
    """(A_u, A_v, A_w) = -div(u u_i) on the u, v, w points [m s^-2], from the per-point kernels
    the stage kernels inline."""
    au = np.empty_like(u)
    av = np.empty_like(v)
    aw = np.empty_like(w)
    _advection_kernel(u, v, w, grid.dx, grid.dy, grid.dz_c, grid.dz_f, au, av, aw,
                      _check_order(order))
    return au, av, aw


def scalar_advection(grid, s, u, v, w, order: int = 2):
    """-div(u s) for a cell-centred scalar; ``order``: 2, or 4 in x and y."""
    out = np.empty_like(s)
    _scalar_kernel(s, u, v, w, grid.dx, grid.dy, grid.dz_c, out, _check_order(order))
    return out


def lacking_metadata(ds) -> list[str]:
    """Names of an archive's variables and coordinates without ``units`` or ``long_name``."""
    return [n for n in ds.variables if not ds[n].attrs.get("units") or not ds[n].attrs.get("long_name")]
