"""The one time loop (solver/simulation.py) on the smoke grid's particle-free flow: schedules met
exactly, callbacks in order, a stop from a callback, and a resume from its checkpoint that ends
as the uninterrupted run does, bit for bit."""
from __future__ import annotations

import math

import numpy as np
import pytest

from saltstudy.config import load_case, load_fidelity, resolve_scene
from saltstudy.solver.model import Model
from saltstudy.solver.simulation import (TIME_EPS, IterationInterval, Simulation, SpecifiedTimes,
                                         TimeInterval, WallTimeInterval)


@pytest.fixture(scope="module")
def scene():
    return resolve_scene(load_case(2), load_fidelity("smoke"))


class Log:
    """A callback with state: the times it fired at and u at one point then."""

    def __init__(self):
        self.t: list[float] = []
        self.u: list[float] = []

    def __call__(self, sim):
        self.t.append(sim.event_time)
        self.u.append(float(sim.model.state.u[3, 2, 4]))

    def checkpoint(self):
        return {"t": np.array(self.t), "u": np.array(self.u)}

    def restore(self, d):
        self.t, self.u = list(d["t"]), list(d["u"])


def test_schedules_are_met_exactly_and_fire_in_order(scene):
    m = Model.from_scene(scene)
    sim = Simulation(m, stop_time=0.3)
    order: list[tuple[str, float, float]] = []
    every = Log()
    sim.add_callback("every", every, TimeInterval(0.07))
    sim.add_callback("at", lambda s: order.append(("at", s.event_time, s.t)),
                     SpecifiedTimes([0.07, 0.1, 0.25]))
    sim.add_callback("steps", lambda s: order.append(("step", s.n_steps, s.t)), IterationInterval(2))
    assert sim.run().startswith("stop time")
    assert abs(m.t - 0.3) < TIME_EPS
    # multiples of the interval, not sums, from the origin 0
    assert every.t == [0.0, 0.07, 2 * 0.07, 3 * 0.07, 4 * 0.07]
    at = [(when, t) for k, when, t in order if k == "at"]
    assert [w for w, _ in at] == [0.07, 0.1, 0.25]
    # a step never passes a scheduled time: the model is on it when the callback fires
    assert all(abs(t - w) < TIME_EPS for w, t in at)
    # the step callback fires after every second step, before the time callbacks of that instant
    steps = [n for k, n, _ in order if k == "step"]
    assert steps == list(range(2, sim.n_steps + 1, 2))


def test_from_last_counts_from_the_actual_firing(scene):
    m = Model.from_scene(scene)
    sim = Simulation(m, stop_time=0.1)
    log = Log()
    sim.add_callback("log", log, TimeInterval(0.03, from_last=True))
    sim.run()
    assert len(log.t) == 4 and log.t[0] == 0.0
    assert all(abs((b - a) - 0.03) < 1e-12 for a, b in zip(log.t, log.t[1:]))


def test_a_callback_stops_the_run_and_dt_fixed_holds(scene):
    m = Model.from_scene(scene)
    sim = Simulation(m, stop_time=1.0, dt_fixed=0.004)

    def stop_late(s):
        if s.t > 0.05:
            s.stop("enough")

    sim.add_callback("stop", stop_late, IterationInterval(1))
    assert sim.run() == "enough"
    assert sim.n_steps == math.floor(0.05 / 0.004) + 1
    assert sim.last_step.dt == 0.004


def test_wall_time_interval_zero_fires_after_every_step(scene):
    m = Model.from_scene(scene)
    sim = Simulation(m, stop_time=0.05)
    n = []
    sim.add_callback("ckpt", lambda s: n.append(s.n_steps), WallTimeInterval(0.0))
    sim.run()
    assert n == list(range(1, sim.n_steps + 1))


def test_resume_from_a_checkpoint_ends_as_the_uninterrupted_run(scene):
    def build(restart=None):
        m = Model.from_scene(scene, restart=restart)
        sim = Simulation(m, stop_time=0.4)
        log = Log()
        sim.add_callback("log", log, TimeInterval(0.05))
        return sim, log

    full, log_full = build()
    full.run()

    first, log_first = build()
    saved = {}

    def halt(s):
        if s.n_steps == 9:
            saved["model"], saved["sim"] = s.model.checkpoint(), s.checkpoint()
            s.stop("killed")

    first.add_callback("halt", halt, IterationInterval(1))
    assert first.run() == "killed"
    resumed, log_resumed = build(restart=saved["model"])
    resumed.restore(saved["sim"])
    resumed.run()
    assert resumed.n_steps == full.n_steps
    assert log_resumed.t == log_full.t and log_resumed.u == log_full.u
    for name in ("u", "v", "w", "e", "p"):
        assert np.array_equal(getattr(resumed.model.state, name), getattr(full.model.state, name))


def test_bad_schedules_are_refused():
    with pytest.raises(ValueError, match="interval"):
        TimeInterval(0.0)
    with pytest.raises(ValueError, match="sorted"):
        SpecifiedTimes([0.2, 0.1])
    with pytest.raises(ValueError, match="n must"):
        IterationInterval(0)
