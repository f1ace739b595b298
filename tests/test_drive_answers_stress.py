"""The top drive that answers the stress at z_ref (fidelity ``relaxation.stress_gain`` K_p):
M = u*s^2 - K_p (tau_f - u*s^2), the same fixed point as the constant drive, only after activation,
and carried through a restart."""
from __future__ import annotations

import math

import numpy as np
import pytest

from solver_helpers import smoke_scene  # noqa: F401  (imports saltstudy first)
from saltstudy.config import load_case, load_fidelity, resolve_scene
from saltstudy.solver.model import Model


def _model(gain: float, saltation: bool = False) -> Model:
    fid = load_fidelity("smoke")
    fid = fid.model_copy(update={"relaxation": fid.relaxation.model_copy(
        update={"stress_gain": gain, "stress_timescale": 0.5})})
    return Model.from_scene(resolve_scene(load_case(1), fid), saltation=saltation)


def _momentum_fed(m: Model) -> float:
    """M = sum_k f_k (u_drive - <u>_k) dz_k [m^2 s^-2] with the model's own profile."""
    um = m._damped_mean_u()
    return float(np.dot(m.controller.f_dz, m.state.u_drive - um))


@pytest.mark.parametrize("excess", [0.3, -0.2, 0.0])
def test_drive_feeds_less_when_the_stress_at_zref_is_high(excess):
    m = _model(2.0)
    c = m.controller
    target = c.target_stress
    c.answers_stress = True
    tau = target * (1.0 + excess)
    # a time step far longer than T_s: the filter and the drive reach their targets in one update
    for _ in range(3):
        c.update(m.state, 5.0, m._damped_mean_u(), tau)
    assert c.tau_ref_fast == pytest.approx(tau, rel=1e-12)
    assert _momentum_fed(m) == pytest.approx(target - 2.0 * (tau - target), rel=1e-9, abs=1e-12)
    if excess == 0.0:   # the fixed point: a column at tau(z_ref) = u*s^2 is fed exactly u*s^2
        assert _momentum_fed(m) == pytest.approx(target, rel=1e-9)


def test_drive_is_bounded_so_a_gust_cannot_reverse_it():
    m = _model(10.0)
    c = m.controller
    c.answers_stress = True
    for tau, bound in ((3.0 * c.target_stress, 0.0), (-2.0 * c.target_stress, 2.0 * c.target_stress)):
        c.tau_ref_fast = math.nan
        for _ in range(3):
            c.update(m.state, 5.0, m._damped_mean_u(), tau)
        assert _momentum_fed(m) == pytest.approx(bound, abs=1e-9 * c.target_stress)


@pytest.mark.parametrize("gain", [2.0, 0.0])
def test_gain_is_off_before_activation_and_on_after(gain):
    m = _model(gain, saltation=True)
    c = m.controller
    assert not c.answers_stress          # spin-up and staggered starts: the constant drive
    c.tau_ref_fast = 2.0 * c.target_stress
    assert c.momentum_target() == pytest.approx(c.target_stress)
    m.activate_saltation()
    assert c.answers_stress == (gain > 0)
    expected = c.target_stress * (1.0 - gain)
    assert c.momentum_target() == pytest.approx(max(0.0, expected))


def test_gain_survives_a_restart():
    m = _model(2.0)
    c = m.controller
    c.answers_stress = True
    c.update(m.state, 0.01, m._damped_mean_u(), 1.4 * c.target_stress)
    ck = c.checkpoint()
    m2 = _model(2.0)
    m2.controller.restore(ck)
    assert m2.controller.answers_stress
    assert m2.controller.tau_ref_fast == c.tau_ref_fast
    assert m2.controller.momentum_target() == c.momentum_target()
    # a checkpoint written before the term existed restores it off
    old = {k: v for k, v in ck.items() if k not in ("tau_ref_fast", "answers_stress")}
    m3 = _model(2.0)
    m3.controller.restore(old)
    assert not m3.controller.answers_stress and math.isnan(m3.controller.tau_ref_fast)


def test_the_gain_does_not_change_the_shared_spinup():
    a = resolve_scene(load_case(2), load_fidelity("reduced"))
    fid = a.fidelity.model_copy(update={"relaxation": a.fidelity.relaxation.model_copy(
        update={"stress_gain": 3.0})})
    b = resolve_scene(load_case(2), fid)
    assert a.spinup_slice() == b.spinup_slice()
