"""The live progress display: ETA of a resumed run and files left behind by a killed process."""
import json
import time

from saltstudy.workflow.progress import STALE_AFTER, ProgressDisplay, ProgressFile, TaskRef


def _display(tmp_path):
    return ProgressDisplay([TaskRef("saltation case02", tmp_path)], quiet=True)


def _writer_stopped(task_dir, seconds_ago=STALE_AFTER + 60.0):
    """Date the task's progress file back, as if its writer had died that long ago."""
    p = task_dir / "progress.json"
    data = json.loads(p.read_text())
    data["updated"] = time.time() - seconds_ago
    p.write_text(json.dumps(data))


def _running_task(out_dir, task, key, t, target):
    """A task directory as a live process leaves it: task.json running, progress at t."""
    from saltstudy.workflow.paths import task_dir
    from saltstudy.workflow.tasks import write_task_json

    d = task_dir(out_dir, task, key)
    d.mkdir(parents=True)
    write_task_json(d, task=task, state="running", started=time.time())
    ProgressFile(d, task, "case", task, min_interval=0.0)(t, target)
    return d


def test_resumed_run_eta_uses_the_rate_since_resume(tmp_path, monkeypatch):
    clock = [1000.0]
    monkeypatch.setattr(time, "time", lambda: clock[0])
    prog = ProgressFile(tmp_path, "saltation", "case02", "saltation", min_interval=0.0)
    prog(60.0, 100.0)            # resumed from a checkpoint at 60 s of 100 s
    clock[0] += 100.0
    prog(70.0, 100.0)            # 10 simulated s in 100 wall s: 30 s left take 300 s
    row = _display(tmp_path).rows()[0]
    assert "( 70.0 %)" in row
    assert "ETA 5m00s" in row, row
    # `saltstudy status` says the same of a running task
    from saltstudy.workflow.status import _running
    state, detail = _running(tmp_path, {"started": 900.0})
    assert state == "running" and "t = 70 / 100 s, ETA 5m00s" in detail, detail


def test_file_of_a_killed_process_is_not_shown_running(tmp_path):
    prog = ProgressFile(tmp_path, "saltation", "case02", "saltation", min_interval=0.0)
    prog(10.0, 100.0)
    assert len(_display(tmp_path).rows()) == 1
    _writer_stopped(tmp_path, STALE_AFTER + 1.0)
    assert _display(tmp_path).rows() == []


def test_status_tells_a_live_task_from_one_whose_process_died(tmp_path):
    from saltstudy.workflow.status import _state

    d = _running_task(tmp_path, "spinup", "k" * 20, 12.0, 90.0)
    state, detail = _state(tmp_path, "spinup", "k" * 20, None)
    assert state == "running" and "t = 12 / 90 s" in detail
    _writer_stopped(d)
    state, detail = _state(tmp_path, "spinup", "k" * 20, None)
    assert state == "stopped" and "died" in detail


def test_status_of_a_checkpointed_task_running_or_killed(tmp_path):
    from saltstudy.workflow.status import _state

    d = _running_task(tmp_path, "saltation", "s" * 20, 30.0, 42.0)
    (d / "checkpoint.npz").write_bytes(b"")          # a running task checkpoints as it goes
    assert _state(tmp_path, "saltation", "s" * 20, None)[0] == "running"
    _writer_stopped(d)
    state, detail = _state(tmp_path, "saltation", "s" * 20, None)
    assert state == "partial" and "died" in detail   # resumable from its checkpoint


def test_a_killed_writer_on_this_host_is_seen_at_once(tmp_path):
    """The process that wrote a progress file is asked directly when it ran on this host, so a
    killed run-all's task stops showing as running without waiting STALE_AFTER."""
    import subprocess
    import sys

    from saltstudy.workflow.status import _state

    d = _running_task(tmp_path, "saltation", "g" * 20, 5.0, 42.0)
    assert _state(tmp_path, "saltation", "g" * 20, None)[0] == "running"   # this process: alive
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    p = d / "progress.json"
    data = json.loads(p.read_text())
    data["pid"] = dead.pid
    p.write_text(json.dumps(data))
    state, detail = _state(tmp_path, "saltation", "g" * 20, None)
    assert state == "stopped" and f"({dead.pid}) is gone" in detail, detail
    assert ProgressDisplay([TaskRef("saltation case02", d)], quiet=True).rows() == []
    data["host"] = "another-host"          # a cluster worker's file: only the clock can tell
    p.write_text(json.dumps(data))
    assert _state(tmp_path, "saltation", "g" * 20, None)[0] == "running"
    # a progress file that does not name its process: task.json's host and pid are asked
    del data["host"], data["pid"]
    p.write_text(json.dumps(data))
    tj = json.loads((d / "task.json").read_text())
    (d / "task.json").write_text(json.dumps({**tj, "pid": dead.pid}))
    state, detail = _state(tmp_path, "saltation", "g" * 20, None)
    assert state == "stopped" and f"({dead.pid}) is gone" in detail, detail
