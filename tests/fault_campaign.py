"""Stop saltstudy commands at chosen instants, rerun them, and check what they leave (not a test
module: tests/test_faults.py uses it).

An instant is a write point of the package (saltstudy/faults.py: ``SALTSTUDY_FAULT`` freezes or
kills the process at the k-th call of a named point) or a wall time. After each stop the checks
are those of docs/USAGE.md, "Faults": ``saltstudy status`` tells the truth (a task is "done"
exactly when its archive is complete, and then that archive is the uninterrupted run's, bit for
bit; "running" only while its process lives; "partial" only beside a checkpoint; the out dir's
holder named while it lives), the rerun completes, its archives equal the uninterrupted run's bit
for bit, and nothing temporary is left (no ``*.tmp``, lock, checkpoint or report stage).
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import xarray as xr

from saltstudy.config import project_root
from saltstudy.faults import FAULT_ENV
from saltstudy.ncio import is_complete
from saltstudy.workflow.paths import output_path, task_dir

SALTSTUDY = str(Path(sys.executable).parent / "saltstudy")
RUN_TIMEOUT_S = 1800        # a command: a bound for a cold numba compile on a busy machine

#: the smoke fidelity at half its simulated times (the distributed test's cut, the same kernels)
CUT = (("saltation_duration = 2.0", "saltation_duration = 1.0"), ("t_min = 1.0", "t_min = 0.5"),
       ("t_max = 3.0", "t_max = 1.5"), ("window = 1.0", "window = 0.5"),
       ("start = 1.0", "start = 0.4"), ("interval = 0.5", "interval = 0.3"))
ALL_CASES = "cases = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]"


def make_home(root: Path, cases: list[int] | None = None, cut: bool = False,
              checkpoint_interval: float | None = None, report: bool = True) -> Path:
    """A project home (``SALTSTUDY_HOME``) with the package's cases and workflows, its smoke study
    cut to ``cases``, its smoke fidelity cut in time (``cut``) and checkpointing every
    ``checkpoint_interval`` s of wall time (a checkpoint's time changes no cache key)."""
    h = Path(root)
    for d in ("cases", "workflows"):
        shutil.copytree(project_root() / d, h / d)
    f = h / "workflows" / "fidelities" / "smoke.toml"
    text = f.read_text()
    for old, new in (CUT if cut else ()):
        assert old in text, old
        text = text.replace(old, new)
    if checkpoint_interval is not None:
        assert "checkpoint_interval_wall = 5.0" in text
        text = text.replace("checkpoint_interval_wall = 5.0",
                            f"checkpoint_interval_wall = {checkpoint_interval}")
    f.write_text(text)
    s = h / "workflows" / "smoke.toml"
    text = s.read_text()
    assert ALL_CASES in text
    if cases is not None:
        text = text.replace(ALL_CASES, f"cases = {list(cases)}")
    s.write_text(text + ("" if report else "report = false\n"))
    return h


def env_for(home: Path, fault: str | None = None) -> dict[str, str]:
    """The environment of a command on ``home`` (with the hook ``fault``), its numba kernels on
    one thread: a test runs several processes at once (a frozen holder and a waiter, two workers)
    on a machine of CI's two cores, and numba's parallel regions stall when threads outnumber
    cores (the cut case 9 under a load of 15: 51 s of CPU on two threads, 5 s on one;
    ``/usr/bin/time saltstudy run-all --study smoke`` with ``NUMBA_NUM_THREADS`` 2 and 1). Every
    run of a test has it, so they remain one realization."""
    env = {k: v for k, v in os.environ.items() if k not in ("SALTSTUDY_OUT", FAULT_ENV)}
    env["SALTSTUDY_HOME"] = str(home)
    env["NUMBA_NUM_THREADS"] = "1"
    if fault:
        env[FAULT_ENV] = fault
    return env


def run(args: list[str], env: dict[str, str], timeout: float = RUN_TIMEOUT_S) -> subprocess.CompletedProcess:
    """A saltstudy command to its end."""
    return subprocess.run([SALTSTUDY, *args], env=env, capture_output=True, text=True, timeout=timeout)


def launch(args: list[str], env: dict[str, str], log: Path) -> subprocess.Popen:
    """A saltstudy command in its own session (so it and any child stop together), output to ``log``."""
    fh = open(log, "wb")
    try:
        return subprocess.Popen([SALTSTUDY, *args], env=env, stdout=fh, stderr=subprocess.STDOUT,
                                start_new_session=True)
    finally:
        fh.close()


def frozen(pid: int) -> bool:
    """True if process ``pid`` is stopped (SIGSTOP)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] in ("T", "t")


def wait_frozen(p: subprocess.Popen, timeout: float = RUN_TIMEOUT_S) -> bool:
    """Wait until ``p`` stops itself (True) or exits (False)."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        if p.poll() is not None:
            return False
        if frozen(p.pid):
            return True
        time.sleep(0.05)
    raise TimeoutError(f"pid {p.pid} neither stopped nor exited in {timeout} s")


def kill(p: subprocess.Popen) -> None:
    """SIGKILL ``p``'s whole session and reap it."""
    try:
        os.killpg(p.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    p.wait(timeout=60)


def archives(out: Path) -> dict[str, Path]:
    """``<task>/<key>/<name>.nc`` -> path of every archive under ``out``."""
    return {p.relative_to(out).as_posix(): p for p in Path(out).glob("*/*/*.nc")}


def same_archive(a: Path, b: Path) -> list[str]:
    """Names of the variables whose values differ (bit for bit; NaN equals NaN)."""
    with xr.open_dataset(a) as x, xr.open_dataset(b) as y:
        names = set(x.variables) | set(y.variables)
        return sorted(n for n in names if n not in x.variables or n not in y.variables
                      or not np.array_equal(x[n].values, y[n].values, equal_nan=True))


def differences(reference: Path, out: Path) -> list[str]:
    """How the archives under ``out`` differ from those under ``reference`` (files and values)."""
    ref, got = archives(reference), archives(out)
    problems = [f"missing {n}" for n in sorted(set(ref) - set(got))]
    problems += [f"not in the reference: {n}" for n in sorted(set(got) - set(ref))]
    for n in sorted(set(ref) & set(got)):
        diff = same_archive(ref[n], got[n])
        if diff:
            problems.append(f"{n}: {', '.join(diff)} differ")
    return problems


def leftovers(out: Path, report_dir: Path | None = None) -> list[str]:
    """Files a finished run must not leave: temporary files, locks, checkpoints, report stages."""
    found = [p for p in Path(out).rglob("*")
             if p.name.endswith(".tmp") or p.name.endswith(".lock") or p.name == "checkpoint.npz"]
    if report_dir is not None:
        found += list(Path(report_dir).parent.glob(f".{Path(report_dir).name}.*.tmp"))
        found += [p for p in Path(report_dir).glob("*") if p.name.endswith(".tmp")]
    return sorted(str(p) for p in found)


def status_cli(home: Path, out: Path, study: str = "smoke") -> tuple[list[tuple[str, ...]], str]:
    """``saltstudy status`` as a user runs it: (label, task, state, key, detail) rows and its
    out-dir line."""
    r = run(["status", "--study", study, "--out", str(out)], env_for(home), timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    return parse_status(r.stdout)


def parse_status(text: str) -> tuple[list[tuple[str, ...]], str]:
    """The (label, task, state, key, detail) rows and the out-dir line of ``status``'s output."""
    rows, lock_line = [], ""
    for line in text.splitlines():
        parts = line.split(None, 4)
        if len(parts) >= 4 and len(parts[3]) == 20 and all(c in "0123456789abcdef" for c in parts[3]):
            rows.append(tuple(parts) + ("",) * (5 - len(parts)))
        elif line.startswith("out dir:"):
            lock_line = line
    return rows, lock_line


def status_here(home: Path, out: Path, study: str = "smoke") -> tuple[list[tuple[str, ...]], str]:
    """:func:`status_cli`'s rows and out-dir line from this process (the same functions, without
    a process start)."""
    from saltstudy.config import load_study
    from saltstudy.workflow.status import out_dir_state, study_status

    old = os.environ.get("SALTSTUDY_HOME")
    os.environ["SALTSTUDY_HOME"] = str(home)
    try:
        rows = study_status(load_study(study), out)
    finally:
        if old is None:
            del os.environ["SALTSTUDY_HOME"]
        else:
            os.environ["SALTSTUDY_HOME"] = old
    return [(r.label, r.task, r.state, r.key, r.detail) for r in rows], out_dir_state(out)


def status_problems(rows: list[tuple[str, ...]], lock_line: str, out: Path, reference: Path,
                    live_pid: int | None) -> list[str]:
    """Where the status rows (and the out-dir line) are not the truth about ``out`` (module doc).
    ``live_pid``: the run's process if it lives (frozen), else None."""
    problems = []
    for label, task, state, key, detail in rows:
        where = f"{label} {task} ({state}: {detail})"
        if state == "running" and live_pid is None:
            problems.append(f"{where}: running, but no process runs")
        if task == "report":
            tj = _task_json(task_dir(out, "report", key))
            done = tj.get("state") == "done" and Path(tj.get("report_dir", "")).is_dir()
            if done != (state == "done"):
                problems.append(f"{where}: the report's marker says {tj.get('state')}")
            continue
        kind = "spinup" if task == "start" else task
        archive = output_path(out, kind, key)
        complete = is_complete(archive)
        if complete != (state == "done"):
            problems.append(f"{where}: the archive is {'complete' if complete else 'not complete'}")
        if complete:
            ref = output_path(reference, kind, key)
            diff = same_archive(ref, archive) if ref.is_file() else ["(no reference archive)"]
            if diff:
                problems.append(f"{where}: differs from the uninterrupted run's ({diff})")
        if state == "partial" and not (task_dir(out, kind, key) / "checkpoint.npz").is_file():
            problems.append(f"{where}: partial without a checkpoint")
        if state == "running":
            tj = _task_json(task_dir(out, kind, key))
            if tj.get("state") != "running" or tj.get("pid") != live_pid:
                problems.append(f"{where}: running, but task.json says {tj.get('state')} by "
                                f"pid {tj.get('pid')} (the run is pid {live_pid})")
    if live_pid is not None and f"in use by saltstudy pid {live_pid} " not in lock_line:
        problems.append(f"the out dir's holder, pid {live_pid}, is not named: {lock_line!r}")
    if live_pid is None and not lock_line.startswith("out dir: not in use"):
        problems.append(f"no process runs, yet: {lock_line!r}")
    return problems


def _task_json(d: Path) -> dict:
    try:
        return json.loads((Path(d) / "task.json").read_text())
    except (OSError, ValueError):
        return {}


def _first_point(path: Path) -> float | None:
    """The time of the first point of a trace, once its line is whole."""
    try:
        line = Path(path).read_text().split("\n", 1)
    except OSError:
        return None
    return float(line[0].split()[0]) if len(line) == 2 else None


def read_trace(path: Path) -> list[tuple[float, int, str]]:
    """(time, pid, point) of the ``trace`` hook's lines."""
    rows = []
    for line in Path(path).read_text().splitlines():
        t, pid, name = line.split(" ", 2)
        rows.append((float(t), int(pid), name))
    return rows


def point_instants(trace: list[tuple[float, int, str]], n: int) -> list[tuple[float, str]]:
    """``n`` instants among the points of one process's trace: (fraction of the run, hook spec
    'GLOB K'): every kind of point once (its middle call; if ``n`` is smaller, kinds spread over
    the run), the rest spread evenly in time."""
    if not trace:
        return []
    t0, t1 = trace[0][0], trace[-1][0]
    calls: list[tuple[float, str, int]] = []
    count: dict[str, int] = {}
    for t, _, name in trace:
        count[name] = count.get(name, 0) + 1
        calls.append(((t - t0) / max(t1 - t0, 1e-9), name, count[name]))
    chosen: dict[tuple[str, int], float] = {}
    kinds = sorted(count, key=lambda name: next(c[0] for c in calls if c[1] == name))
    if n < len(kinds):
        kinds = [kinds[round(i * (len(kinds) - 1) / max(1, n - 1))] for i in range(n)]
    for name in kinds:
        mid = [c for c in calls if c[1] == name][(count[name] - 1) // 2]
        chosen[(name, mid[2])] = mid[0]
    for i in range(max(0, n - len(chosen))):
        target = (i + 0.5) / max(1, n - len(chosen))
        best = min((c for c in calls if (c[1], c[2]) not in chosen), key=lambda c: abs(c[0] - target),
                   default=None)
        if best is not None:
            chosen[(best[1], best[2])] = best[0]
    return sorted((f, f"{name} {k}") for (name, k), f in chosen.items())


def campaign(home: Path, work: Path, n_points: int, n_wall: int, log: Path,
             study: str = "smoke") -> dict:
    """Run ``study`` of ``home`` once uninterrupted (tracing its write points), then once per
    instant from an empty out dir: stopped there (a write point: the hook freezes it; a wall time:
    SIGSTOP), status read while it lives, SIGKILL, status read, rerun to its end, every check of
    the module doc. ``n_points`` instants among the traced points (progress.json's left out and
    the checkpoints after the second: their calls follow the clock), ``n_wall`` at wall times spread over 5-95 % of the run, counted from
    the run's first write point (the reference's first warms the kernels' cache). Writes the
    summary to ``log`` (JSON) after every instant and returns it."""
    ref, ref_report, trace = work / "ref", work / "ref-report", work / "trace.txt"
    r = run(["run-all", "--study", study, "--quiet", "--out", str(ref), "--report-dir",
             str(ref_report)], env_for(home, f"trace {trace}"))
    assert r.returncode == 0, r.stdout + r.stderr
    traced = read_trace(trace)
    wall = traced[-1][0] - traced[0][0]
    # progress.json and the checkpoints follow the clock: their k-th call in a rerun comes at
    # another moment or not at all; of the checkpoints, the first two (in the spin-up) are chosen
    points, seen = [], {}
    for x in traced:
        seen[x[2]] = seen.get(x[2], 0) + 1
        if not x[2].startswith("progress.json") and (not x[2].startswith("checkpoint.npz")
                                                     or seen[x[2]] <= 2):
            points.append(x)
    instants = [("point", f, spec) for f, spec in point_instants(points, n_points)]
    instants += [("wall", 0.05 + 0.9 * (i + 0.5) / n_wall, "") for i in range(n_wall)]
    summary = {"study": study, "reference_run_s": round(wall, 1), "results": []}
    for i, (kind, frac, spec) in enumerate(instants):
        out, report = work / f"out{i}", work / f"report{i}"
        args = ["run-all", "--study", study, "--quiet", "--out", str(out), "--report-dir", str(report)]
        t_start = time.time()
        own_trace = work / f"trace{i}.txt"
        p = launch(args, env_for(home, f"stop {spec}" if kind == "point" else f"trace {own_trace}"),
                   work / f"run{i}.log")
        if kind == "point":
            stopped = wait_frozen(p)
        else:
            spec = f"{frac * wall:.1f} s after the first write"
            first = None
            while first is None and p.poll() is None:
                first = _first_point(own_trace)
                time.sleep(0.02)
            while first is not None and time.time() < first + frac * wall and p.poll() is None:
                time.sleep(0.05)
            stopped = p.poll() is None
            if stopped:
                os.killpg(p.pid, signal.SIGSTOP)
        entry = {"instant": spec, "kind": kind, "fraction_of_run": round(frac, 3),
                 "stopped": stopped, "stopped_after_s": round(time.time() - t_start, 1)}
        problems: list[str] = []
        if stopped:
            rows, lock_line = status_cli(home, out, study)
            problems += [f"live: {x}" for x in status_problems(rows, lock_line, out, ref, p.pid)]
            entry["status_live"] = sorted({f"{r[1]} {r[2]}" for r in rows})
            kill(p)
            rows, lock_line = status_cli(home, out, study)
            problems += [f"killed: {x}" for x in status_problems(rows, lock_line, out, ref, None)]
            entry["status_killed"] = sorted({f"{r[1]} {r[2]}" for r in rows})
        else:
            p.wait()
        rr = run(args, env_for(home))
        if rr.returncode != 0:
            problems.append(f"rerun exit {rr.returncode}: {rr.stderr[-2000:]}")
        entry["rerun_computed"] = sum(line.startswith("[start] ") for line in rr.stderr.splitlines())
        problems += differences(ref, out) + [f"left: {x}" for x in leftovers(out, report)]
        rows, lock_line = status_cli(home, out, study)
        problems += [f"after: {x}" for x in status_problems(rows, lock_line, out, ref, None)]
        if {row[2] for row in rows} != {"done"}:
            problems.append(f"after the rerun, status: {sorted({row[2] for row in rows})}")
        if not (report / "index.html").is_file():
            problems.append("no report after the rerun")
        entry["problems"] = problems
        summary["results"].append(entry)
        res = summary["results"]
        summary.update(instants=len(res), stopped=sum(e["stopped"] for e in res),
                       passed=sum(e["stopped"] and not e["problems"] for e in res),
                       failed=sum(bool(e["problems"]) for e in res))
        Path(log).write_text(json.dumps(summary, indent=1))
        shutil.rmtree(out, ignore_errors=True)
        shutil.rmtree(report, ignore_errors=True)
    return summary
