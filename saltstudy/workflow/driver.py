"""A run's records and checkpoints on the one time loop (``solver.simulation.Simulation``), and
the saltation run.

The simulation clips each step to the next record time; record times are integer multiples, never
accumulated, so they do not drift. Every ``fidelity.checkpoint_interval_wall`` s of wall time a
run writes ``checkpoint.npz`` atomically (model, simulation, records so far); the solver's restart
is bit for bit, so a resumed run's records equal an uninterrupted one's.
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .._identity import SOURCE_KEY
from ..config import Scene
from ..faults import write_atomic
from ..solver.simulation import (TIME_EPS, IterationInterval, Simulation, SpecifiedTimes,
                                 WallTimeInterval)
from . import archives, cores

GROUPS = ("series", "plane", "sample")


class Interrupted(RuntimeError):
    """Raised by the test hook ``interrupt_after_steps`` (simulates a killed run)."""


class Recorder:
    """In-memory records, by group; each group is a list of times and a list per variable."""

    def __init__(self, groups: tuple[str, ...] = GROUPS) -> None:
        self.times: dict[str, list[float]] = {g: [] for g in groups}
        self.values: dict[str, dict[str, list[np.ndarray]]] = {g: {} for g in groups}

    def add(self, group: str, t: float, values: dict[str, Any]) -> None:
        n = len(self.times[group])
        for name, v in values.items():
            col = self.values[group].setdefault(name, [])
            if not col and n:
                # a record first written after a resume from an older checkpoint: NaN before it
                col.extend(np.full(np.shape(v), np.nan) for _ in range(n))
            if len(col) != n:
                raise ValueError(f"record '{group}.{name}' missing at earlier times")
            col.append(np.array(v, copy=True))
        self.times[group].append(float(t))

    def stacked(self, group: str) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        return (np.array(self.times[group], dtype=np.float64),
                {k: np.stack(v) for k, v in self.values[group].items() if v})

    def checkpoint(self) -> dict[str, np.ndarray]:
        out: dict[str, np.ndarray] = {}
        for g in self.times:
            t, vals = self.stacked(g)
            out.update({f"rec:{g}:__times__": t, **{f"rec:{g}:{k}": v for k, v in vals.items()}})
        return out

    @classmethod
    def restore(cls, flat: dict[str, np.ndarray], groups: tuple[str, ...] = GROUPS) -> "Recorder":
        r = cls(groups)
        for g in groups:
            prefix = f"rec:{g}:"
            r.times[g] = [float(x) for x in flat.get(prefix + "__times__", [])]
            r.values[g] = {k[len(prefix):]: list(v) for k, v in flat.items()
                           if k.startswith(prefix) and k != prefix + "__times__"}
        return r


@dataclass
class Schedule:
    """Record times (s since activation), merged into one sorted list of (time, groups)."""

    events: list[tuple[float, frozenset[str]]]
    duration: float

    @classmethod
    def from_scene(cls, scene: Scene) -> "Schedule":
        f = scene.fidelity
        s, dur = f.sampling, f.saltation_duration

        def multiples(start: float, step: float, stop: float) -> list[float]:
            n = int(math.floor((stop - start) / step + 1e-9))
            return [start + i * step for i in range(n + 1)]

        by_time: dict[float, set[str]] = {}

        def put(times: list[float], group: str) -> None:
            for t in times:
                # snap to an existing time within TIME_EPS (e.g. 0.1*3 vs 0.3)
                key = next((k for k in by_time if abs(k - t) < TIME_EPS), round(t, 12))
                by_time.setdefault(key, set()).add(group)

        put(multiples(0.0, s.series_interval, dur), "series")
        first, last = (0.0, dur) if f.outputs.animation else (s.start, s.end)
        put(multiples(first, s.plane_interval, last), "plane")
        put([s.start + i * s.interval for i in range(s.count)], "sample")
        by_time.setdefault(round(dur, 12), set())  # run to the end even if nothing is recorded
        events = sorted((t, frozenset(g)) for t, g in by_time.items() if t <= dur + TIME_EPS)
        return cls(events, dur)

    def times(self, group: str) -> list[float]:
        """The record times of one group [s since activation]."""
        return [t for t, g in self.events if group in g]

    @property
    def end(self) -> float:
        """The run's last time [s since activation]."""
        return self.events[-1][0]


def save_checkpoint(path: Path, model_ckpt: dict[str, Any], sim_ckpt: dict[str, Any],
                    meta: dict[str, Any]) -> None:
    """Write a model and a simulation checkpoint (callback arrays as arrays, the rest as JSON) and
    ``meta`` to ``path`` atomically."""
    kinds = {k: archives.scalar_kind(v) or "array" for k, v in model_ckpt.items()}
    arrays = {f"model:{k}": np.asarray("" if v is None else v) for k, v in model_ckpt.items()}
    callbacks = sim_ckpt.get("callbacks", {})
    arrays.update({f"cb:{name}:{k}": np.asarray(v) for name, state in callbacks.items()
                   for k, v in state.items()})
    sim = {**{k: v for k, v in sim_ckpt.items() if k != "callbacks"},
           "callbacks": {name: list(state) for name, state in callbacks.items()}}
    meta = dict(meta, model_kinds=kinds, source_key=SOURCE_KEY, simulation=sim)
    arrays["meta"] = np.asarray(json.dumps(meta))

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as fh:   # a file, not a name: np.savez would append ".npz" to it
            np.savez(fh, **arrays)

    write_atomic(path, write, sum(a.nbytes for a in arrays.values()))


def load_checkpoint(path: Path) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any]] | None:
    """(model checkpoint, simulation checkpoint, meta), or None if the file is absent, unreadable
    or was written by other numerical code (then it cannot resume bit for bit and is ignored)."""
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            flat = {k: z[k] for k in z.files}
        meta = json.loads(str(flat.pop("meta")))
    except Exception:  # truncated or corrupt: start over rather than trust it
        return None
    if meta.get("source_key") != SOURCE_KEY or "simulation" not in meta:
        return None
    conv = {**archives.SCALAR_FROM, "array": np.ascontiguousarray}
    model_ckpt = {k[len("model:"):]: conv[meta["model_kinds"][k[len("model:"):]]](v)
                  for k, v in flat.items() if k.startswith("model:")}
    sim = dict(meta.pop("simulation"))
    sim["callbacks"] = {name: {k: flat[f"cb:{name}:{k}"] for k in names}
                        for name, names in sim.get("callbacks", {}).items()}
    return model_ckpt, sim, meta


def resume(scene: Scene, path: Path, saltation: bool, restart: dict[str, Any] | None = None):
    """(model, simulation checkpoint, wall time so far [s]): resumed from the checkpoint at
    ``path`` if it is valid, else a new model of ``scene`` (from ``restart``; saltation activated)
    with (None, 0)."""
    from ..solver.model import Model

    loaded = load_checkpoint(path)
    if loaded is not None:
        model_ckpt, sim_ckpt, meta = loaded
        return (Model.from_scene(scene, saltation=saltation, restart=model_ckpt), sim_ckpt,
                float(meta["wall_time_s"]))
    model = Model.from_scene(scene, saltation=saltation, restart=restart)
    if saltation:
        if scene.spinup_fidelity is not None:
            from ..solver.tiling import project_restart
            project_restart(model)   # a tiled flow is divergence-free only once projected
        model.activate_saltation()
    return model, None, 0.0


def add_checkpoints(sim: Simulation, path: Path, interval: float,
                    meta: Callable[[], dict[str, Any]] | None = None,
                    interrupt_after_steps: int | None = None) -> None:
    """A checkpoint to ``path`` every ``interval`` s of wall time (with ``meta()``) and, as a test
    hook, a checkpoint and :class:`Interrupted` after ``interrupt_after_steps`` steps of a run."""
    def write(s: Simulation) -> None:
        save_checkpoint(path, s.model.checkpoint(), s.checkpoint(), meta() if meta else {})

    sim.add_callback("checkpoint", write, WallTimeInterval(interval))
    if interrupt_after_steps is not None:
        def interrupt(s: Simulation) -> None:
            write(s)
            raise Interrupted(f"test hook: stopped after {s.steps_this_run} steps")

        sim.add_callback("interrupt", interrupt, IterationInterval(interrupt_after_steps))


@dataclass
class SaltationResult:
    records: dict[str, tuple[np.ndarray, dict[str, np.ndarray]]]
    grid: Any
    z_plane: np.ndarray
    d_edges: np.ndarray
    t_activation: float
    wall_time_s: float
    n_steps: int
    resumed_from: float | None = None  # t since activation of the checkpoint resumed from


class SaltationRecords:
    """The saltation run's records, a Simulation callback per group on the merged record times of
    ``Schedule`` (values from ``solver.diagnostics.records``); called, it records the series, and
    its state is checkpointed with that callback."""

    def __init__(self, scene: Scene, model, n_released: int):
        from ..solver.diagnostics import records

        self.records = records
        self.scene, self.model, self.n_released = scene, model, n_released
        self.recorder = Recorder()
        self.z_plane = archives.plane_heights(scene)
        self.d_edges = archives.diameter_edges(scene)
        self.z_ref = archives.z_ref_eff(scene)
        self.full = scene.fidelity.outputs.full_snapshots
        #: (dt, Courant number) of the last step before a record; kept over a resume
        self.last = (math.nan, math.nan)
        self.sim: Simulation | None = None

    def __call__(self, sim: Simulation) -> None:
        if sim.last_step is not None:
            self.last = (float(sim.last_step.dt), float(sim.last_step.max_cfl))
        self.recorder.add("series", sim.event_time, self.records.series(
            self.model, self.z_ref, self.n_released, *self.last))

    def plane(self, sim: Simulation) -> None:
        self.recorder.add("plane", sim.event_time, self.records.planes(self.model, self.z_plane))

    def sample(self, sim: Simulation) -> None:
        self.recorder.add("sample", sim.event_time,
                          self.records.sample(self.model, self.d_edges, full=self.full))

    def checkpoint(self) -> dict[str, np.ndarray]:
        out = self.recorder.checkpoint()
        step = self.sim.last_step if self.sim is not None else None
        last = self.last if step is None else (float(step.dt), float(step.max_cfl))
        out["last_step"] = np.asarray(last, dtype=np.float64)
        return out

    def restore(self, data: dict[str, np.ndarray]) -> None:
        last = data.get("last_step")
        self.recorder = Recorder.restore({k: v for k, v in data.items() if k.startswith("rec:")})
        if last is not None:
            self.last = (float(last[0]), float(last[1]))


def run_saltation(scene: Scene, restart: dict[str, Any], checkpoint_path: Path,
                  progress: Callable[[float, float], None] | None = None,
                  checkpoint_interval: float | None = None,
                  interrupt_after_steps: int | None = None) -> SaltationResult:
    """Activate saltation on the spun-up flow ``restart`` and run it, recording on schedule;
    resumes from a valid ``checkpoint_path`` (``interrupt_after_steps``: add_checkpoints)."""
    interval = (scene.fidelity.checkpoint_interval_wall if checkpoint_interval is None
                else checkpoint_interval)
    schedule = Schedule.from_scene(scene)
    model, sim_ckpt, wall_before = resume(scene, checkpoint_path, True, restart)
    t_act = float(model.t_activation)
    # what activation released (the component rounds scene.n_initial)
    n_released = int(model.components[0].n_initial)

    sim = Simulation(model, stop_time=schedule.end, origin=t_act,
                     dt_fixed=scene.fidelity.saltation_dt_fixed)
    recs = SaltationRecords(scene, model, n_released)
    recs.sim = sim
    for group, call in (("series", recs), ("plane", recs.plane), ("sample", recs.sample)):
        sim.add_callback(group, call, SpecifiedTimes(schedule.times(group)))
    if progress is not None:
        sim.add_callback("progress", lambda s: progress(s.t, s.stop_time), IterationInterval(1))
    t0_wall = time.perf_counter()
    cores.add_share(sim)
    add_checkpoints(sim, checkpoint_path, interval,
                    meta=lambda: {"wall_time_s": wall_before + time.perf_counter() - t0_wall,
                                  "t_since_activation": sim.t, "n_steps": sim.n_steps},
                    interrupt_after_steps=interrupt_after_steps)
    resumed_from = None
    if sim_ckpt is not None:
        sim.restore(sim_ckpt)
        resumed_from = sim.t
    try:
        sim.run()
    finally:
        model.close()

    rec = recs.recorder
    return SaltationResult(
        records={g: rec.stacked(g) for g in GROUPS}, grid=model.grid, z_plane=recs.z_plane,
        d_edges=recs.d_edges, t_activation=t_act,
        wall_time_s=wall_before + time.perf_counter() - t0_wall, n_steps=sim.n_steps,
        resumed_from=resumed_from)
