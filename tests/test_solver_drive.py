"""The two drives (forcing.drive = "top" | "pressure_gradient") and the log-law fit with a linear
stress profile (solver.diagnostics.flow.fit_log_law)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from solver_helpers import smoke_scene  # noqa: F401  (imports saltstudy first)
from saltstudy.config import load_case, load_fidelity, resolve_scene
from saltstudy.solver.diagnostics import flow as df
from saltstudy.solver.flow.forcing import pressure_gradient_force
from saltstudy.solver.model import Model

KAPPA = 0.4


def _scene(drive: str):
    return resolve_scene(load_case(1, overrides={"forcing": {"drive": drive}}), load_fidelity("smoke"))


def test_pressure_gradient_drive_is_a_uniform_body_force_without_damping():
    sc = _scene("pressure_gradient")
    m = Model.from_scene(sc)
    us, Lz = sc.case.forcing.u_star_s, m.grid.Lz
    G = pressure_gradient_force(us, Lz)
    assert math.isclose(m.body_force, us**2 / Lz) and math.isclose(G, m.body_force)
    assert m.damping_depth == 0.0
    assert not np.any(m.stepper.f_c) and not np.any(m.stepper.f_cu) and not np.any(m.stepper.f_f)
    # fluid at rest: no wall stress, no advection, no SGS flux -> u = G dt everywhere, v = w = 0
    s = m.state
    s.u[...] = 0.0
    s.v[...] = 0.0
    s.w[...] = 0.0
    s.e[...] = 1e-10
    dt = 0.01
    m.step(dt)
    assert np.allclose(s.u, G * dt, rtol=1e-4, atol=0)   # (+ the tiny wall stress of the RK stages)
    assert np.allclose(s.v, 0.0) and np.allclose(s.w, 0.0)
    assert s.u_drive == 0.0
    # initial mean profile: the local-equilibrium profile of the linear stress
    m2 = Model.from_scene(sc)
    um = m2.state.u.mean(axis=(0, 1))
    ref = df.log_law_profile(m2.grid.z_c, math.sqrt(G * Lz), sc.case.surface.z0, KAPPA, H=Lz)
    assert np.allclose(um, ref, atol=0.5 * us)    # (+ the horizontal mean of the noise)


def test_pressure_gradient_hold_height():
    assert math.isclose(pressure_gradient_force(0.4, 6.0, 2.0), 0.16 / 4.0)
    with pytest.raises(ValueError):
        pressure_gradient_force(0.4, 6.0, 6.0)


def test_top_drive_keeps_rayleigh_relaxation_of_u():
    m = Model.from_scene(_scene("top"))
    assert m.body_force == 0.0 and np.any(m.stepper.f_cu) and m.state.u_drive > 0


@pytest.mark.parametrize("H", [None, 6.0, 12.0])
def test_fit_log_law_recovers_its_profile(H):
    z = np.geomspace(0.005, 5.9, 48)
    U = df.log_law_profile(z, 0.41, 1e-5, KAPPA, H)
    f = df.fit_log_law(z, U, KAPPA, H, z_min=0.3, z_max=2.0, z_eval=[0.0, 2.0])
    assert math.isclose(f["u_star0"], 0.41, rel_tol=1e-9)
    assert math.isclose(f["z0"], 1e-5, rel_tol=1e-6)
    expect2 = 0.41 if H is None else 0.41 * math.sqrt(1 - 2.0 / H)
    assert np.allclose(f["u_star_at"], [0.41, expect2])
    assert f["rms"] < 1e-10 and f["n"] == int(np.sum((z >= 0.3) & (z <= 2.0)))


def test_linear_stress_profile_shape():
    # dU/dz = u*_0 sqrt(1 - z/H) / (kappa z) and F ~ ln z for z << H
    H, z = 6.0, np.geomspace(1e-4, 5.0, 400)
    U = df.log_law_profile(z, 1.0, 1e-5, KAPPA, H)
    dudz = np.gradient(U, z)
    phi = KAPPA * z * dudz / np.sqrt(1 - z / H)
    assert np.allclose(phi[5:-5], 1.0, atol=2e-3)
    F = df.log_law_shape(np.array([1e-6, 1e-5]), H)
    assert math.isclose(F[1] - F[0], math.log(10.0), rel_tol=1e-5)
    # a plain log fit of the linear-stress profile underestimates u*_0
    plain = df.fit_log_law(z, U, KAPPA, None, 0.3, 2.0)
    assert plain["u_star0"] < 0.95
