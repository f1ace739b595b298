"""The flow in single precision (``time.precision = "single"``): a validated fidelity knob whose
default is double; float32 fields and stencil arithmetic that conserve momentum and keep the
projection's residual at float32's round-off; the momentum exchanged with the grains still
balanced in float64."""
from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from solver_helpers import make_stepper, random_velocity, smoke_scene, stretched_grid
from test_particles_helpers import component, scene, synthetic_flow
from saltstudy.config import ConfigError, TimeStepping, load_fidelity
from saltstudy.solver.flow.pressure import max_relative_divergence
from saltstudy.solver.flow.stepper import FlowNumerics
from saltstudy.solver.model import Model
from saltstudy.solver.state import FlowState

FIDELITIES = ("smoke", "quick", "reduced", "fine", "paper")
#: float32's unit round-off (2^-24)
EPS32 = float(np.finfo(np.float32).eps) / 2


def _with_time(sc, **time):
    fid = sc.fidelity
    return sc.model_copy(update={"fidelity": fid.model_copy(
        update={"time": TimeStepping.model_validate({**fid.time.model_dump(), **time})})})


def test_precision_is_a_validated_fidelity_knob_whose_default_is_double(tmp_path):
    assert TimeStepping().precision == "double"
    assert TimeStepping(precision="single").precision == "single"
    with pytest.raises(ValidationError, match="precision"):
        TimeStepping(precision="half")
    with pytest.raises(ValueError, match="precision"):
        FlowNumerics(precision="quad")
    assert FlowNumerics().dtype == np.float64
    assert FlowNumerics(precision="single").dtype == np.float32
    for name in FIDELITIES:       # the shipped fidelities run the flow in double
        assert load_fidelity(name).time.precision == "double", name
    bad = tmp_path / "half.toml"
    bad.write_text('based_on = "smoke"\n[time]\nprecision = "half"\n')
    with pytest.raises(ConfigError, match=r"time\.precision: Input should be 'double' or 'single'"):
        load_fidelity(bad)
    state = Model.from_scene(smoke_scene()).state
    assert {a.dtype for a in (state.u, state.v, state.w, state.e, state.p)} == {np.dtype(np.float64)}


# the float32 kernels compile on first use; the explicit stages (shared with the Model test below)
# are the default suite's, the implicit ones and the grains' float32 variants the slow suite's
@pytest.mark.parametrize("scheme", ["explicit", pytest.param("implicit", marks=pytest.mark.slow)])
def test_single_precision_periodic_box_conserves_momentum_and_mass_to_float32_round_off(scheme):
    """No wall, no drive, no damping: the centred advection, the SGS diffusion (zero flux at the
    bed and the lid) and the projection move momentum about but sum it to zero, so the box's
    momentum changes by round-off only; in float32 that is a few EPS32 of the box's |momentum|
    per step, against float64's 1e-15. The projection leaves the divergence at float32's
    round-off relative to the flow."""
    g = stretched_grid(nx=16, ny=12, nz=12, dz_bottom=0.05)
    vol_c = g.dx * g.dy * g.dz_c
    vol_f = g.dx * g.dy * g.dz_f
    u0, v0, w0 = random_velocity(g, seed=11, mean_u=1.0)
    e0 = np.random.default_rng(12).uniform(0.05, 0.5, g.shape)
    dt = 0.2 / (4.0 / min(g.dx, g.dy, g.dz_c.min()))     # Courant ~ 0.2
    nsteps = 4
    out = {}
    for prec in ("double", "single"):
        st = make_stepper(g, wall=False, vertical_diffusion=scheme, precision=prec)
        s = FlowState.zeros(g, st.dtype)
        s.u[...], s.v[...], s.w[...], s.e[...] = u0, v0, w0, e0
        st.pressure.project(s.u, s.v, s.w)

        def momentum():
            return np.array([np.sum(vol_c * s.u, dtype=np.float64),
                             np.sum(vol_c * s.v, dtype=np.float64),
                             np.sum(vol_f * s.w, dtype=np.float64)])

        m0 = momentum()
        scale = np.sum(vol_c * np.abs(s.u), dtype=np.float64)
        for _ in range(nsteps):
            st.step(s, dt)
        assert {a.dtype for a in (s.u, s.v, s.w, s.e, s.p, st.nu)} == {st.dtype}
        out[prec] = (np.abs(momentum() - m0).max() / scale,
                     max_relative_divergence(g, s.u, s.v, s.w), s)
        st.close()
    drift64, div64, s64 = out["double"]
    drift32, div32, s32 = out["single"]
    assert drift64 < 1e-13 and div64 < 1e-12
    assert drift32 < 20 * nsteps * EPS32
    assert div32 < 20 * EPS32
    # float32 round-off, not float64's: the check above would pass for a flow left in double
    assert div32 > 10 * div64
    # the flow moved, and both precisions moved it the same way (to float32's precision over
    # a few steps)
    assert np.abs(s64.v - v0).max() > 0.1
    for name in ("u", "v", "w", "e"):
        a, b = getattr(s32, name), getattr(s64, name)
        assert np.abs(a - b).max() <= 1e-4 * np.abs(b).max(), name


def test_single_precision_model_steps_in_float32_and_projects_to_its_round_off():
    sc = smoke_scene()
    runs = {}
    for prec in ("double", "single"):
        m = Model.from_scene(_with_time(sc, precision=prec, vertical_diffusion="explicit"))
        dt = m.next_dt()
        for _ in range(3):
            m.step(dt)
        runs[prec] = m
    m32, m64 = runs["single"], runs["double"]
    s = m32.state
    assert {a.dtype for a in (s.u, s.v, s.w, s.e, s.p, m32.stepper.nu)} == {np.dtype(np.float32)}
    # the stage kernel ran in float32: its scalars (the stage's c dt) were float32, not float64
    from saltstudy.solver.flow.stepper import _momentum_stage
    assert any(str(sig[13]) == "float32" for sig in _momentum_stage.signatures)
    # the correction is computed in double and rounded once: the residual is float32's round-off
    assert max_relative_divergence(m32.grid, s.u, s.v, s.w) < 20 * EPS32
    # the same physics: three steps from the same start agree to float32's precision
    for name in ("u", "v", "w", "e"):
        a, b = getattr(s, name), getattr(m64.state, name)
        assert np.abs(a - b).max() <= 1e-5 * np.abs(b).max(), name
    for m in (m32, m64):
        m.close()


@pytest.mark.slow
def test_single_precision_exchange_balances_momentum_in_float64():
    """The grains read float32 air and give it their drag once per step: the momentum they lose
    is what the exchange's float64 tally gives the air, to float64 round-off; the float32 air
    receives it to float32 round-off."""
    sc = scene(7)
    s, st64 = component(sc, gravity=False)
    st = FlowState.zeros(st64.grid, np.float32)
    synthetic_flow(st64, 0.57, 1e-5, amp=0.5)
    for name in ("u", "v"):
        getattr(st, name)[...] = getattr(st64, name)
    rng = np.random.default_rng(3)
    n = 2000
    g = s.grid
    s.add_parcels(rng.uniform(0, g.Lx, n), rng.uniform(0, g.Ly, n), rng.uniform(6e-4, 0.5, n),
                  u=rng.normal(0, 2, n), v=rng.normal(0, 1, n), w=0.0,
                  d=rng.uniform(60e-6, 120e-6, n))
    vol = g.dx * g.dy * g.dz_c
    rho = sc.case.air.rho
    air = lambda: np.array([rho * np.sum(st.u * vol, dtype=np.float64),  # noqa: E731
                            rho * np.sum(st.v * vol, dtype=np.float64)])
    a0, p0 = air(), s.grain_momentum()[:2].copy()
    for _ in range(20):
        s.dynamics(st, 0.01)
    assert st.u.dtype == np.float32
    lost = p0 - s.grain_momentum()[:2]
    given = s.counters()["momentum_to_air"][:2]
    scale = np.abs(s.Q * s.mass * s.u).sum() + np.abs(a0).sum()
    assert abs(given[0]) > 1e-3 * scale                     # the exchange did something
    assert np.all(np.abs(lost - given) <= 1e-12 * scale)    # the float64 tally: exact
    assert np.all(np.abs(air() - a0 - given) <= 1e-5 * scale)   # the float32 air: its round-off
