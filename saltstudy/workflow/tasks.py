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
from .driver import Interrupted, Recorder, load_checkpoint, run_saltation, save_checkpoint
from .paths import output_path, task_dir, write_json_atomic
from .progress import ProgressFile

#: the spin-up checkpoint's record groups: the steadiness series and the profile samples
SPINUP_GROUPS = ("history", "profile")

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


def _close(model) -> None:
    """Release the solver's resources (FFT plans, thread pools) if it has any to release."""
    close = getattr(model, "close", None)
    if close is not None:
        close()


# ------------------------------------------------------------------------------------------
def spinup_task(scene: Scene, out_dir: Path, source_key: str | None = None,
                checkpoint_interval: float | None = None,
                interrupt_after_records: int | None = None) -> Path:
    """Flow-only spin-up of ``scene`` -> ``<out>/spinup/<key>/spinup.nc``.

    Every ``fidelity.checkpoint_interval_wall`` seconds of wall time (at a record of the
    steadiness series) it writes ``checkpoint.npz``: the model, the series and the profile samples
    of the last window. A rerun resumes from it and ends as the uninterrupted spin-up would; the
    paper's grid needs 6-55 h of it (docs/BENCHMARKS.md), longer than many batch queues allow.
    ``interrupt_after_records`` is a test hook: checkpoint and raise Interrupted at that record.
    """
    key = keys.spinup_key(scene)
    path = output_path(out_dir, "spinup", key)
    if is_complete(path):
        return path
    check_source_key(source_key)
    from ..solver.diagnostics import flow as dflow
    from ..solver.model import Model
    from ..solver.spinup import HISTORY_KEYS

    scene = scene.spinup_scene()   # at fidelity.spinup.u_star_ref when set (solver.similarity)
    interval = (scene.fidelity.checkpoint_interval_wall if checkpoint_interval is None
                else checkpoint_interval)

    d = task_dir(out_dir, "spinup", key)
    ckpt_path = d / "checkpoint.npz"
    with _Running(d, "spinup", key=key, label=scene.label, config=scene.spinup_slice()):
        t0 = time.perf_counter()
        sp = scene.fidelity.spinup
        # Profiles averaged over the last spin-up window: keep samples of the last `window`
        # seconds (every window/20), since when the steadiness test stops is not known ahead.
        window, every = sp.window, sp.window / 20.0
        samples: deque[tuple[float, dict[str, np.ndarray]]] = deque()
        history: dict[str, Any] = {}
        wall_before = 0.0
        loaded = load_checkpoint(ckpt_path, SPINUP_GROUPS)
        if loaded is not None:
            model_ckpt, rec, meta = loaded
            model = Model.from_scene(scene, saltation=False, restart=model_ckpt)
            t_h, series = rec.stacked("history")
            history = {"t0": float(meta["t0"]), "t": t_h.tolist(),
                       **{k: series[k].tolist() for k in HISTORY_KEYS if k != "t"}}
            t_p, prof = rec.stacked("profile")
            samples.extend((float(t), {k: v[i] for k, v in prof.items()}) for i, t in enumerate(t_p))
            wall_before = float(meta["wall_time_s"])
        else:
            model = Model.from_scene(scene, saltation=False)
        t_start = float(history.get("t0", getattr(model, "t", model.state.t)))
        prog = ProgressFile(d, "spinup", scene.label, "spin-up")
        prog.target = sp.t_max  # the solver reports (t since start of spin-up, t_max)
        last_ckpt = time.perf_counter()
        n_records = 0

        def write_ckpt() -> None:
            rec = Recorder(SPINUP_GROUPS)
            for i, t in enumerate(history["t"]):
                rec.add("history", t, {k: history[k][i] for k in HISTORY_KEYS if k != "t"})
            for t, prof in samples:
                rec.add("profile", t, prof)
            save_checkpoint(ckpt_path, model.checkpoint(), rec, {
                "t0": history["t0"], "t_spinup": history["t"][-1],
                "wall_time_s": wall_before + time.perf_counter() - t0})

        def on_progress(*args: Any, **kw: Any) -> None:
            nonlocal last_ckpt, n_records
            prog(*args, **kw)
            t = float(getattr(model, "t", model.state.t))
            if not samples or t - samples[-1][0] >= every - 1e-12:
                samples.append((t, {k: np.array(v) for k, v in dflow.flow_profiles(model).items()}))
                while samples and samples[0][0] < t - window - 1e-9:
                    samples.popleft()
            n_records += 1
            hook = interrupt_after_records is not None and n_records >= interrupt_after_records
            if time.perf_counter() - last_ckpt >= interval or hook:
                write_ckpt()
                last_ckpt = time.perf_counter()
            if hook:
                raise Interrupted(f"test hook: stopped after {n_records} records")

        try:
            res = model.spinup(progress=on_progress, history=history)
            t_end = float(getattr(model, "t", model.state.t))
            last = {k: np.array(v) for k, v in dflow.flow_profiles(model).items()}
            ckpt = model.checkpoint()
        finally:
            _close(model)
        if not samples or samples[-1][0] < t_end - 1e-12:
            samples.append((t_end, last))
        use = [s for t, s in samples if t >= t_end - window - 1e-9]
        profiles = {k: np.mean([s[k] for s in use], axis=0) for k in last}
        ds = archives.spinup_dataset(
            scene, model.state.grid, ckpt, profiles, dict(res.history),
            converged=bool(res.converged), reason=str(res.reason), u_drive=float(model.state.u_drive),
            t_end=t_end, wall_time_s=wall_before + time.perf_counter() - t0, key=key,
            profile_window=(min(t for t, _ in samples if t >= t_end - window - 1e-9), t_end, len(use)))
        write_dataset(ds, path)
        prog.write(t_end - t_start, "done")
    # only now is the checkpoint redundant (spinup.nc is complete and renamed into place)
    ckpt_path.unlink(missing_ok=True)
    return path


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
    over the link; its wall time is the link's own (a study's task times then sum each task once).
    A link is short (seconds of flow), so it has no checkpoint: an interrupted one reruns."""
    path = output_path(out_dir, "spinup", key)
    if is_complete(path):
        return path
    check_source_key(source_key)
    if not is_complete(parent_path):
        raise FileNotFoundError(f"{parent_path}: parent archive missing or incomplete")
    from ..solver.diagnostics.flow import resolved_tke_volume_mean, u_star_at
    from ..solver.model import Model

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
        t_start = float(model.state.t)
        history = {k[:-5] if k.endswith("_hist") else k: np.asarray(parent[k].values)
                   for k in ("u_star_hist", "tke_hist", "u_drive_hist")}
        t_hist = np.asarray(parent["time_hist"].values)
        offset = t_start - float(t_hist[-1]) if t_hist.size else t_start
        rec_t, rec = [], {"u_star": [], "tke": [], "u_drive": []}
        try:
            next_rec = 1.0
            while model.state.t - t_start < duration - 1e-9:
                t_rel = model.state.t - t_start
                model.step(model.next_dt(limit=min(next_rec, duration) - t_rel))
                t_rel = model.state.t - t_start
                if t_rel >= next_rec - 1e-9 or t_rel >= duration - 1e-9:
                    rec_t.append(model.state.t - offset)
                    rec["u_star"].append(u_star_at(model, model.z_ref))
                    rec["tke"].append(resolved_tke_volume_mean(model))
                    rec["u_drive"].append(model.state.u_drive)
                    prog.write(t_rel, "running")
                    next_rec = t_rel + 1.0
            ckpt = model.checkpoint()
            grid = model.state.grid
            u_drive = float(model.state.u_drive)
            t_end = float(model.state.t)
        finally:
            _close(model)
        hist = {"t": np.concatenate([t_hist, rec_t]),
                **{k: np.concatenate([history[k], rec[k]]) for k in rec}}
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
        build_report(study.name, runs, Path(report_dir), meta or {})
    return Path(report_dir)
