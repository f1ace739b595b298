"""Column relaxation after activation (solver/flow/relaxation.py): fixed point, rate, switch-off, restart."""
from __future__ import annotations

import math

import numpy as np
import pydantic
import pytest

from saltstudy.config import Relaxation, load_fidelity
from saltstudy.solver.flow.relaxation import ColumnRelaxation

U_STAR, LZ, AREA, RHO = 0.5, 4.0, 20.0, 1.2


def _relax(gain=4.0, until=10.0, timescale=1.0):
    return ColumnRelaxation(U_STAR, LZ, gain, timescale, until, AREA, RHO)


def _taux(tau_air):
    return np.full((4, 3), -tau_air)     # the flux u'w' at the bed: negative for a drag


def test_no_force_at_the_fixed_point():
    """Air + grain bed stress equal to u*s^2: B = 0 and u is untouched."""
    r = _relax()
    u = np.full((4, 3, 5), 7.0)
    tau_air, tau_grain, dt = 0.05, U_STAR ** 2 - 0.05, 0.01
    p = 0.0
    for n in range(50):
        p -= tau_grain * dt * AREA * RHO             # the air loses tau_grain to the grains
        r.update(u, _taux(tau_air), p, dt, n * dt)
    assert r.tau_bed_filtered == pytest.approx(U_STAR ** 2, rel=1e-12)
    assert abs(r.force) < 1e-12
    assert np.allclose(u, 7.0, rtol=0, atol=1e-12)


def test_excess_bed_stress_decelerates_the_column_uniformly_at_K_times_the_excess():
    r = _relax(gain=4.0, timescale=1e-9)            # no filtering: B follows the bed stress
    u = np.random.default_rng(1).normal(5.0, 1.0, (4, 3, 5))
    u0 = u.copy()
    excess, dt = 0.2, 0.01
    du = r.update(u, _taux(U_STAR ** 2 + excess), 0.0, dt, 0.0)
    expected = -4.0 * excess / LZ
    assert du == pytest.approx(expected * dt, rel=1e-12)
    assert r.force == pytest.approx(expected, rel=1e-12)
    assert np.allclose(u - u0, expected * dt, rtol=0, atol=1e-14)   # the same at every point


def test_switched_off_after_until_and_with_zero_gain():
    u = np.zeros((2, 2, 2))
    r = _relax(until=1.0, timescale=1e-9)
    r.update(u, _taux(1.0), 0.0, 0.01, 1.0)        # t since activation == until: off
    assert r.force == 0.0 and np.all(u == 0.0)
    r0 = _relax(gain=0.0)
    r0.update(u, _taux(1.0), 0.0, 0.01, 0.0)
    assert r0.force == 0.0 and np.all(u == 0.0)


def test_checkpoint_restore_continues_identically():
    a, b = _relax(), _relax()
    ua, ub = np.ones((2, 2, 2)), np.ones((2, 2, 2))
    for n in range(5):
        a.update(ua, _taux(0.3 + 0.01 * n), -0.5 * n, 0.01, 0.01 * n)
    b.restore(a.checkpoint())
    ub[...] = ua
    for n in range(5, 9):
        for r, u in ((a, ua), (b, ub)):
            r.update(u, _taux(0.3 + 0.01 * n), -0.5 * n, 0.01, 0.01 * n)
    assert a.force == b.force and np.array_equal(ua, ub)
    fresh = _relax()
    fresh.restore(_relax().checkpoint())             # never updated: NaN filter
    assert math.isnan(fresh.tau_bed_filtered)


def test_config_rejects_relaxation_into_the_sampling_window():
    f = load_fidelity("quick")
    data = f.model_dump()
    data["relaxation"] = {"gain": 2.0, "until": f.sampling.start + 1.0}
    with pytest.raises(pydantic.ValidationError, match="relaxation.until"):
        type(f).model_validate(data)
    with pytest.raises(pydantic.ValidationError, match="gain"):
        Relaxation(gain=-1.0)


# ---- inside the Model -----------------------------------------------------------------------
def _smoke_scene(gain):
    from test_particles_helpers import scene
    sc = scene(2, "smoke")
    f = sc.fidelity
    fid = f.model_copy(update={"relaxation": Relaxation(gain=gain, timescale=0.1, until=f.sampling.start)})
    return type(sc)(label=sc.label, case=sc.case, fidelity=fid)


def _activated(sc, steps=6):
    from saltstudy.solver.model import Model
    m = Model.from_scene(sc, saltation=True)
    for _ in range(3):
        m.step(0.01)
    m.activate_saltation()
    for _ in range(steps):
        m.step(0.01)
    return m


def test_model_builds_it_only_when_asked_and_applies_a_uniform_force():
    on, off = _activated(_smoke_scene(6.0)), _activated(_smoke_scene(0.0))
    assert off.relaxation is None and not any(k.startswith("relaxation/") for k in off.checkpoint())
    r = on.relaxation
    assert r is not None and r.force != 0.0
    assert r.force == pytest.approx(-6.0 * (r.tau_bed_filtered - 0.54 ** 2) / on.grid.Lz, rel=1e-12)
    # one more step from identical states: the two models differ by exactly B dt, uniformly
    ck = on.checkpoint()
    from saltstudy.solver.model import Model
    a = Model.from_scene(_smoke_scene(6.0), saltation=True, restart=ck)
    b = Model.from_scene(_smoke_scene(0.0), saltation=True, restart=ck)
    a.step(0.01)
    b.step(0.01)
    diff = a.state.u - b.state.u
    assert np.allclose(diff, a.relaxation.force * 0.01, rtol=1e-9, atol=1e-13)
    assert np.array_equal(a.state.w, b.state.w)
    # the top drive's target moves with the column, so the Rayleigh layer does not undo the shift
    assert a.drive == "top"
    assert a.state.u_drive - b.state.u_drive == pytest.approx(a.relaxation.force * 0.01, rel=1e-9)


def test_model_restart_with_relaxation_is_bit_for_bit():
    from saltstudy.solver.model import Model
    sc = _smoke_scene(4.0)
    m = _activated(sc)
    ck = m.checkpoint()
    assert "relaxation/tau_bed_filtered" in ck
    m2 = Model.from_scene(sc, saltation=True, restart=ck)
    for _ in range(5):
        m.step(0.01)
        m2.step(0.01)
    assert m.relaxation.force == m2.relaxation.force
    assert np.array_equal(m.state.u, m2.state.u)


def test_paper_fidelity_runs_without_it_and_laptop_fidelities_stop_it_before_sampling():
    assert load_fidelity("paper").relaxation.gain == 0.0
    for name in ("quick", "reduced-relaxed", "stability/reduced-short-maxcfl"):
        f = load_fidelity(name)
        assert 0 < f.relaxation.until <= f.sampling.start
