"""Pressure: the FFT + tridiagonal Poisson solver and the projection."""
from __future__ import annotations

import numpy as np

from solver_helpers import random_velocity, smoke_scene, stretched_grid
from saltstudy.solver.flow.pressure import (PressureSolver, divergence, laplacian,
                                       max_relative_divergence)


def test_manufactured_poisson_on_stretched_grid_to_round_off():
    g = stretched_grid(nx=20, ny=12, nz=18)
    x, y, z = np.meshgrid(g.x_c, g.y_c, g.z_c, indexing="ij")
    # a smooth field plus noise: every wavenumber pair and the mean mode are exercised
    phi = (np.cos(2 * np.pi * x / g.Lx) * np.sin(4 * np.pi * y / g.Ly) * np.cos(np.pi * z / g.Lz)
           + 0.3 * z**2 + 0.1 * np.random.default_rng(3).standard_normal(g.shape))
    rhs = laplacian(g, phi)
    ps = PressureSolver(g)
    sol = ps.solve(rhs)
    # phi is defined up to a constant
    err = (sol - sol.mean()) - (phi - phi.mean())
    assert np.abs(err).max() < 1e-10 * np.abs(phi).max()
    assert np.abs(laplacian(g, sol) - rhs).max() < 1e-10 * np.abs(rhs).max()


def test_projection_removes_divergence_and_keeps_solenoidal_part():
    g = stretched_grid()
    u, v, w = random_velocity(g, seed=1)
    assert max_relative_divergence(g, u, v, w) > 0.1   # the test field is far from solenoidal
    ps = PressureSolver(g, workers=2)
    ps.project(u, v, w)
    assert max_relative_divergence(g, u, v, w) < 1e-12
    assert np.all(w[..., 0] == 0) and np.all(w[..., -1] == 0)
    u0, v0, w0 = u.copy(), v.copy(), w.copy()
    ps.project(u, v, w)          # a projection is idempotent
    assert max(np.abs(u - u0).max(), np.abs(v - v0).max(), np.abs(w - w0).max()) < 1e-12


def test_divergence_after_a_model_step_is_round_off():
    from saltstudy.solver.model import Model
    m = Model.from_scene(smoke_scene())
    for _ in range(2):
        m.step(m.next_dt())
    s = m.state
    d = divergence(m.grid, s.u, s.v, s.w)
    umax = np.abs(s.u).max()
    assert np.abs(d).max() * m.grid.dx / umax < 1e-10
