"""The cores shared among the solver tasks running at this moment in this process.

With the local threaded scheduler and ``--workers N`` a task alone on the machine (a study's shared
spin-up, which every other task waits for, or its last run) would leave cores idle on cores // N
threads. So a running task re-reads its share every 2 s of wall time (a Simulation callback) and
takes cores // (tasks running now). Results do not depend on the numba thread count (parcel work
is split into a fixed number of chunks; tests/test_particles_determinism.py), only the wall time.
"""
from __future__ import annotations

import os
import threading
from contextlib import contextmanager
from typing import Iterator

_lock = threading.Lock()
_state = {"running": 0, "sharing": False}


def share_now() -> int:
    """Numba threads for one running task now [1]."""
    return max(1, (os.cpu_count() or 1) // max(1, _state["running"]))


def apply() -> None:
    """Set the calling thread's numba threads (numba's count is per thread) to its share, when a
    local study turned sharing on."""
    if _state["sharing"]:
        import numba

        numba.set_num_threads(max(1, min(share_now(), numba.config.NUMBA_NUM_THREADS)))


@contextmanager
def sharing() -> Iterator[None]:
    _state["sharing"] = True
    try:
        yield
    finally:
        _state["sharing"] = False


@contextmanager
def running() -> Iterator[None]:
    """One solver task running in this thread: counted while it runs, its threads set."""
    with _lock:
        _state["running"] += 1
    apply()
    try:
        yield
    finally:
        with _lock:
            _state["running"] -= 1


def add_share(sim) -> None:
    from ..solver.simulation import WallTimeInterval

    if _state["sharing"]:
        sim.add_callback("core_share", lambda s: apply(), WallTimeInterval(2.0))
