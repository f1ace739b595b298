"""Restart: N steps == N/2 steps + checkpoint + restore + N/2 steps, bit for bit."""
from __future__ import annotations

import numpy as np

from solver_helpers import smoke_scene
from saltstudy.solver.model import Model


def _run(m, n):
    for _ in range(n):
        m.step(m.next_dt())


def test_restart_is_bit_for_bit():
    sc = smoke_scene()
    a = Model.from_scene(sc)
    _run(a, 6)
    b = Model.from_scene(sc)
    _run(b, 3)
    ck = b.checkpoint()
    assert all(isinstance(v, (np.ndarray, float, int, str)) for v in ck.values())
    c = Model.from_scene(sc, restart=ck)
    _run(c, 3)
    for name in ("u", "v", "w", "e", "p"):
        assert np.array_equal(getattr(a.state, name), getattr(c.state, name)), name
    assert a.state.t == c.state.t and a.state.step == c.state.step
    assert a.state.u_drive == c.state.u_drive
    # NaN until the top drive's controller first measures (the pressure-gradient drive has none)
    assert np.array_equal(a.controller.tau_ref_filtered, c.controller.tau_ref_filtered, equal_nan=True)
    # the RNG continues where it was
    assert a.rng.random() == c.rng.random()


def test_checkpoint_is_a_copy_and_same_seed_same_start():
    sc = smoke_scene()
    a, b = Model.from_scene(sc), Model.from_scene(sc)
    assert np.array_equal(a.state.u, b.state.u)
    ck = a.checkpoint()
    a.step(a.next_dt())
    assert not np.array_equal(ck["u"], a.state.u)
    other = Model.from_scene(smoke_scene().model_copy(
        update={"case": sc.case.model_copy(update={"seed": 7})}))
    assert not np.array_equal(other.state.u, b.state.u)
