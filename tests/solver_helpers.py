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
