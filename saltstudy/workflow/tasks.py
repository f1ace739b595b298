"""The four task functions: spin-up, saltation, analysis, report.

Each takes its configuration and its input paths, writes one output into its cache directory
``<out>/<task>/<key>/`` and returns the output's path. Each first checks for a complete output
(:func:`saltstudy.ncio.is_complete`: readable and marked complete) and returns it untouched if
present; an incomplete, truncated or corrupt file is never trusted but recomputed. Each records
what it did in ``task.json`` beside its output (state, config slice, inputs, wall time, error).

They know nothing of dask (graph.py wraps them), so ``saltstudy run CASE`` calls them directly.
"""
from __future__ import annotations

import json
import os
import platform
import time
import traceback
from collections import deque
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .. import SOURCE_KEY, __version__
from ..config import Scene, Study
from ..ncio import NC_LOCK, is_complete, open_dataset, write_dataset
from . import archives, keys
from ..solver.similarity import rescale_restart
from .driver import Interrupted, add_checkpoints, load_checkpoint, run_saltation
from .paths import output_path, task_dir, write_json_atomic
from .progress import ProgressFile
from .report_meta import cache_meta

__all__ = ["spinup_task", "saltation_task", "analysis_task", "report_task", "read_attrs",
           "write_task_json", "read_task_json", "report_done", "check_source_key", "SourceMismatch"]


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


def read_task_json(directory: Path) -> dict | None:
    try:
        return json.loads((Path(directory) / "task.json").read_text())
    except (OSError, ValueError):
        return None


def read_attrs(path: Path) -> dict[str, Any]:
    """Global attributes of an archive without loading its variables."""
    import xarray as xr

    with NC_LOCK:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            return dict(ds.attrs)


class _Running:
    """Context: task.json says running; on error it says failed (with the reason) and re-raises."""

    def __init__(self, directory: Path, task: str, **fields: Any):
        self.directory, self.task, self.fields = directory, task, fields
        self.t0 = time.perf_counter()

    def __enter__(self) -> "_Running":
        self.directory.mkdir(parents=True, exist_ok=True)
        write_task_json(self.directory, task=self.task, state="running", started=time.time(),
                        error=None, **self.fields)
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        wall = time.perf_counter() - self.t0
        if exc is None:
            write_task_json(self.directory, state="done", finished=time.time(), task_wall_s=wall)
        else:
            write_task_json(self.directory, state="failed", finished=time.time(), task_wall_s=wall,
                            error=f"{type(exc).__name__}: {exc}",
                            traceback="".join(traceback.format_exception(exc_type, exc, tb))[-4000:])
            ProgressFile(self.directory, self.task, "", "").write(0.0, "failed", str(exc))


# ------------------------------------------------------------------------------------------
class ProfileSamples:
    """Mean profiles (``flow_profiles``) sampled at the spin-up's records at least ``window``/20
    apart, keeping the last ``window`` seconds: the spin-up archive's profiles are their mean over
    the spin-up's last window, and when the steadiness test stops the run is not known ahead.
    A Simulation callback with state."""

    def __init__(self, model, window: float):
        self.model, self.window, self.every = model, window, window / 20.0
        self.samples: deque[tuple[float, dict[str, np.ndarray]]] = deque()

    def __call__(self, sim) -> None:
        from ..solver.diagnostics.flow import flow_profiles

        t = float(self.model.t)
        if not self.samples or t - self.samples[-1][0] >= self.every - 1e-12:
            self.samples.append((t, {k: np.array(v) for k, v in flow_profiles(self.model).items()}))
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
        """The profiles' mean over the window that ends at ``t_end`` (a sample at ``t_end`` is
        taken if there is none), and (first time, last time, count) of the samples in it."""
        from ..solver.diagnostics.flow import flow_profiles

        if not self.samples or self.samples[-1][0] < t_end - 1e-12:
            self.samples.append((t_end, {k: np.array(v) for k, v in
                                         flow_profiles(self.model).items()}))
        use = [(t, p) for t, p in self.samples if t >= t_end - self.window - 1e-9]
        mean = {k: np.mean([p[k] for _, p in use], axis=0) for k in use[-1][1]}
        return mean, (min(t for t, _ in use), t_end, len(use))


def spinup_task(scene: Scene, out_dir: Path, source_key: str | None = None,
                checkpoint_interval: float | None = None,
                interrupt_after_steps: int | None = None) -> Path:
    """Flow-only spin-up of ``scene`` -> ``<out>/spinup/<key>/spinup.nc``.

    Every ``fidelity.checkpoint_interval_wall`` seconds of wall time it writes ``checkpoint.npz``:
    the model, the steadiness series and the profile samples of the last window. A rerun resumes
    from it and ends as the uninterrupted spin-up would; the paper's grid needs 6-55 h of it
    (docs/BENCHMARKS.md), longer than many batch queues allow. ``interrupt_after_steps`` is a
    test hook: checkpoint and raise Interrupted after that many steps.
    """
    key = keys.spinup_key(scene)
    path = output_path(out_dir, "spinup", key)
    if is_complete(path):
        return path
    check_source_key(source_key)
    from ..solver.model import Model
    from ..solver.simulation import IterationInterval, TimeInterval
    from ..solver.spinup import record_interval, spinup_simulation

    scene = scene.spinup_scene()   # at fidelity.spinup.u_star_ref when set (solver.similarity)
    interval = (scene.fidelity.checkpoint_interval_wall if checkpoint_interval is None
                else checkpoint_interval)
    d = task_dir(out_dir, "spinup", key)
    ckpt_path = d / "checkpoint.npz"
    with _Running(d, "spinup", key=key, label=scene.label, config=scene.spinup_slice()):
        t0 = time.perf_counter()
        sp = scene.fidelity.spinup
        loaded = load_checkpoint(ckpt_path)
        if loaded is not None:
            model_ckpt, sim_ckpt, meta = loaded
            model = Model.from_scene(scene, saltation=False, restart=model_ckpt)
            wall_before = float(meta["wall_time_s"])
        else:
            model = Model.from_scene(scene, saltation=False)
            sim_ckpt, wall_before = None, 0.0
        sim, steadiness = spinup_simulation(model)
        # the profiles are sampled at the records after the first (at t = 0 the flow is the
        # initial perturbed log law)
        every = record_interval(sp)
        profiles = ProfileSamples(model, sp.window)
        sim.add_callback("profiles", profiles, TimeInterval(every, start=every, from_last=True))
        prog = ProgressFile(d, "spinup", scene.label, "spin-up")
        prog.target = sp.t_max
        sim.add_callback("progress", lambda s: prog(s.t, s.stop_time), IterationInterval(1))
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
    """One link of a staggered start: the particle-free flow of ``parent_path`` (a spin-up or an
    earlier link) continued for ``fidelity.spinup.stagger`` seconds at the spin-up's u* ->
    ``<out>/spinup/<key>/spinup.nc``, an archive a saltation run starts from as from the spin-up.

    Why: cases that share one spin-up start from one instant of it and so sample one phase of the
    box's slow swings of the stress at 2 m (about a minute long on the reduced grid: 5-s means of
    u* at 2 m 0.43-0.72 m/s around 0.54 in its spin-up,
    ``git show 546de10:reports/reduced/FINDINGS.md``); starting case
    n (n - 1) links later spreads the cases over the swing. On ``reduced`` it did not remove the
    ten cases' common excess of the stress u*s (+13 % from one instant, +11 % staggered): that is
    the column above 2 m out of balance after the relaxation, in every start
    (reports/reduced/FINDINGS.md). The archive keeps the parent's
    window-mean profiles (the particle-free reference of the analysis) and extends its u* history
    over the link (a record every second and at its end); its wall time is the link's own (a
    study's task times then sum each task once). A link is short (seconds of flow), so it has no
    checkpoint: an interrupted one reruns."""
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
    with _Running(d, "continuation", key=key, label=scene.label,
                  inputs={"parent": str(parent_path)}, duration=duration):
        t0 = time.perf_counter()
        parent = open_dataset(parent_path)
        restart = archives.restart_from_dataset(parent)
        model = Model.from_scene(scene, saltation=False, restart=restart)
        prog = ProgressFile(d, "spinup", scene.label, "continuation")
        prog.target = duration
        history = {k[:-5] if k.endswith("_hist") else k: np.asarray(parent[k].values)
                   for k in ("u_star_hist", "tke_hist", "u_drive_hist")}
        t_hist = np.asarray(parent["time_hist"].values)
        t_start = float(model.t)
        rec = _ContinuationRecord(model, t_start - float(t_hist[-1]) if t_hist.size else t_start)
        sim = Simulation(model, stop_time=duration)
        sim.add_callback("record", rec, TimeInterval(1.0, start=1.0, from_last=True))
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
        hist = {"t": np.concatenate([t_hist, rec.t]),
                **{k: np.concatenate([history[k], rec.series[k]]) for k in rec.series}}
        profiles = {src: np.asarray(parent[dst].values) for src, dst in
                    (("u", "u_mean"), ("uw_res", "uw_res"), ("uw_sgs", "uw_sgs"),
                     ("tke_res", "tke_res"), ("e_sgs", "e_sgs"))}
        wall = time.perf_counter() - t0
        ds = archives.spinup_dataset(
            scene, grid, ckpt, profiles, hist, converged=bool(parent.attrs.get("converged", 0)),
            reason=f"{parent.attrs.get('spinup_reason', '')}; continued {duration:g} s",
            u_drive=u_drive, t_end=t_end, wall_time_s=wall, key=key,
            profile_window=(float(parent.attrs["profile_window_start"]),
                            float(parent.attrs["profile_window_end"]),
                            int(parent.attrs["profile_window_samples"])))
        write_dataset(ds, path)
        prog.write(duration, "done")
    return path


def saltation_task(scene: Scene, spinup_path: Path, out_dir: Path, source_key: str | None = None,
                   interrupt_after_steps: int | None = None,
                   checkpoint_interval: float | None = None) -> Path:
    """Activation + saltation run + sampling -> ``<out>/saltation/<key>/samples.nc``.

    Resumes from ``checkpoint.npz`` in the same directory if an earlier run was interrupted; the
    checkpoint is removed once samples.nc is complete. On a solver blow-up the last checkpoint is
    kept and task.json names step, time, field and place.
    """
    key = keys.run_keys(scene.label, scene).saltation
    path = output_path(out_dir, "saltation", key)
    if is_complete(path):
        return path
    check_source_key(source_key)
    if not is_complete(spinup_path):
        raise FileNotFoundError(f"{spinup_path}: spin-up archive missing or incomplete")
    d = task_dir(out_dir, "saltation", key)
    ckpt_path = d / "checkpoint.npz"
    with _Running(d, "saltation", key=key, label=scene.label, inputs={"spinup": str(spinup_path)},
                  config=keys.saltation_slice(scene)):
        sp = open_dataset(spinup_path)
        restart = archives.restart_from_dataset(sp)
        # a spin-up shared by similarity ran at another u*: rescale it to this case's u*s
        u_spin = float(sp.attrs.get("u_star_target", scene.case.forcing.u_star_s))
        restart = rescale_restart(restart, scene.case.forcing.u_star_s / u_spin)
        prog = ProgressFile(d, "saltation", scene.label, "saltation")
        res = run_saltation(scene, restart, ckpt_path, progress=prog,
                            checkpoint_interval=checkpoint_interval,
                            interrupt_after_steps=interrupt_after_steps,
                            reference_profile=(scene.case.forcing.u_star_s / u_spin)
                            * np.asarray(sp["u_mean"].values))
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
    with _Running(d, "analysis", key=key, inputs={"samples": str(samples_path), "spinup": str(spinup_path)}):
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
                key: str, meta: dict[str, Any] | None = None,
                log: Callable[[str], None] = print) -> Path | None:
    """``saltstudy.report.build_report`` over all runs -> ``report_dir``; None if the report
    package is not installed in this checkout. Marker: ``<out>/report/<key>/task.json``."""
    d = task_dir(out_dir, "report", key)
    if report_done(out_dir, key, report_dir):
        return Path(report_dir)
    try:
        from ..report import build_report
    except ImportError as exc:
        log(f"report: skipped (saltstudy.report.build_report not available: {exc})")
        return None
    with _Running(d, "report", key=key, study=study.name, report_dir=str(report_dir),
                  inputs={k: (str(v) if v else None) for k, v in runs.items()}):
        build_report(study.name, runs, Path(report_dir), cache_meta(meta or {}))
    return Path(report_dir)
