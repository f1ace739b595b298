"""Reproducibility: same seed same result, thread-count independence, bit-for-bit checkpoints."""
from __future__ import annotations

import numba
import numpy as np

from test_particles_helpers import component, scene, synthetic_flow


def _run(threads=None, steps=30, ckpt_at=None, prepare=None):
    if threads is not None:
        numba.set_num_threads(threads)
    try:
        sc = scene(2)
        s, st = component(sc)
        if prepare is not None:
            prepare(s)
        synthetic_flow(st, 0.54, sc.case.surface.z0)
        s.activate(st)
        # plus grains near the bed, moving, so that they splash within the run
        rng = np.random.default_rng(5)
        m = 2000
        s.add_parcels(rng.uniform(0, 2.4, m), rng.uniform(0, 1.6, m), rng.uniform(1e-3, 0.05, m),
                      u=rng.uniform(1, 4, m), w=-rng.uniform(0.2, 1.5, m), d=2e-4)
        saved = None
        for i in range(steps):
            if ckpt_at is not None and i == ckpt_at:
                saved = (s.checkpoint(), st.u.copy(), st.v.copy(), st.w.copy())
            s.dynamics(st, 0.004)
        return s, st, saved
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)


def _same(a, b):
    sa, sta, _ = a
    sb, stb, _ = b
    assert sa.n == sb.n
    for f in "xyzuvwd":
        assert np.array_equal(getattr(sa, f), getattr(sb, f)), f
    assert np.array_equal(sta.u, stb.u) and np.array_equal(sta.w, stb.w)
    assert np.array_equal(sta.tke_sink, stb.tke_sink)
    assert sa.counters()["n_impacts"] == sb.counters()["n_impacts"]


def test_same_seed_same_result_and_splash_happened():
    a = _run()
    assert a[0].counters()["n_impacts"] > 100 and a[0].counters()["n_ejections"] > 10
    _same(a, _run())


def test_other_seed_differs():
    a = _run()
    sc = scene(2, seed=99)
    s, st = component(sc)
    s.activate(st)
    assert not np.array_equal(s.x, a[0].x[: s.n])


def test_independent_of_thread_count():
    if numba.config.NUMBA_NUM_THREADS < 2:
        import pytest
        pytest.skip("needs 2 numba threads")
    _same(_run(threads=1), _run(threads=2))


def test_thread_count_chosen_call_by_call_leaves_the_result(monkeypatch):
    """particles.Threads runs each parallel kernel of a step on all the numba threads or on one,
    by their recent times: a run whose choice flips every second call (each kernel, from its
    third call on) equals a run on one thread."""
    if numba.config.NUMBA_NUM_THREADS < 2:
        import pytest
        pytest.skip("needs 2 numba threads")
    from saltstudy.solver.grains import particles

    ref = _run(threads=1)
    monkeypatch.setattr(particles.Threads, "EXPLORE", 2)
    threads = []

    def both_timed(s):
        """Both counts timed: from here on each kernel's choice alternates."""
        for name in particles.PARALLEL:
            t = getattr(s._run, name)
            assert isinstance(t, particles.Threads) and t.kernel is getattr(s.kernels, name)
            t.cost = [1.0, 1.0]
            threads.append(t)

    used = {}
    real = numba.set_num_threads

    def spy(n):
        used[n] = used.get(n, 0) + 1
        real(n)

    monkeypatch.setattr(particles.numba, "set_num_threads", spy)
    try:
        flipped = _run(prepare=both_timed)
    finally:
        monkeypatch.undo()
    assert {t.kernel for t in threads} >= {particles.KERNELS.implicit_coefficients,
                                          particles.KERNELS.advance_all,
                                          particles.KERNELS.splash_runs}
    assert used.get(1, 0) > 30  # one-thread calls did happen
    _same(ref, flipped)


def test_checkpoint_restore_bit_for_bit():
    ref = _run(steps=30)
    _, _, saved = _run(steps=12, ckpt_at=12 - 1)  # checkpoint before step 11 (sort step 10 done)
    ck, u, v, w = saved
    sc = scene(2)
    s, st = component(sc)
    synthetic_flow(st, 0.54, sc.case.surface.z0)
    st.u[...], st.v[...], st.w[...] = u, v, w
    s.restore(ck)
    st.tke_sink = np.zeros(st.u.shape)
    for _ in range(30 - 11):
        s.dynamics(st, 0.004)
    _same(ref, (s, st, None))
