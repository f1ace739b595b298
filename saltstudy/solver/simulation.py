"""``Simulation``: the one time loop. A model, a stop time and schedules of callbacks.

Every run goes through :meth:`Simulation.run` (spin-up, continuation, saltation run, probes); they
differ only in their callbacks. One pass: the callbacks whose time has come fire in the order they
were added (one may ``stop`` the run); one step of the model, clipped so that the next scheduled
time is met exactly; the per-step callbacks. Times are relative to ``origin`` (the activation
time for a saltation run) and the step's limit is formed from the absolute target, so two runs
with the same origin and schedule take the same steps to the last bit. The loop's own state is
pure data (:meth:`checkpoint`): restored beside the model's, a run ends as the uninterrupted one.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable

#: two times closer than this are the same time [s]; far below any time step
TIME_EPS = 1e-9


class TimeInterval:
    """Fires at model times ``start + k interval`` since the origin (no drift), or, ``from_last``,
    ``interval`` after the last firing (the spin-up's steadiness series)."""

    def __init__(self, interval: float, start: float = 0.0, from_last: bool = False):
        if not (interval > 0 and math.isfinite(interval)):
            raise ValueError(f"TimeInterval: interval must be positive (got {interval!r})")
        self.interval, self.start, self.from_last = float(interval), float(start), from_last
        self.count = 0
        self.next = float(start)

    def next_time(self) -> float | None:
        return self.next

    def fired(self, t: float) -> None:
        self.count += 1
        self.next = (t + self.interval if self.from_last
                     else self.start + self.count * self.interval)

    def state(self) -> dict[str, float]:
        return {"count": self.count, "next": self.next}

    def restore(self, d: dict[str, Any]) -> None:
        self.count, self.next = int(d["count"]), float(d["next"])


class SpecifiedTimes:
    """Fires at each of a sorted list of model times (relative to the origin)."""

    def __init__(self, times):
        self.times = [float(t) for t in times]
        if any(b < a for a, b in zip(self.times, self.times[1:])):
            raise ValueError("SpecifiedTimes: times must be sorted")
        self.index = 0

    def next_time(self) -> float | None:
        return self.times[self.index] if self.index < len(self.times) else None

    def fired(self, t: float) -> None:
        self.index += 1

    def state(self) -> dict[str, int]:
        return {"index": self.index}

    def restore(self, d: dict[str, Any]) -> None:
        self.index = int(d["index"])


class IterationInterval:
    """Fires after every ``n``-th step of this call of ``run`` (``n = 1``: after every step)."""

    def __init__(self, n: int = 1):
        if n < 1:
            raise ValueError(f"IterationInterval: n must be >= 1 (got {n!r})")
        self.n = int(n)

    def next_time(self) -> None:
        return None

    def due_after_step(self, sim: "Simulation") -> bool:
        return sim.steps_this_run % self.n == 0

    def fired(self, t: float) -> None:
        pass


class WallTimeInterval:
    """Fires after a step once ``seconds`` of wall time have passed since the last firing."""

    def __init__(self, seconds: float):
        if not seconds >= 0:
            raise ValueError(f"WallTimeInterval: seconds must be >= 0 (got {seconds!r})")
        self.seconds = float(seconds)
        self.last = time.perf_counter()

    def next_time(self) -> None:
        return None

    def due_after_step(self, sim: "Simulation") -> bool:
        return time.perf_counter() - self.last >= self.seconds

    def fired(self, t: float) -> None:
        self.last = time.perf_counter()


@dataclass
class Callback:
    """``func(sim)`` on ``schedule``; a ``func`` with ``checkpoint``/``restore`` is checkpointed."""
    func: Callable[["Simulation"], None]
    schedule: Any

    @property
    def timed(self) -> bool:
        return not hasattr(self.schedule, "due_after_step")


class Simulation:
    """Runs ``model`` to ``origin + stop_time``; ``dt_fixed``: every step that long (clipped)."""

    def __init__(self, model, stop_time: float = math.inf, origin: float | None = None,
                 dt_fixed: float | None = None):
        if not stop_time > 0:
            raise ValueError(f"Simulation: stop_time must be positive (got {stop_time!r})")
        self.model = model
        self.origin = float(model.t if origin is None else origin)
        self.stop_time = float(stop_time)
        self.dt_fixed = dt_fixed
        self.callbacks: dict[str, Callback] = {}
        #: steps taken by this simulation, over all its resumes
        self.n_steps = 0
        #: steps taken by the present call of ``run``
        self.steps_this_run = 0
        #: the last step's StepInfo (None before the first step of this call of ``run``)
        self.last_step = None
        self.stop_reason: str | None = None
        #: the scheduled time of the firing callback (since the origin): records carry it
        self.event_time: float = math.nan

    @property
    def t(self) -> float:
        """Model time since the origin [s]."""
        return self.model.t - self.origin

    def add_callback(self, name: str, func: Callable[["Simulation"], None], schedule) -> None:
        if name in self.callbacks:
            raise ValueError(f"Simulation: a callback named {name!r} exists")
        self.callbacks[name] = Callback(func, schedule)

    def stop(self, reason: str) -> None:
        """Ends the run after the callback that calls it (the loop's next check)."""
        self.stop_reason = reason

    # ---- the loop --------------------------------------------------------------------------
    def run(self) -> str:
        """Step until the stop time or a callback's ``stop``; returns why it stopped."""
        self.stop_reason = None
        self.steps_this_run = 0
        timed = [(n, c) for n, c in self.callbacks.items() if c.timed]
        stepped = [(n, c) for n, c in self.callbacks.items() if not c.timed]
        for _, c in stepped:
            c.schedule.fired(self.t)          # wall-time intervals count from now
        m = self.model
        while True:
            for _, c in timed:
                while (nt := c.schedule.next_time()) is not None and self.t >= nt - TIME_EPS:
                    self.event_time = nt
                    c.func(self)
                    c.schedule.fired(self.t)
            if self.stop_reason is not None:
                break
            if self.t >= self.stop_time - TIME_EPS:
                self.stop_reason = f"stop time {self.stop_time:g} s reached"
                break
            target = self.stop_time
            for _, c in timed:
                nt = c.schedule.next_time()
                if nt is not None and nt < target - TIME_EPS:
                    target = nt
            limit = (self.origin + target) - m.t
            dt = m.next_dt(limit=limit)
            if self.dt_fixed is not None:
                dt = min(self.dt_fixed, limit)
            self.last_step = m.step(dt)
            self.n_steps += 1
            self.steps_this_run += 1
            for _, c in stepped:
                if c.schedule.due_after_step(self):
                    c.func(self)
                    c.schedule.fired(self.t)
            if self.stop_reason is not None:
                break
        return self.stop_reason

    # ---- restart ---------------------------------------------------------------------------
    def checkpoint(self) -> dict[str, Any]:
        """The loop's own state as pure data; the model's is ``model.checkpoint()``."""
        out: dict[str, Any] = {"n_steps": self.n_steps, "origin": self.origin, "schedules": {},
                               "callbacks": {}}
        for name, c in self.callbacks.items():
            st = getattr(c.schedule, "state", None)
            if st is not None:
                out["schedules"][name] = st()
            ck = getattr(c.func, "checkpoint", None)
            if ck is not None:
                out["callbacks"][name] = ck()
        return out

    def restore(self, data: dict[str, Any]) -> None:
        """Put back what :meth:`checkpoint` returned, after the callbacks have been added."""
        self.n_steps = int(data["n_steps"])
        self.origin = float(data["origin"])
        for name, st in data.get("schedules", {}).items():
            if name in self.callbacks:
                self.callbacks[name].schedule.restore(st)
        for name, st in data.get("callbacks", {}).items():
            if name in self.callbacks:
                self.callbacks[name].func.restore(st)
