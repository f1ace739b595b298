"""The cores shared among running solver tasks (workflow/cores.py): a task takes
cores // (tasks running now), in its own thread, and only while a local study turns sharing on."""
from __future__ import annotations

import os
import threading

import numba
import pytest

from saltstudy.workflow import cores


def _threads_seen_in_a_task(started: threading.Event, release: threading.Event, seen: list):
    with cores.running():
        started.set()
        release.wait(10)
        cores.apply()
        seen.append(numba.get_num_threads())


@pytest.mark.skipif((os.cpu_count() or 1) < 2 or numba.config.NUMBA_NUM_THREADS < 2,
                    reason="needs two cores")
def test_a_lone_task_takes_every_core_and_two_tasks_half_each():
    n = min(os.cpu_count(), numba.config.NUMBA_NUM_THREADS)
    with cores.sharing():
        with cores.running():
            assert cores.share_now() == os.cpu_count()
            assert numba.get_num_threads() == n            # set on entry, in this thread
            started, release, seen = threading.Event(), threading.Event(), []
            other = threading.Thread(target=_threads_seen_in_a_task, args=(started, release, seen))
            other.start()
            started.wait(10)
            assert cores.share_now() == os.cpu_count() // 2
            cores.apply()
            assert numba.get_num_threads() == max(1, n // 2)
            release.set()
            other.join(10)
            assert seen == [max(1, n // 2)]
            cores.apply()                                   # the other task has ended
            assert numba.get_num_threads() == n


def test_off_outside_a_study_the_thread_count_is_left_alone():
    numba.set_num_threads(1)
    with cores.running():
        cores.apply()
        assert numba.get_num_threads() == 1
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
