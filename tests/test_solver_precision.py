"""The flow in single precision (``time.precision = "single"``): float32 fields and stencil
arithmetic, the projection's residual at float32's round-off, and the momentum exchanged with the
grains still balanced in float64."""
from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from solver_helpers import smoke_scene
from test_particles_helpers import component, scene, synthetic_flow
from saltstudy.config import TimeStepping, load_fidelity
from saltstudy.solver.flow.pressure import max_relative_divergence
from saltstudy.solver.flow.stepper import FlowNumerics
from saltstudy.solver.model import Model
from saltstudy.solver.state import FlowState

FIDELITIES = ("smoke", "quick", "reduced", "fine", "paper")


def _with_time(sc, **time):
    fid = sc.fidelity
    return sc.model_copy(update={"fidelity": fid.model_copy(
        update={"time": TimeStepping.model_validate({**fid.time.model_dump(), **time})})})


def test_precision_is_a_validated_fidelity_knob():
    assert TimeStepping().precision == "double"
    assert TimeStepping(precision="single").precision == "single"
    with pytest.raises(ValidationError, match="precision"):
        TimeStepping(precision="half")
    with pytest.raises(ValueError, match="precision"):
        FlowNumerics(precision="quad")
    assert FlowNumerics(precision="single").dtype == np.float32
    for name in FIDELITIES:       # every shipped fidelity validates, whichever precision it names
        assert load_fidelity(name).time.precision in ("single", "double")


def test_single_precision_flow_steps_in_float32_and_projects_to_its_round_off():
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
    rel = max_relative_divergence(m32.grid, s.u, s.v, s.w)
    assert rel < 1e-6
    # the same physics: three steps from the same start agree to float32's precision
    for name in ("u", "v", "w", "e"):
        a, b = getattr(s, name), getattr(m64.state, name)
        assert np.abs(a - b).max() <= 1e-5 * np.abs(b).max(), name


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
    air = lambda: np.array([1.2 * np.sum(st.u * vol, dtype=np.float64),  # noqa: E731
                            1.2 * np.sum(st.v * vol, dtype=np.float64)])
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
