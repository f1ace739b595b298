"""The machine's cores shared among the solver tasks running at this moment in this process.

With the local threaded scheduler and ``--workers N`` each task starts on cores // N numba
threads; a task alone on the machine (a study's shared spin-up, which every other task waits for,
or the last saltation run) would then leave cores idle. A running task re-reads its share every
few seconds of wall time (a Simulation callback) and takes cores // (tasks running now). Results
do not depend on the thread count (parcel work is split into a fixed number of chunks;
tests/test_particles_determinism.py), so the share moves the wall time only. Off (every task
keeps the count it was started with) unless the scheduler turned it on.
"""
from __future__ import annotations

import os
import threading
from contextlib import contextmanager
from typing import Iterator

_lock = threading.Lock()
_running = 0
_sharing = False

#: wall seconds between two reads of the share: short against a run, long against a step
PERIOD_S = 2.0


def share_now() -> int:
    """Numba threads for one running task now [1]."""
    return max(1, (os.cpu_count() or 1) // max(1, _running))


def apply() -> None:
    """Set the calling thread's numba threads to its share (numba's count is per thread)."""
    if not _sharing:
        return
    import numba

    numba.set_num_threads(max(1, min(share_now(), numba.config.NUMBA_NUM_THREADS)))


@contextmanager
def sharing() -> Iterator[None]:
    """Turn sharing on for the tasks run inside (one local study's execution)."""
    global _sharing
    _sharing = True
    try:
        yield
    finally:
        _sharing = False


@contextmanager
def running() -> Iterator[None]:
    """One solver task running in this thread: counted while it runs, its threads set."""
    global _running
    with _lock:
        _running += 1
    apply()
    try:
        yield
    finally:
        with _lock:
            _running -= 1


def add_share(sim) -> None:
    """A callback re-reading the task's share every ``PERIOD_S`` of wall time."""
    from ..solver.simulation import WallTimeInterval

    if _sharing:
        sim.add_callback("core_share", lambda s: apply(), WallTimeInterval(PERIOD_S))
