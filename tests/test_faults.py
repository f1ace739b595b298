"""Faults: a run killed anywhere, a full disk, two runs on one out dir, a lost dask worker.

The default tests use the smoke fidelity cut in time, case 9 alone, checkpointing every 0.2 s of
wall time (tests/fault_campaign.py), against one uninterrupted run of it (the module's
``reference``); the campaign over the whole smoke study is ``slow`` (docs/USAGE.md, "Faults").
Every command runs in its own process, as a user's does: the kernels load from the numba cache
that the first run's warm-up filled (workflow/warmup.py), so every run is the same realization
and "equal" means bit for bit.
"""
from __future__ import annotations

import json
import os
import platform
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

import fault_campaign as fc
from cluster_helpers import start_cluster, stop
from saltstudy.cli import app
from saltstudy.ncio import open_dataset
from saltstudy.workflow.lock import LOCK_NAME, read_holder

RUN_ALL = ["run-all", "--study", "smoke", "--quiet"]


@pytest.fixture(scope="module")
def home(tmp_path_factory):
    return fc.make_home(tmp_path_factory.mktemp("home"), cases=[9], cut=True,
                        checkpoint_interval=0.2, report=False)


@pytest.fixture(scope="module")
def reference(home, tmp_path_factory):
    out = tmp_path_factory.mktemp("reference")
    r = fc.run([*RUN_ALL, "--out", str(out)], fc.env_for(home))
    assert r.returncode == 0, r.stdout + r.stderr
    assert len(fc.archives(out)) == 3            # spin-up, saltation, analysis
    return out


def _status(home: Path, out: Path, reference: Path, live_pid: int | None) -> list[str]:
    """Where status, read from this process, is not the truth (fault_campaign.status_problems)."""
    rows, lock_line = fc.status_here(home, out)
    return fc.status_problems(rows, lock_line, out, reference, live_pid)


def _with_spinup(reference: Path, out: Path) -> Path:
    """An out dir holding the reference's spin-up only (a run then computes the saltation and
    the analysis)."""
    (src,) = reference.glob("spinup/*")
    shutil.copytree(src, out / "spinup" / src.name)
    return out


# ------------------------------------------------------------------------------------------
def test_killed_at_write_points_then_rerun_equals_the_uninterrupted_run(home, reference, tmp_path,
                                                                       monkeypatch):
    """One run stopped three times, each time at another write point of its rerun, then rerun to
    its end, in an out dir that holds wrong archives where its saltation and analysis will write
    (a truncated samples.nc; as analysis.nc, the spin-up's archive: ours, complete, of another key
    and kind): status tells the truth at each stop, the wrong archives are never trusted, and the
    archives equal the uninterrupted run's."""
    out = tmp_path / "out"
    ref = fc.archives(reference)
    (spinup_rel,), (samples_rel,), (analysis_rel,) = (
        [n for n in ref if n.startswith(task)] for task in ("spinup/", "saltation/", "analysis/"))
    for rel in (samples_rel, analysis_rel):
        (out / rel).parent.mkdir(parents=True)
    data = ref[samples_rel].read_bytes()
    (out / samples_rel).write_bytes(data[: len(data) // 2])
    shutil.copy(ref[spinup_rel], out / analysis_rel)
    stages = [  # (hook, what the process is doing there)
        ("stop spinup.nc:tmp 1", "the spin-up's archive written, not renamed, its checkpoint kept"),
        ("enospc samples.nc:write 1", "a full disk at the samples archive"),
        ("kill analysis.nc:done 1", "the analysis archive renamed into place"),
    ]
    for hook, what in stages:
        p = fc.launch([*RUN_ALL, "--out", str(out)], fc.env_for(home, hook), tmp_path / "log")
        if hook.startswith("stop"):
            assert fc.wait_frozen(p), (tmp_path / "log").read_text()
            assert _status(home, out, reference, p.pid) == [], what
            fc.kill(p)
        p.wait(timeout=fc.RUN_TIMEOUT_S)
        log = (tmp_path / "log").read_text()
        if hook.startswith("enospc"):
            assert p.returncode == 1, log
            assert "no space left on the device of" in log and "samples.nc needs about" in log, log
            assert "[lock] taking over" in log          # the earlier run was killed holding it
        else:
            assert p.returncode == -signal.SIGKILL, (what, log)
        assert _status(home, out, reference, None) == [], what
    r = fc.run([*RUN_ALL, "--out", str(out)], fc.env_for(home))
    assert r.returncode == 0, r.stdout + r.stderr
    assert fc.differences(reference, out) == []
    assert fc.leftovers(out) == []
    assert open_dataset(out / samples_rel).attrs["resumed_from_t"] > 0   # after the full disk
    monkeypatch.setenv("SALTSTUDY_HOME", str(home))
    res = CliRunner().invoke(app, ["status", "--study", "smoke", "--out", str(out)])
    rows, lock_line = fc.parse_status(res.output)
    assert res.exit_code == 0 and len(rows) == 3, res.output
    assert {r[2] for r in rows} == {"done"} and lock_line == "out dir: not in use", res.output


# ------------------------------------------------------------------------------------------
def test_a_second_run_on_one_out_dir_refuses_at_once_or_waits(home, reference, tmp_path,
                                                                monkeypatch):
    """While one run-all works (held at its samples archive, frozen), run-all, run and figures
    on its out dir (from the test's process) refuse at once naming it (exit 3), status names it,
    and run-all --wait (a third process) waits,
    then finds every task done: no task is computed twice, the archives are the first run's."""
    out = _with_spinup(reference, tmp_path / "out")
    a = fc.launch([*RUN_ALL, "--out", str(out)], fc.env_for(home, "stop samples.nc:write 1"),
                  tmp_path / "a.log")
    try:
        assert fc.wait_frozen(a), (tmp_path / "a.log").read_text()
        holder = read_holder(out / LOCK_NAME)
        assert holder["pid"] == a.pid and holder["host"] == platform.node()
        waiter = fc.launch([*RUN_ALL, "--wait", "--out", str(out)], fc.env_for(home),
                           tmp_path / "w.log")
        started = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(holder["started"]))
        named = (f"is in use by saltstudy pid {a.pid} on {platform.node()}, started {started} "
                 f"(`saltstudy run-all --study smoke --quiet --out {out}`)")
        # run-all, `run` (one case) and `figures` from this process, another than the holder
        monkeypatch.setenv("SALTSTUDY_HOME", str(home))
        for args in (RUN_ALL, ["run", "9", "--quiet"],
                     ["figures", "--study", "smoke", "--report-dir", str(tmp_path / "report")]):
            res = CliRunner().invoke(app, [*args, "--out", str(out)])
            assert res.exit_code == 3 and named in res.output, (args, res.output)
            assert "--wait" in res.output and "[start]" not in res.output, (args, res.output)
        assert not (tmp_path / "report").exists()
        assert _status(home, out, reference, a.pid) == []
        deadline = time.time() + 300
        while "[wait]" not in (tmp_path / "w.log").read_text():
            assert waiter.poll() is None and time.time() < deadline, (tmp_path / "w.log").read_text()
            time.sleep(0.1)
        assert waiter.poll() is None
        os.killpg(a.pid, signal.SIGCONT)
        assert a.wait(timeout=fc.RUN_TIMEOUT_S) == 0, (tmp_path / "a.log").read_text()
        assert waiter.wait(timeout=fc.RUN_TIMEOUT_S) == 0, (tmp_path / "w.log").read_text()
    finally:
        if a.poll() is None:
            fc.kill(a)
    w = (tmp_path / "w.log").read_text()
    assert f"in use by saltstudy pid {a.pid}" in w and "[start]" not in w
    assert "all runs cached: no solver work to do" in w
    # the spin-up's record is the reference's own: the saltation and analysis are the first run's
    pids = {json.loads(p.read_text())["pid"] for t in ("saltation", "analysis")
            for p in out.glob(f"{t}/*/task.json")}
    assert pids == {a.pid}
    assert fc.differences(reference, out) == []
    assert fc.leftovers(out) == []


# ------------------------------------------------------------------------------------------
def test_a_worker_lost_mid_saltation_is_resumed_on_another(home, reference, tmp_path):
    """On a loopback dask.distributed cluster, the worker running the saltation is killed after
    its second checkpoint: the scheduler gives the task to the other worker, which resumes from
    that checkpoint; the archives equal the local run's."""
    out = _with_spinup(reference, tmp_path / "out")
    procs: list[subprocess.Popen] = []
    try:
        # both workers freeze at their second checkpoint: the first to get there is the victim;
        # the other, which resumes its task, is let go on if it freezes too
        address, workers = start_cluster(tmp_path, procs,
                                         worker_env=fc.env_for(home, "stop checkpoint.npz:done 2"))
        run = fc.launch([*RUN_ALL, "--out", str(out), "--scheduler", address], fc.env_for(home),
                        tmp_path / "run.log")
        procs.append(run)
        deadline = time.time() + fc.RUN_TIMEOUT_S
        while not any(fc.frozen(w) for w in workers):
            assert run.poll() is None and time.time() < deadline, (tmp_path / "run.log").read_text()
            time.sleep(0.05)
        (victim,) = [w for w in workers if fc.frozen(w)]
        (ckpt,) = out.glob("saltation/*/checkpoint.npz")
        os.kill(victim, signal.SIGKILL)
        while run.poll() is None:
            for w in workers:
                if w != victim and fc.frozen(w):
                    os.kill(w, signal.SIGCONT)
            time.sleep(0.05)
            assert time.time() < deadline
        assert run.returncode == 0, (tmp_path / "run.log").read_text()
    finally:
        stop(procs[::-1])
    (samples,) = out.glob("saltation/*/samples.nc")
    assert open_dataset(samples).attrs["resumed_from_t"] > 0
    record = json.loads((samples.parent / "task.json").read_text())
    assert record["pid"] in set(workers) - {victim} and record["state"] == "done"
    assert fc.differences(reference, out) == []
    assert fc.leftovers(out) == []


# ------------------------------------------------------------------------------------------
def _mount_tmpfs(path: Path, size_kb: int) -> bool:
    path.mkdir(parents=True, exist_ok=True)
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size_kb}k", "tmpfs", str(path)],
                       capture_output=True)
    return r.returncode == 0


@pytest.mark.slow
def test_a_full_disk_stops_naming_the_file_and_resumes_once_freed(home, reference, tmp_path):
    """The out dir on a small tmpfs that the saltation run fills: the run stops (exit 1) naming
    the file and the space, keeps the spin-up, leaves no temporary file; once the disk is
    grown, the rerun completes with the uninterrupted run's archives."""
    disk = tmp_path / "disk"
    ref_sizes = {n: p.stat().st_size for n, p in fc.archives(reference).items()}
    spin = next(s for n, s in ref_sizes.items() if n.startswith("spinup/"))
    samples = next(s for n, s in ref_sizes.items() if n.startswith("saltation/"))
    if not _mount_tmpfs(disk, (spin + samples // 2) // 1024):
        pytest.skip("mounting a tmpfs needs root (the injected full disk of the kill test runs "
                    "everywhere)")
    try:
        out = _with_spinup(reference, disk / "out")
        r = fc.run([*RUN_ALL, "--out", str(out)], fc.env_for(home))
        assert r.returncode == 1, r.stdout + r.stderr
        assert f"no space left on the device of {out}/saltation/" in r.stderr, r.stderr
        assert "needs about" in r.stderr and "free" in r.stderr
        assert "Traceback" not in r.stderr and "no solver work was needed" not in r.stdout
        rows, _ = fc.status_here(home, out)
        assert [row[2] for row in rows][::2] == ["done", "missing"], rows
        assert rows[1][2] in ("failed", "partial"), rows      # partial: beside a checkpoint
        assert "DiskFull: no space left on the device of" in rows[1][4], rows
        assert not list(out.rglob("*.tmp")) and not list(out.rglob("*.lock"))
        assert fc.differences(reference, out) == [f"missing {n}" for n in sorted(ref_sizes)
                                                 if not n.startswith("spinup/")]
        subprocess.run(["mount", "-o", "remount,size=64m", str(disk)], check=True)
        r = fc.run([*RUN_ALL, "--out", str(out)], fc.env_for(home))
        assert r.returncode == 0, r.stdout + r.stderr
        assert fc.differences(reference, out) == []
        assert fc.leftovers(out) == []
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True)


# ------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_kill_campaign_over_the_smoke_study(tmp_path):
    """The smoke study (ten cases, report) stopped at 34 instants over its whole run, each from an
    empty out dir (fault_campaign.campaign): 26 write points that the traced uninterrupted run
    reached, 8 wall times. ``SALTSTUDY_CAMPAIGN_CASES`` (e.g. ``9``) cuts the study to those
    cases at the default tests' cut fidelity and checkpoint interval (with the report), a campaign of the same instants
    that a busy machine finishes in an hour. The result goes to ``$SALTSTUDY_CAMPAIGN_LOG``
    (default: the test's tmp dir) as JSON; docs/USAGE.md, "Faults", records it."""
    dest = Path(os.environ.get("SALTSTUDY_CAMPAIGN_LOG", tmp_path / "campaign.json"))
    cases = os.environ.get("SALTSTUDY_CAMPAIGN_CASES")
    home = (fc.make_home(tmp_path / "home", cases=[int(c) for c in cases.split(",")], cut=True,
                         checkpoint_interval=0.2) if cases else fc.make_home(tmp_path / "home"))
    summary = fc.campaign(home, tmp_path, n_points=26, n_wall=8, log=dest)
    failed = [e for e in summary["results"] if e["problems"]]
    assert not failed, json.dumps(failed, indent=1)
    assert summary["stopped"] >= 30, {k: v for k, v in summary.items() if k != "results"}
