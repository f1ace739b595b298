"""The task functions: spin-up, continuation, saltation, analysis, report.

Each writes one output into ``<out>/<task>/<key>/`` and returns its path; a complete output
(:func:`saltstudy.ncio.is_complete`) is returned untouched, anything else recomputed. While it
computes, a task holds its directory (``task.lock``) and records itself in ``task.json``. They
know nothing of dask (graph.py wraps them).
"""
from __future__ import annotations

import os
import platform
import shutil
import time
import traceback
from collections import deque
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .._identity import SOURCE_KEY, __version__
from ..config import Scene, Study
from ..faults import disk_full, point
from ..ncio import is_complete, open_dataset, read_attrs, write_dataset
from . import archives, cores, keys
from .driver import add_checkpoints, resume, run_saltation
from .paths import output_path, read_task_json, task_dir, write_json_atomic
from .lock import TASK_LOCK_NAME, Busy, DirLock, claim_task, pid_alive
from .progress import ProgressFile, emit
from .report_meta import cache_meta


class SourceMismatch(RuntimeError):
    """A worker runs other numerical code than the client that computed the cache keys."""


def check_source_key(expected: str | None) -> None:
    if expected is not None and expected != SOURCE_KEY:
        raise SourceMismatch(
            f"this process ({platform.node()}) runs saltstudy code {SOURCE_KEY}, but the client "
            f"keyed the tasks with {expected}: install the same checkout on every worker")


def write_task_json(directory: Path, **fields: Any) -> None:
    d = read_task_json(directory) or {}
    d.update(fields)
    d.update({"package_version": __version__, "source_key": SOURCE_KEY, "host": platform.node(),
              "pid": os.getpid()})
    write_json_atomic(Path(directory) / "task.json", d)


class _Running:
    """Context: the task's directory claimed (``lock.claim_task``), its leftovers tidied, task.json
    saying running, then done or failed. ``output``: the archive, or a function telling whether
    the task is done; ``done`` is True if another process completed it while this one waited."""

    def __init__(self, directory: Path, task: str, output: Path | Callable[[], bool],
                 **fields: Any):
        self.directory, self.task, self.fields = directory, task, fields
        self.finished = (lambda: is_complete(output)) if isinstance(output, Path) else output
        self.t0 = time.perf_counter()
        self.done = False
        self._lock = None

    def __enter__(self) -> "_Running":
        self.directory.mkdir(parents=True, exist_ok=True)
        name = f"{self.task} {self.fields.get('label') or self.fields.get('study') or ''}".strip()
        self._lock = claim_task(self.directory, name, emit)
        try:
            self.done = bool(self.finished())
            tidy_task_dir(self.directory, self.done)
            if not self.done:
                write_task_json(self.directory, task=self.task, state="running", started=time.time(),
                                error=None, **self.fields)
        except BaseException:
            self._lock.release()
            raise
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if not self.done:
                self._record(exc_type, exc, tb)
        finally:
            self._lock.release()

    def _record(self, exc_type, exc, tb) -> None:
        wall = time.perf_counter() - self.t0
        if exc is None:
            write_task_json(self.directory, state="done", finished=time.time(), task_wall_s=wall)
            return
        try:   # best effort (a full disk may refuse it): the task's own error is what propagates
            write_task_json(self.directory, state="failed", finished=time.time(), task_wall_s=wall,
                            error=f"{type(exc).__name__}: {exc}",
                            traceback="".join(traceback.format_exception(exc_type, exc, tb))[-4000:])
        except OSError:
            pass
        ProgressFile(self.directory, self.task, "", "").write(0.0, "failed", str(exc))


def tidy_task_dir(directory: Path, done: bool) -> None:
    """Remove a killed process's temporary files from a task's directory (the caller holds its
    lock), and the checkpoint if the archive is ``done``."""
    for tmp in Path(directory).glob("*.tmp"):
        tmp.unlink(missing_ok=True)
    if done:
        (Path(directory) / "checkpoint.npz").unlink(missing_ok=True)


def tidy_leftovers(directory: Path, output: Path | None) -> None:
    """:func:`tidy_task_dir` for a task this run does not compute, if no process holds it."""
    d = Path(directory)
    if not (d / TASK_LOCK_NAME).exists() and not (d / "checkpoint.npz").exists() \
            and not any(d.glob("*.tmp")):
        return
    lock = DirLock(d / TASK_LOCK_NAME, f"task {d.name}")
    try:
        lock.acquire(wait=False)
    except Busy:
        return
    try:
        tidy_task_dir(d, output is not None and is_complete(output))
    finally:
        lock.release()


class ProfileSamples:
    """Simulation callback: mean profiles sampled at least ``window``/20 s apart, the last
    ``window`` s kept (the spin-up's end, hence its last window, is not known ahead)."""

    def __init__(self, model, window: float):
        self.model, self.window, self.every = model, window, window / 20.0
        self.samples: deque[tuple[float, dict[str, np.ndarray]]] = deque()

    def _sample(self, t: float) -> None:
        from ..solver.diagnostics.flow import flow_profiles

        self.samples.append((t, {k: np.array(v) for k, v in flow_profiles(self.model).items()}))

    def __call__(self, sim) -> None:
        t = float(self.model.t)
        if not self.samples or t - self.samples[-1][0] >= self.every - 1e-12:
            self._sample(t)
            while self.samples and self.samples[0][0] < t - self.window - 1e-9:
                self.samples.popleft()

    def checkpoint(self) -> dict[str, np.ndarray]:
        if not self.samples:
            return {"t": np.zeros(0)}
        out = {"t": np.array([t for t, _ in self.samples])}
        for k in self.samples[0][1]:
            out[f"p:{k}"] = np.stack([p[k] for _, p in self.samples])
        return out

    def restore(self, data: dict[str, np.ndarray]) -> None:
        names = [k[2:] for k in data if k.startswith("p:")]
        self.samples = deque((float(t), {k: np.array(data[f"p:{k}"][i]) for k in names})
                             for i, t in enumerate(np.asarray(data["t"])))

    def window_mean(self, t_end: float) -> tuple[dict[str, np.ndarray], tuple[float, float, int]]:
        """The profiles' mean over the window ending at ``t_end``, and (first time, last time,
        count) of its samples."""
        if not self.samples or self.samples[-1][0] < t_end - 1e-12:
            self._sample(t_end)
        use = [(t, p) for t, p in self.samples if t >= t_end - self.window - 1e-9]
        mean = {k: np.mean([p[k] for _, p in use], axis=0) for k in use[-1][1]}
        return mean, (min(t for t, _ in use), t_end, len(use))


def spinup_task(scene: Scene, out_dir: Path, source_key: str | None = None,
                checkpoint_interval: float | None = None,
                interrupt_after_steps: int | None = None) -> Path:
    """Flow-only spin-up of ``scene`` -> ``<out>/spinup/<key>/spinup.nc``.

    Checkpoints every ``fidelity.checkpoint_interval_wall`` s of wall time (the paper's grid needs
    6-55 h, docs/BENCHMARKS.md); a rerun resumes and ends as the uninterrupted spin-up would.
    ``interrupt_after_steps`` (test hook): checkpoint and raise Interrupted after that many steps.
    """
    key = keys.spinup_key(scene)
    path = output_path(out_dir, "spinup", key)
    if is_complete(path):
        return path
    check_source_key(source_key)
    from ..solver.simulation import IterationInterval, TimeInterval
    from ..solver.spinup import record_interval, spinup_simulation

    scene = scene.spinup_scene()   # at fidelity.spinup.u_star_ref when set (solver.similarity)
    interval = (scene.fidelity.checkpoint_interval_wall if checkpoint_interval is None
                else checkpoint_interval)
    d = task_dir(out_dir, "spinup", key)
    ckpt_path = d / "checkpoint.npz"
    with _Running(d, "spinup", path, key=key, label=scene.label, config=scene.spinup_slice()) as run:
        if run.done:
            return path
        t0 = time.perf_counter()
        sp = scene.fidelity.spinup
        model, sim_ckpt, wall_before = resume(scene, ckpt_path, False)
        sim, steadiness = spinup_simulation(model)
        # the profiles are sampled at the records after the first (at t = 0 the flow is the
        # initial perturbed log law)
        every = record_interval(sp)
        profiles = ProfileSamples(model, sp.window)
        sim.add_callback("profiles", profiles, TimeInterval(every, start=every, from_last=True))
        prog = ProgressFile(d, "spinup", scene.label, "spin-up")
        prog.target = sp.t_max
        sim.add_callback("progress", lambda s: prog(s.t, s.stop_time), IterationInterval(1))
        cores.add_share(sim)
        add_checkpoints(sim, ckpt_path, interval,
                        meta=lambda: {"wall_time_s": wall_before + time.perf_counter() - t0},
                        interrupt_after_steps=interrupt_after_steps)
        if sim_ckpt is not None:
            sim.restore(sim_ckpt)
        try:
            sim.run()
            res = steadiness.result(sim)
            t_end = float(model.t)
            mean, window = profiles.window_mean(t_end)
            ckpt = model.checkpoint()
        finally:
            model.close()
        ds = archives.spinup_dataset(
            scene, model.grid, ckpt, mean, dict(res.history),
            converged=bool(res.converged), reason=str(res.reason), u_drive=float(model.state.u_drive),
            t_end=t_end, wall_time_s=wall_before + time.perf_counter() - t0, key=key,
            profile_window=window)
        write_dataset(ds, path)
        prog.write(t_end - sim.origin, "done")
    # only now is the checkpoint redundant (spinup.nc is complete and renamed into place)
    ckpt_path.unlink(missing_ok=True)
    return path


class _ContinuationRecord:
    """The u* history of a staggered start's link, at model times on the parent's clock."""

    def __init__(self, model, offset: float):
        self.model, self.offset = model, offset
        self.t: list[float] = []
        self.series: dict[str, list[float]] = {"u_star": [], "tke": [], "u_drive": []}

    def __call__(self, sim) -> None:
        from ..solver.diagnostics.flow import resolved_tke_volume_mean, u_star_at

        m = self.model
        self.t.append(m.t - self.offset)
        self.series["u_star"].append(u_star_at(m, m.z_ref))
        self.series["tke"].append(resolved_tke_volume_mean(m))
        self.series["u_drive"].append(m.state.u_drive)


def continuation_task(scene: Scene, parent_path: Path, out_dir: Path, key: str,
                      source_key: str | None = None) -> Path:
    """One link of a staggered start: the particle-free flow of ``parent_path`` continued for
    ``fidelity.spinup.stagger`` s -> ``<out>/spinup/<key>/spinup.nc``.

    Cases sharing one spin-up instant sample one phase of the box's minute-long swings of u* at
    2 m (0.43-0.72 m/s on reduced, ``git show 546de10:reports/reduced/FINDINGS.md``); starting case
    n (n - 1) links later spreads them over the swing. The archive keeps the parent's window-mean
    profiles, extends its u* history, and carries the link's own wall time. A link is seconds of
    flow, so it has no checkpoint."""
    path = output_path(out_dir, "spinup", key)
    if is_complete(path):
        return path
    check_source_key(source_key)
    if not is_complete(parent_path):
        raise FileNotFoundError(f"{parent_path}: parent archive missing or incomplete")
    from ..solver.model import Model
    from ..solver.simulation import IterationInterval, Simulation, TimeInterval

    scene = scene.spinup_scene()
    duration = float(scene.fidelity.spinup.stagger)
    d = task_dir(out_dir, "spinup", key)
    with _Running(d, "continuation", path, key=key, label=scene.label,
                  inputs={"parent": str(parent_path)}, duration=duration) as run:
        if run.done:
            return path
        t0 = time.perf_counter()
        parent = open_dataset(parent_path)
        restart = archives.restart_from_dataset(parent)
        model = Model.from_scene(scene, saltation=False, restart=restart)
        prog = ProgressFile(d, "spinup", scene.label, "continuation")
        prog.target = duration
        t_hist = np.asarray(parent["time_hist"].values)
        t_start = float(model.t)
        rec = _ContinuationRecord(model, t_start - float(t_hist[-1]) if t_hist.size else t_start)
        sim = Simulation(model, stop_time=duration)
        sim.add_callback("record", rec, TimeInterval(1.0, start=1.0, from_last=True))
        cores.add_share(sim)
        sim.add_callback("progress", lambda s: prog(s.t, s.stop_time), IterationInterval(1))
        try:
            sim.run()
            if not rec.t or rec.t[-1] < model.t - rec.offset - 1e-9:
                rec(sim)                       # the link's end
            ckpt = model.checkpoint()
            grid = model.grid
            u_drive = float(model.state.u_drive)
            t_end = float(model.t)
        finally:
            model.close()
        hist = {"t": np.concatenate([t_hist, rec.t]), **{
            k: np.concatenate([parent[f"{k}_hist"].values, v]) for k, v in rec.series.items()}}
        profiles = {src: np.asarray(parent[dst].values)
                    for src, dst in archives.PROFILE_NAMES.items()}
        wall = time.perf_counter() - t0
        ds = archives.spinup_dataset(
            scene, grid, ckpt, profiles, hist, converged=bool(parent.attrs.get("converged", 0)),
            reason=f"{parent.attrs.get('spinup_reason', '')}; continued {duration:g} s",
            u_drive=u_drive, t_end=t_end, wall_time_s=wall, key=key,
            profile_window=tuple(parent.attrs[f"profile_window_{k}"]
                                 for k in ("start", "end", "samples")))
        write_dataset(ds, path)
        prog.write(duration, "done")
    return path


def saltation_task(scene: Scene, spinup_path: Path, out_dir: Path, source_key: str | None = None,
                   interrupt_after_steps: int | None = None,
                   checkpoint_interval: float | None = None) -> Path:
    """Activation + saltation run + sampling -> ``<out>/saltation/<key>/samples.nc``; resumes
    from ``checkpoint.npz``, removed once samples.nc is complete."""
    key = keys.run_keys(scene.label, scene).saltation
    path = output_path(out_dir, "saltation", key)
    if is_complete(path):
        return path
    check_source_key(source_key)
    if not is_complete(spinup_path):
        raise FileNotFoundError(f"{spinup_path}: spin-up archive missing or incomplete")
    d = task_dir(out_dir, "saltation", key)
    ckpt_path = d / "checkpoint.npz"
    with _Running(d, "saltation", path, key=key, label=scene.label, inputs={"spinup": str(spinup_path)},
                  config=keys.saltation_slice(scene)) as run:
        if run.done:
            return path
        sp = open_dataset(spinup_path)
        restart = archives.start_restart(sp, scene)
        prog = ProgressFile(d, "saltation", scene.label, "saltation")
        res = run_saltation(scene, restart, ckpt_path, progress=prog,
                            checkpoint_interval=checkpoint_interval,
                            interrupt_after_steps=interrupt_after_steps)
        ds = archives.samples_dataset(scene, res.grid, res.records, res.z_plane, res.d_edges,
                                      res.t_activation, res.wall_time_s, key, res.n_steps)
        ds.attrs["spinup_wall_time_s"] = float(sp.attrs.get("wall_time_s", np.nan))
        if res.resumed_from is not None:
            ds.attrs["resumed_from_t"] = float(res.resumed_from)
        write_dataset(ds, path)
        write_task_json(d, solver_wall_s=res.wall_time_s, n_steps=res.n_steps,
                        resumed_from=res.resumed_from)
        prog.write(scene.fidelity.saltation_duration, "done")
    # only now is the checkpoint redundant (samples.nc is complete and renamed into place)
    ckpt_path.unlink(missing_ok=True)
    return path


def analysis_task(samples_path: Path, spinup_path: Path, out_dir: Path, key: str) -> Path:
    """``saltstudy.analysis.analyse.analyse_case`` -> ``<out>/analysis/<key>/analysis.nc``."""
    path = output_path(out_dir, "analysis", key)
    if is_complete(path):
        return path
    from ..analysis.analyse import analyse_case

    d = task_dir(out_dir, "analysis", key)
    with _Running(d, "analysis", path, key=key,
                  inputs={"samples": str(samples_path), "spinup": str(spinup_path)}) as run:
        if run.done:
            return path
        wall = (float(read_attrs(samples_path).get("wall_time_s", 0.0))
                + float(read_attrs(spinup_path).get("wall_time_s", 0.0)))
        analyse_case(samples_path, spinup_path, path, wall_time_s=wall)
        if not is_complete(path):
            raise RuntimeError(f"analyse_case returned but {path} is missing or incomplete")
    return path


def report_done(out_dir: Path, key: str, report_dir: Path) -> bool:
    """True if the report with this key was built into ``report_dir`` and is still there."""
    done = read_task_json(task_dir(out_dir, "report", key)) or {}
    return (done.get("state") == "done" and done.get("report_dir") == str(report_dir)
            and Path(report_dir).is_dir())


def report_task(study: Study, runs: dict[str, Path | None], out_dir: Path, report_dir: Path,
                key: str, meta: dict[str, Any] | None = None) -> Path:
    """``saltstudy.report.build_report`` over all runs -> ``report_dir``. Marker:
    ``<out>/report/<key>/task.json``."""
    from ..report import build_report

    d = task_dir(out_dir, "report", key)
    if report_done(out_dir, key, report_dir):
        return Path(report_dir)
    with _Running(d, "report", lambda: report_done(out_dir, key, report_dir), key=key,
                  study=study.name, report_dir=str(report_dir),
                  inputs={k: (str(v) if v else None) for k, v in runs.items()}) as run:
        if not run.done:
            build_report_staged(build_report, study.name, runs, Path(report_dir),
                                cache_meta(meta or {}))
    return Path(report_dir)


#: what ``build_report`` reads from the report directory it rebuilds
_REPORT_INPUTS = ("FINDINGS.md", "summary.json")


def build_report_staged(build_report: Callable[..., Path], study_name: str,
                        runs: dict[str, Path | None], report_dir: Path,
                        meta: dict[str, Any]) -> Path:
    """``build_report`` into ``.<name>.<pid>.tmp`` beside ``report_dir``, then each file renamed
    into it, ``index.html`` last: a stopped build leaves whole files, never a half-written one.
    Files the build does not write (FINDINGS.md) stay. Returns ``report_dir/index.html``."""
    report_dir = Path(report_dir)
    report_dir.parent.mkdir(parents=True, exist_ok=True)
    for old in report_dir.parent.glob(f".{report_dir.name}.*.tmp"):
        pid = old.name[len(report_dir.name) + 2:-len(".tmp")]
        if old.is_dir() and not (pid.isdigit() and pid_alive(int(pid))):
            shutil.rmtree(old, ignore_errors=True)      # a stage left by a stopped build
    stage = report_dir.parent / f".{report_dir.name}.{os.getpid()}.tmp"
    shutil.rmtree(stage, ignore_errors=True)     # of an earlier process that had this pid
    stage.mkdir()
    try:
        point("report:write")
        for name in _REPORT_INPUTS:
            if (report_dir / name).is_file():
                shutil.copy2(report_dir / name, stage / name)
        try:
            build_report(study_name, runs, stage, meta)
        except OSError as exc:
            full = disk_full(stage / "index.html", None, exc)
            if full is not None:
                raise full from exc
            raise
        point("report:tmp")
        report_dir.mkdir(parents=True, exist_ok=True)
        made = sorted((p for p in stage.iterdir() if p.name != "FINDINGS.md"),
                      key=lambda p: p.name == "index.html")
        for p in made:
            os.replace(p, report_dir / p.name)
        point("report:done")
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return report_dir / "index.html"
