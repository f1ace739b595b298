"""Shared helpers of the flow-solver tests (not a test module)."""
from __future__ import annotations

import saltstudy  # noqa: F401  (sets numba's cache dir and threading layer before numba loads)

import numpy as np

from saltstudy.config import load_case, load_fidelity, resolve_scene
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
