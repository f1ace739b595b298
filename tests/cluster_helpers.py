"""A dask.distributed cluster on loopback, started as docs/USAGE.md starts one by hand (not a test
module): a scheduler (`dask scheduler`) and worker processes of one thread each
(`dask worker --nthreads 1 --no-nanny`, so a worker's pid is the process that runs its tasks), all
on 127.0.0.1 with ports the system picks, each in its own session so that it and any child stop
together."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

PY = sys.executable
START_TIMEOUT_S = 90         # scheduler up and the workers registered


def start(args: list[str], log: Path, env: dict | None = None) -> subprocess.Popen:
    """A process in its own session, its output in ``log``."""
    fh = open(log, "wb")
    try:
        return subprocess.Popen(args, stdout=fh, stderr=subprocess.STDOUT, start_new_session=True,
                                env=env)
    finally:
        fh.close()


def stop(procs: list[subprocess.Popen]) -> None:
    """SIGTERM each process group, SIGKILL what is left after 15 s."""
    for p in procs:
        if p.poll() is None:
            try:
                os.killpg(p.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
    deadline = time.time() + 15
    for p in procs:
        try:
            p.wait(timeout=max(0.1, deadline - time.time()))
        except subprocess.TimeoutExpired:
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            p.wait(timeout=10)


def start_cluster(tmp: Path, procs: list[subprocess.Popen], n_workers: int = 2,
                  worker_env: dict | None = None) -> tuple[str, list[int]]:
    """Scheduler + ``n_workers`` 1-thread worker processes on loopback (with ``worker_env``, else
    this process's environment); returns (address, worker pids). Every process started is
    appended to ``procs`` (stop them with :func:`stop`)."""
    from distributed import Client

    sched_file = tmp / "scheduler.json"
    procs.append(start([PY, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                        "--port", "0", "--no-dashboard", "--scheduler-file", str(sched_file)],
                       tmp / "scheduler.log"))
    deadline = time.time() + START_TIMEOUT_S
    while not sched_file.is_file():
        assert procs[0].poll() is None, (tmp / "scheduler.log").read_text()
        assert time.time() < deadline, "the scheduler did not start"
        time.sleep(0.2)
    time.sleep(0.2)   # the file is written whole, but give a slow machine a moment
    address = json.loads(sched_file.read_text())["address"]
    assert address.startswith("tcp://127.0.0.1:")
    pids = []
    for i in range(1, n_workers + 1):
        p = start([PY, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                   "--no-nanny", "--host", "127.0.0.1", "--no-dashboard",
                   "--local-directory", str(tmp / f"worker{i}")], tmp / f"worker{i}.log",
                  env=worker_env)
        procs.append(p)
        pids.append(p.pid)
    with Client(address, timeout=START_TIMEOUT_S) as client:
        client.wait_for_workers(n_workers, timeout=START_TIMEOUT_S)
        assert sorted(client.nthreads().values()) == [1] * n_workers
    return address, pids
