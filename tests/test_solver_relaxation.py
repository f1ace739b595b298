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
    for name in ("quick", "reduced", "stability/reduced-short-maxcfl"):
        f = load_fidelity(name)
        assert 0 < f.relaxation.until <= f.sampling.start


# ---- the profile target ---------------------------------------------------------------------
from saltstudy.solver.flow.relaxation import ProfileRelaxation  # noqa: E402

Z_C = np.array([0.005, 0.02, 0.06, 0.15, 0.3, 0.6, 1.2, 2.0, 3.0, 4.0])
ANCHOR = 0.3                                       # a level: U(z_a) is u_mean[4]


def _log_profile(u_star, z0):
    return u_star / 0.4 * np.log(Z_C / z0)


def _field(profile, seed=3):
    """(4, 3, nz) field: the mean ``profile`` plus zero-mean fluctuations on each level."""
    rng = np.random.default_rng(seed)
    dev = rng.normal(0.0, 0.5, (4, 3, Z_C.size))
    dev -= dev.mean(axis=(0, 1))
    return profile[None, None, :] + dev


class _StateOnly:
    """What ``start`` reads from a model when it is given no reference profile."""

    def __init__(self, u):
        self.state = type("S", (), {"u": u})()


def _started(reference, timescale=1.0, until=10.0):
    r = ProfileRelaxation(Z_C, ANCHOR, timescale, until)
    r.start(None, reference)
    return r


def test_profile_target_leaves_a_column_of_the_reference_shape_alone_at_any_offset():
    """A profile of the particle-free shape, shifted by any constant (a saltation layer with any
    z0s): already at the target, so no force, u untouched."""
    ref = _log_profile(0.5, 1e-5)
    r = _started(ref)
    for shift in (0.0, -3.7):                      # -3.7 m/s: (u*/kappa) ln(z0s/z0) at z0s ~ 0.2 mm
        u = _field(ref + shift)
        u0 = u.copy()
        tgt = r.update(u, 0.01, 0.0)
        assert np.allclose(tgt, ref + shift, rtol=0, atol=1e-12)
        assert np.allclose(r.force, 0.0, rtol=0, atol=1e-9)
        assert np.allclose(u, u0, rtol=0, atol=1e-12)


def test_profile_target_moves_the_mean_above_the_anchor_and_leaves_the_layer_and_the_eddies():
    """Above 2 z_a the mean lands on U(z_a) + S(z) - S(z_a) (one step with dt = T); below z_a
    nothing moves; each level moves uniformly, so the fluctuations are the same."""
    ref = _log_profile(0.5, 1e-5)
    salting = _log_profile(0.5, 5e-4)              # a saltating column: lower by a constant above
    salting[Z_C > ANCHOR] += 1.5                   # ... but the air above still 1.5 m/s too fast
    u = _field(salting)
    u0 = u.copy()
    r = _started(ref, timescale=0.01)
    tgt = r.update(u, 0.01, 2.0)
    expected = salting[4] + ref - ref[4]
    assert np.allclose(tgt, expected, rtol=0, atol=1e-12)
    full = Z_C >= 2 * ANCHOR
    assert np.allclose(u.mean(axis=(0, 1))[full], expected[full], rtol=0, atol=1e-12)
    below = Z_C <= ANCHOR
    assert np.array_equal(u[..., below], u0[..., below])
    step = u - u0
    assert np.allclose(step, step[:1, :1, :], rtol=0, atol=1e-12)   # uniform on each level
    assert np.all(r.force[full] < 0)                                 # decelerates the fast column
    # a partial step (dt < T) goes the fraction dt/T of the way
    u = _field(salting)
    r2 = _started(ref, timescale=1.0)
    r2.update(u, 0.1, 2.0)
    moved = u.mean(axis=(0, 1)) - salting
    assert np.allclose(moved[full], 0.1 * (expected - salting)[full], rtol=1e-12, atol=1e-12)


def test_profile_target_is_off_after_until_and_needs_its_reference():
    ref = _log_profile(0.5, 1e-5)
    r = _started(ref, until=1.0)
    u = _field(ref + 1.0)
    u[..., 6:] += 2.0
    u0 = u.copy()
    assert r.update(u, 0.01, 1.0) is None
    assert np.array_equal(u, u0) and np.all(r.force == 0.0)
    bare = ProfileRelaxation(Z_C, ANCHOR, 1.0, 10.0)
    with pytest.raises(RuntimeError, match="reference"):
        bare.update(u, 0.01, 0.0)
    with pytest.raises(ValueError, match="levels"):
        bare.start(None, ref[:-1])
    with pytest.raises(ValueError, match="anchor"):
        ProfileRelaxation(Z_C, 5.0, 1.0, 10.0)
    # without a reference, start takes the instantaneous horizontal mean
    bare.start(_StateOnly(u), None)
    assert np.allclose(bare.shape, u.mean(axis=(0, 1)) - u.mean(axis=(0, 1))[4], atol=1e-12)


def test_profile_target_checkpoint_restores_its_reference():
    ref = _log_profile(0.5, 1e-5)
    a = _started(ref)
    b = ProfileRelaxation(Z_C, ANCHOR, 1.0, 10.0)
    assert b.checkpoint() == {}
    b.restore(a.checkpoint())
    ua, ub = _field(ref + 2.0), _field(ref + 2.0)
    ua[..., 7:] -= 1.0
    ub[...] = ua
    a.update(ua, 0.05, 0.5)
    b.update(ub, 0.05, 0.5)
    assert np.array_equal(ua, ub)


def test_config_profile_target_is_on_without_a_gain_and_keeps_its_anchor_below_the_damping():
    assert Relaxation(target="profile", until=5.0).on
    assert not Relaxation(target="profile", until=0.0).on
    assert not Relaxation(gain=0.0, until=5.0).on
    f = load_fidelity("reduced")
    assert f.relaxation.target == "profile" and f.relaxation.on
    data = f.model_dump()
    data["relaxation"]["anchor"] = f.grid.Lz - f.grid.damping_depth + 0.1
    with pytest.raises(pydantic.ValidationError, match="relaxation.anchor"):
        type(f).model_validate(data)


def _profile_scene():
    from test_particles_helpers import scene
    sc = scene(2, "smoke")
    f = sc.fidelity
    fid = f.model_copy(update={"relaxation": Relaxation(target="profile", anchor=0.3, timescale=0.05,
                                                        until=f.sampling.start)})
    return type(sc)(label=sc.label, case=sc.case, fidelity=fid)


def test_model_profile_target_nudges_the_drive_to_the_feed_forward_of_the_target_and_restarts():
    from saltstudy.solver.model import Model
    sc = _profile_scene()
    m = Model.from_scene(sc, saltation=True)
    for _ in range(3):
        m.step(0.01)
    ref = m.state.u.mean(axis=(0, 1)) + 0.4 * np.log1p(m.grid.z_c)   # a reference of another shape
    m.activate_saltation(ref)
    r = m.relaxation
    assert isinstance(r, ProfileRelaxation)
    assert np.allclose(r.shape, ref - r.anchor_wind(ref), rtol=0, atol=1e-12)
    ck = m.checkpoint()
    assert np.array_equal(ck["relaxation/shape"], r.shape)
    a = Model.from_scene(sc, saltation=True, restart=ck)
    a.step(0.01)
    # the same step with the nudge undone: the drive moved by dt/T of its gap to the feed-forward
    b = Model.from_scene(sc.model_copy(update={"fidelity": sc.fidelity.model_copy(
        update={"relaxation": Relaxation()})}), saltation=True, restart=ck)
    b.step(0.01)
    tgt = a.relaxation.target(b.state.u.mean(axis=(0, 1)))
    nudge = (0.01 / 0.05) * (a.controller.feed_forward(tgt) - b.state.u_drive)
    assert a.state.u_drive - b.state.u_drive == pytest.approx(nudge, rel=1e-9, abs=1e-12)
    assert np.array_equal(a.state.w, b.state.w)
    # bit for bit over a restart
    m2 = Model.from_scene(sc, saltation=True, restart=ck)
    for _ in range(4):
        m.step(0.01)
        m2.step(0.01)
    assert np.array_equal(m.state.u, m2.state.u) and m.state.u_drive == m2.state.u_drive


def test_the_profile_target_shares_the_spin_up_and_its_starts_with_the_other_relaxations():
    """The relaxation acts after activation only: the shared spin-up and the staggered links a
    reduced case starts from have the same keys (the same archives) with the profile target, the
    bed-stress target or none; only the saltation run differs."""
    from saltstudy.workflow import keys
    from test_particles_helpers import scene
    sc = scene(7, "reduced")
    assert sc.fidelity.relaxation.target == "profile"
    variants = [sc] + [type(sc)(label=sc.label, case=sc.case,
                                fidelity=sc.fidelity.model_copy(update={"relaxation": rl}))
                       for rl in (Relaxation(gain=20.0, until=10.0), Relaxation())]
    starts = [keys.start_keys(v) for v in variants]
    assert len(starts[0]) == 7 and starts[1] == starts[0] and starts[2] == starts[0]
    salt = {keys.saltation_key(v, starts[0][-1]) for v in variants}
    assert len(salt) == 3
