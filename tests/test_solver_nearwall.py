"""The near-wall mean-field eddy viscosity (solver/closures/nearwall.py) on fields with known answers."""
from __future__ import annotations

import numpy as np
import pytest

from solver_helpers import smoke_scene  # noqa: F401  (imports saltstudy first)
from saltstudy.config import Closure, ConfigError, load_case, load_fidelity, resolve_scene
from saltstudy.solver.grid import Grid
from saltstudy.solver.closures.nearwall import NearWallMeanViscosity, layer_weight
from saltstudy.solver.closures.sgs import C_M, E_MIN, length_scale
from saltstudy.solver.state import FlowState

KAPPA = 0.4


def _grid():
    return Grid.from_spec(load_fidelity("smoke").grid)


def _laminar(grid, U):
    """A flow with the mean profile U(z) only: no resolved stress, SGS TKE at its floor."""
    st = FlowState.zeros(grid)
    st.u[...] = U[None, None, :]
    st.e[...] = E_MIN
    return st


def test_layer_weight_shape():
    z = np.array([0.0, 0.1, 0.2, 0.3, 0.35, 0.4, 0.5])
    w = layer_weight(z, 0.1, 2.0, 4.0)
    assert np.allclose(w[:3], 1.0) and w[5] == 0.0 and w[6] == 0.0
    assert w[3] == pytest.approx(0.5, rel=1e-12) and 0.0 < w[4] < w[3]


def test_log_profile_without_les_stress_is_steady_and_fully_carried():
    """U = u*/kappa ln(z/z0) with no resolved or SGS stress: nu_T S = (kappa z S)^2 = u*^2 on every
    face of the full-weight layer, so the tendency vanishes there; it conserves momentum."""
    g = _grid()
    u_star, z0 = 0.4, 1e-5
    U = u_star / KAPPA * np.log(g.z_c / z0)
    nw = NearWallMeanViscosity(g, KAPPA, (2.0, 4.0))
    cml = np.zeros(g.nz)  # no SGS viscosity at all
    nw.update(_laminar(g, U), cml, 0.0, 1e-9)
    full = nw.weight == 1.0
    assert full.sum() >= 3
    dU = np.diff(U) / g.dz_f[1:-1]
    tau = nw.nu_T[1:-1] * dU
    ml = (KAPPA * g.z_f[1:-1] * dU) ** 2
    assert np.allclose(tau[full[1:-1]], ml[full[1:-1]], rtol=1e-12)
    # ... which is u*^2 up to the centred difference of ln z on the coarse stretched smoke grid
    # (about 10 % at its first face)
    assert np.allclose(tau[full[1:-1]], u_star**2, rtol=0.15)
    # zero flux through bed and lid: the term only redistributes momentum
    assert abs(np.sum(nw.tend_u * g.dz_c)) < 1e-12 * np.abs(nw.tend_u * g.dz_c).sum() + 1e-15
    assert np.all(nw.tend_v == 0.0)


@pytest.mark.parametrize("dt", [1e-4, 10.0, 1e4])
def test_implicit_step_is_backward_euler_stable_and_conservative(dt):
    """The held tendency times dt is the backward-Euler increment of d/dz(nu_T dU/dz): it solves
    that equation to round-off, keeps the column's momentum, and obeys the maximum principle at
    any dt (explicitly, dt 2 nu_T / dz^2 here reaches ~1e6, far past the explicit limit of 1)."""
    g = _grid()
    U = 1.3 * 0.4 / KAPPA * np.log(g.z_c / 1e-5)
    nw = NearWallMeanViscosity(g, KAPPA, (2.0, 4.0))
    nw.update(_laminar(g, U), np.zeros(g.nz), 0.0, dt)
    Us = U + dt * nw.tend_u
    flux = np.zeros(g.nz + 1)
    flux[1:-1] = nw.nu_T[1:-1] * np.diff(Us) / g.dz_f[1:-1]
    resid = (Us - U) / dt - (flux[1:] - flux[:-1]) / g.dz_c
    # round-off scale of the diffusion operator applied to U
    scale = np.max(np.abs(U)) * np.max(nw.nu_T[1:-1] / (g.dz_f[1:-1] * g.dz_c[:-1]))
    assert np.max(np.abs(resid)) < 1e-10 * scale
    assert np.allclose(nw.stress_profile(), flux, rtol=0.0,
                       atol=1e-10 * np.max(np.abs(U)) * np.max(nw.nu_T[1:-1] / g.dz_f[1:-1]))
    assert abs(np.sum((Us - U) * g.dz_c)) < 1e-12 * np.sum(np.abs(U) * g.dz_c)
    assert U.min() - 1e-12 <= Us.min() and Us.max() <= U.max() + 1e-12
    # a monotone profile stays monotone (no overshoot, however large dt)
    assert np.all(np.diff(Us) > 0)


def test_no_viscosity_where_the_les_already_carries_the_stress():
    """With the SGS viscosity larger than the mixing length's, nu_T is zero everywhere."""
    g = _grid()
    U = 0.4 / KAPPA * np.log(g.z_c / 1e-5)
    st = _laminar(g, U)
    st.e[...] = 100.0  # sqrt(e) = 10 m/s: c_m l sqrt(e) >> kappa z u*
    nw = NearWallMeanViscosity(g, KAPPA, (2.0, 4.0))
    nw.update(st, C_M * length_scale(g, KAPPA), 0.0, 0.01)
    assert np.all(nw.nu_T == 0.0) and np.all(nw.tend_u == 0.0)


def test_overshooting_profile_is_pulled_towards_the_log_law():
    """A profile steeper than the log law near the bed (phi = 1.3) with no LES stress: the term
    carries momentum down, out of the fading part of the layer into the lowest level."""
    g = _grid()
    U = 1.3 * 0.4 / KAPPA * np.log(g.z_c / 1e-5)
    nw = NearWallMeanViscosity(g, KAPPA, (2.0, 4.0))
    nw.update(_laminar(g, U), np.zeros(g.nz), 0.0, 1e-3)
    assert np.all(nw.nu_T[1:-1] >= 0) and nw.nu_T.max() > 0
    assert nw.tend_u[0] > 0
    # a downward flux everywhere: the momentum change has a negative first moment in z
    assert np.sum(g.z_c * nw.tend_u * g.dz_c) < 0
    above = (nw.weight[:-1] == 0.0) & (nw.weight[1:] == 0.0)
    assert above.any() and np.all(nw.tend_u[above] == 0.0)


def test_model_builds_it_only_when_asked():
    from saltstudy.solver.model import Model

    on = resolve_scene(load_case(1, overrides={"closure": {"near_wall": True}}), load_fidelity("smoke"))
    off = resolve_scene(load_case(1, overrides={"closure": {"near_wall": False}}), load_fidelity("smoke"))
    m_on, m_off = Model.from_scene(on), Model.from_scene(off)
    assert m_on.stepper.closure.near_wall is not None and m_off.stepper.closure.near_wall is None
    for _ in range(3):
        m_on.step(m_on.next_dt())
    assert np.all(np.isfinite(m_on.state.u)) and m_on.stepper.closure.near_wall.nu_T.max() >= 0
    assert np.all(np.isfinite(m_on.stepper.closure.near_wall.stress_profile()))


def test_bad_layer_is_rejected_naming_the_field():
    with pytest.raises(ValueError, match="near_wall_layer"):
        Closure(near_wall_layer=(3.0, 1.0))
    with pytest.raises(ConfigError, match="near_wall_layer"):
        load_case(1, overrides={"closure": {"near_wall_layer": [2.0, 2.0]}})
