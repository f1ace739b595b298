"""`saltstudy run-all --scheduler ADDRESS` on a real dask.distributed cluster on loopback.

The cluster is started as docs/USAGE.md starts one by hand (tests/cluster_helpers.py: a scheduler
and two worker processes of one thread each, on 127.0.0.1), all stopped in a ``finally``. The smoke study (cut to cases 2 and 9, which
share a spin-up, at half the simulated time, without the report, to keep the default test run
short) runs through them into one cache and through the default local scheduler into another;
the archives must be the same files with the same numbers.

Bit for bit, because both runs load the numba kernels from the same on-disk cache (the local run
warms it in a child process, the distributed one on each worker host: workflow/warmup.py and
graph.warm_workers), and use the same numba thread count (a worker's one dask thread runs one
task at a time, whose kernels use the machine's cores, as locally). Kernels compiled in the
running process would differ at round-off and give another realization.
"""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from cluster_helpers import start_cluster, stop
from saltstudy.config import project_root

SALTSTUDY = str(Path(sys.executable).parent / "saltstudy")
RUN_TIMEOUT_S = 900          # each run-all: a bound for a cold numba compile on a slow machine


@pytest.fixture
def home(tmp_path, monkeypatch):
    h = tmp_path / "home"
    for d in ("cases", "workflows"):
        shutil.copytree(project_root() / d, h / d)
    f = h / "workflows" / "fidelities" / "smoke.toml"
    text = f.read_text()
    for old, new in (("saltation_duration = 2.0", "saltation_duration = 1.0"),
                     ("t_min = 1.0", "t_min = 0.5"), ("t_max = 3.0", "t_max = 1.5"),
                     ("window = 1.0", "window = 0.5"), ("start = 1.0", "start = 0.4"),
                     ("interval = 0.5", "interval = 0.3")):
        assert old in text, old
        text = text.replace(old, new)
    f.write_text(text)
    s = h / "workflows" / "smoke.toml"
    text = s.read_text()
    assert "cases = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]" in text
    s.write_text(text.replace("cases = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]", "cases = [2, 9]")
                 + "report = false\n")
    monkeypatch.setenv("SALTSTUDY_HOME", str(h))
    monkeypatch.delenv("SALTSTUDY_OUT", raising=False)
    return h


def _run_all(out: Path, *extra: str) -> str:
    r = subprocess.run([SALTSTUDY, "run-all", "--study", "smoke", "--quiet", "--out", str(out), *extra],
                       capture_output=True, text=True, timeout=RUN_TIMEOUT_S)
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout


def _archives(out: Path) -> dict[str, Path]:
    return {f"{p.parent.parent.name}/{p.parent.name}/{p.name}": p
            for task, name in (("spinup", "spinup.nc"), ("saltation", "samples.nc"),
                               ("analysis", "analysis.nc"))
            for p in out.glob(f"{task}/*/{name}")}


def test_run_all_on_a_loopback_cluster_writes_the_local_archives(home, tmp_path):
    local, dist = tmp_path / "local", tmp_path / "dist"
    _run_all(local)                                   # the default (threaded, local) scheduler
    procs: list[subprocess.Popen] = []
    try:
        address, worker_pids = start_cluster(tmp_path, procs)
        out = _run_all(dist, "--scheduler", address)
        assert "study smoke:" in out and "report: none (the study sets report = false)" in out
        # every solver task ran in one of the two worker processes, none in the client
        pids = {json.loads(p.read_text())["pid"] for p in dist.glob("*/*/task.json")}
        assert pids and pids <= set(worker_pids), (pids, worker_pids)
    finally:
        stop(procs[::-1])
    assert all(p.poll() is not None for p in procs)

    a, b = _archives(local), _archives(dist)
    assert sorted(a) == sorted(b)                      # same cache keys: same files
    assert [k.split("/")[0] for k in sorted(a)].count("spinup") == 1     # shared, run once
    assert len(a) == 5
    for name in a:
        with xr.open_dataset(a[name]) as x, xr.open_dataset(b[name]) as y:
            assert set(x.variables) == set(y.variables), name
            for v in x.variables:
                assert np.array_equal(x[v].values, y[v].values, equal_nan=True), (name, v)
