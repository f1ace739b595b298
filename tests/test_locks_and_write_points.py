"""The out dir's lock (workflow/lock.py) between real processes, and the write points
(saltstudy/faults.py): the test hook, atomic writes, the full-disk error."""
from __future__ import annotations

import errno
import json
import os
import platform
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from saltstudy import faults
from saltstudy.faults import DiskFull, write_atomic
from saltstudy.ncio import write_dataset
from saltstudy.workflow import lock as L
from saltstudy.workflow.status import out_dir_state

HOLD = ("import sys; from saltstudy.workflow.lock import hold_out_dir; "
        "h = hold_out_dir(sys.argv[1]); print('held', flush=True); sys.stdin.read()")


@pytest.fixture
def holder(tmp_path):
    """Another process holding ``tmp_path/out`` until its stdin closes."""
    p = subprocess.Popen([sys.executable, "-c", HOLD, str(tmp_path / "out")], stdin=subprocess.PIPE,
                         stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "held"
    yield p
    if p.poll() is None:
        p.kill()
    p.wait()


def test_a_held_out_dir_is_refused_naming_the_holder(holder, tmp_path):
    out = tmp_path / "out"
    with pytest.raises(L.Busy) as err:
        L.hold_out_dir(out)
    msg = str(err.value)
    assert f"is in use by saltstudy pid {holder.pid} on {platform.node()}, started " in msg
    assert msg.endswith(f"(`-c {out}`)")           # the holder's command line (python -c ...)
    assert out_dir_state(out).startswith(f"out dir: in use by saltstudy pid {holder.pid} ")
    with pytest.raises(L.Busy):                      # waiting, for at most 0.3 s
        L.hold_out_dir(out, wait=True, timeout=0.3)


def test_wait_takes_the_lock_when_the_holder_finishes(holder, tmp_path):
    said = []
    holder.stdin.close()          # the holder exits (its lock goes with it)
    with L.hold_out_dir(tmp_path / "out", wait=True, log=said.append) as lock:
        assert L.read_holder(lock.path)["pid"] == os.getpid()
    assert not (tmp_path / "out" / L.LOCK_NAME).exists()      # removed on release
    assert out_dir_state(tmp_path / "out") == "out dir: not in use"


def test_the_lock_of_a_killed_process_is_taken_over_with_a_message(holder, tmp_path):
    holder.send_signal(signal.SIGKILL)
    holder.wait()
    out = tmp_path / "out"
    assert L.read_holder(out / L.LOCK_NAME)["pid"] == holder.pid       # left behind
    assert "which is gone" in out_dir_state(out)
    said = []
    with L.hold_out_dir(out, log=said.append):
        pass
    assert len(said) == 1 and f"held by saltstudy pid {holder.pid} " in said[0]
    assert "which is gone" in said[0]


def test_a_process_holds_its_out_dir_once_more(tmp_path):
    with L.hold_out_dir(tmp_path) as a:
        with L.hold_out_dir(tmp_path) as b:
            assert a is b
        assert (tmp_path / L.LOCK_NAME).exists()
    assert not (tmp_path / L.LOCK_NAME).exists()


def test_a_record_from_another_host_counts_until_it_goes_stale(tmp_path):
    """Where flock is not shared between hosts, another host's fresh record is honoured."""
    path = tmp_path / L.LOCK_NAME
    path.write_text(json.dumps({"pid": 1, "host": "elsewhere", "started": time.time(),
                                "command": "saltstudy run-all"}))
    with pytest.raises(L.Busy, match="pid 1 on elsewhere"):
        L.hold_out_dir(tmp_path)
    old = time.time() - L.STALE_AFTER - 1
    os.utime(path, (old, old))
    said = []
    with L.hold_out_dir(tmp_path, log=said.append):
        assert "which is gone" in said[0]


# ------------------------------------------------------------------------------------------
def test_the_hook_fails_the_k_th_matching_write(tmp_path, monkeypatch):
    monkeypatch.setenv(faults.FAULT_ENV, "enospc *.json:write 2")
    write_atomic(tmp_path / "a.json", lambda p: p.write_text("1"))
    write_atomic(tmp_path / "b.txt", lambda p: p.write_text("1"))     # does not match
    with pytest.raises(DiskFull) as err:
        write_atomic(tmp_path / "c.json", lambda p: p.write_text("1"), needed=2000)
    assert err.value.errno == errno.ENOSPC
    assert f"no space left on the device of {tmp_path}: writing c.json needs about 2.0 kB" in str(err.value)
    write_atomic(tmp_path / "d.json", lambda p: p.write_text("1"))     # only the 2nd
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json", "b.txt", "d.json"]


def test_the_hook_traces_the_points_a_run_reaches(tmp_path, monkeypatch):
    trace = tmp_path / "trace.txt"
    monkeypatch.setenv(faults.FAULT_ENV, f"trace {trace}")
    ds = xr.Dataset({"u": (("x",), np.zeros(3), {"units": "m s-1", "long_name": "u"})})
    write_dataset(ds, tmp_path / "k" / "samples.nc")
    names = [line.split(" ", 2)[2] for line in trace.read_text().splitlines()]
    assert names == ["samples.nc:write", "samples.nc:tmp", "samples.nc:done"]


def test_the_hook_kills_the_process_at_its_point(tmp_path):
    code = ("from saltstudy.faults import write_atomic; from pathlib import Path; "
            "[write_atomic(Path(r'%s') / f'{i}.json', lambda p: p.write_text('x')) for i in range(3)]"
            % tmp_path)
    r = subprocess.run([sys.executable, "-c", code], env={**os.environ,
                       faults.FAULT_ENV: "kill *.json:tmp 2"})
    assert r.returncode == -signal.SIGKILL
    # the first file whole, the second's temporary written and not renamed, no third
    assert sorted(p.name for p in tmp_path.iterdir()) == ["0.json", f"1.json.{_pid_of(tmp_path)}.tmp"]


def _pid_of(d: Path) -> str:
    (tmp,) = d.glob("*.tmp")
    return tmp.name.split(".")[-2]


def test_a_netcdf_write_on_a_full_disk_names_the_file_and_leaves_no_temporary(tmp_path, monkeypatch):
    """netCDF reports a full disk as 'NetCDF: HDF error': the free space decides."""
    import saltstudy.faults as F

    ds = xr.Dataset({"u": (("x",), np.zeros(1000), {"units": "m s-1", "long_name": "u"})})
    monkeypatch.setattr(F, "_free", lambda d: 100)

    def hdf_error(*a, **k):
        raise RuntimeError("NetCDF: HDF error")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", hdf_error)
    with pytest.raises(DiskFull) as err:
        write_dataset(ds, tmp_path / "key" / "spinup.nc")
    assert "writing spinup.nc needs about 8.0 kB, 100 B free" in str(err.value)
    assert list((tmp_path / "key").iterdir()) == []
    monkeypatch.setattr(F, "_free", lambda d: 10 ** 9)         # not full: the error as it was
    with pytest.raises(RuntimeError, match="HDF error"):
        write_dataset(ds, tmp_path / "key" / "spinup.nc")


# ------------------------------------------------------------------------------------------
def _fake_build(fail_after: int | None = None):
    """A build_report stand-in: reads the summary it replaces, writes two figures, a summary and
    index.html (raising after ``fail_after`` files)."""
    def build(study, runs, report_dir, meta):
        report_dir = Path(report_dir)
        old = json.loads((report_dir / "summary.json").read_text()) \
            if (report_dir / "summary.json").is_file() else {}
        for i, name in enumerate(("fig01.png", "fig02.png", "summary.json", "index.html")):
            if fail_after is not None and i == fail_after:
                raise RuntimeError("stopped midway")
            text = json.dumps({"build": meta["n"], "previous": old.get("build")}) \
                if name == "summary.json" else f"{name} of build {meta['n']}"
            (report_dir / name).write_text(text)
        return report_dir / "index.html"
    return build


def test_a_report_stopped_midway_leaves_the_old_one_whole(tmp_path):
    from saltstudy.workflow.tasks import build_report_staged

    rep = tmp_path / "reports" / "smoke"
    rep.mkdir(parents=True)
    (rep / "FINDINGS.md").write_text("by hand")
    build_report_staged(_fake_build(), "smoke", {}, rep, {"n": 1})
    assert (rep / "fig01.png").read_text() == "fig01.png of build 1"
    with pytest.raises(RuntimeError, match="midway"):
        build_report_staged(_fake_build(fail_after=1), "smoke", {}, rep, {"n": 2})
    assert sorted(p.name for p in rep.iterdir()) == ["FINDINGS.md", "fig01.png", "fig02.png",
                                                      "index.html", "summary.json"]
    assert all("build 1" in (rep / n).read_text() for n in ("fig01.png", "fig02.png", "index.html"))
    assert list(rep.parent.glob(".smoke.*.tmp")) == []
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (rep.parent / f".smoke.{dead.pid}.tmp").mkdir()          # a stage a killed build left
    build_report_staged(_fake_build(), "smoke", {}, rep, {"n": 3})
    assert json.loads((rep / "summary.json").read_text()) == {"build": 3, "previous": 1}
    assert (rep / "FINDINGS.md").read_text() == "by hand"
    assert list(rep.parent.glob(".smoke.*.tmp")) == []
