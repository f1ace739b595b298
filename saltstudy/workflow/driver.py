"""The saltation driver loop: activation, stepping onto record times, recording, checkpoints.

Records land exactly on their times: each step is clipped with ``model.next_dt(limit=...)`` to
the next record time (series every ``sampling.series_interval``, planes every
``sampling.plane_interval`` inside the sampling window — or over the whole run with
``outputs.animation`` — and 3-D samples at ``sampling.start + i * sampling.interval``). Record
times are computed as integer multiples, never accumulated, so they do not drift.

Every ``fidelity.checkpoint_interval_wall`` seconds of wall time the driver writes
``checkpoint.npz`` (temporary name + ``os.replace``): the model's checkpoint, the recorder's
records so far and the loop position. A rerun resumes from it; because the solver's restart is
bit-for-bit, the final records equal those of an uninterrupted run.
"""
from __future__ import annotations

import json
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from .. import SOURCE_KEY
from ..config import Scene
from . import archives, health

__all__ = ["Recorder", "Schedule", "SaltationResult", "run_saltation", "save_checkpoint",
           "load_checkpoint", "Interrupted"]

#: two record times closer than this are the same time [s]; far below any time step
TIME_EPS = 1e-9

GROUPS = ("series", "plane", "sample")


class Interrupted(RuntimeError):
    """Raised by the test hook ``interrupt_after_steps`` (simulates a killed run)."""


# ------------------------------------------------------------------------------------------
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
            out[f"rec:{g}:__times__"] = t
            for k, v in vals.items():
                out[f"rec:{g}:{k}"] = v
        return out

    @classmethod
    def restore(cls, flat: dict[str, np.ndarray], groups: tuple[str, ...] = GROUPS) -> "Recorder":
        r = cls(groups)
        for g in groups:
            r.times[g] = [float(x) for x in flat.get(f"rec:{g}:__times__", [])]
            prefix = f"rec:{g}:"
            for k, v in flat.items():
                if k.startswith(prefix) and k != f"rec:{g}:__times__":
                    r.values[g][k[len(prefix):]] = list(v)
        return r


# ------------------------------------------------------------------------------------------
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
        if f.outputs.animation:
            put(multiples(0.0, s.plane_interval, dur), "plane")
        else:
            put(multiples(s.start, s.plane_interval, s.end), "plane")
        put([s.start + i * s.interval for i in range(s.count)], "sample")
        by_time.setdefault(round(dur, 12), set())  # run to the end even if nothing is recorded
        events = sorted((t, frozenset(g)) for t, g in by_time.items() if t <= dur + TIME_EPS)
        return cls(events, dur)


# ------------------------------------------------------------------------------------------
def save_checkpoint(path: Path, model_ckpt: dict[str, Any], recorder: Recorder,
                    meta: dict[str, Any]) -> None:
    """Write the model checkpoint, the records and ``meta`` to ``path`` atomically."""
    arrays: dict[str, np.ndarray] = {}
    kinds: dict[str, str] = {}
    for k, v in model_ckpt.items():
        kind = archives._scalar_kind(v)
        kinds[k] = kind or "array"
        arrays[f"model:{k}"] = np.asarray("" if v is None else v)
    arrays.update(recorder.checkpoint())
    meta = dict(meta, model_kinds=kinds, source_key=SOURCE_KEY)
    arrays["meta"] = np.asarray(json.dumps(meta))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")  # per process: never two writers on one file
    with open(tmp, "wb") as fh:
        np.savez(fh, **arrays)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def load_checkpoint(path: Path, groups: tuple[str, ...] = GROUPS
                    ) -> tuple[dict[str, Any], Recorder, dict[str, Any]] | None:
    """(model checkpoint, recorder of ``groups``, meta), or None if the file is absent,
    unreadable or was written by other numerical code (then it cannot resume bit-for-bit and is
    ignored)."""
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            flat = {k: z[k] for k in z.files}
        meta = json.loads(str(flat.pop("meta")))
    except Exception:  # truncated or corrupt: start over rather than trust it
        return None
    if meta.get("source_key") != SOURCE_KEY:
        return None
    conv = {"bool": lambda a: bool(a), "int": lambda a: int(a), "float": lambda a: float(a),
            "str": lambda a: str(a), "none": lambda a: None, "array": lambda a: np.ascontiguousarray(a)}
    model_ckpt = {k[len("model:"):]: conv[meta["model_kinds"][k[len("model:"):]]](v)
                  for k, v in flat.items() if k.startswith("model:")}
    rec = Recorder.restore({k: v for k, v in flat.items() if k.startswith("rec:")}, groups)
    return model_ckpt, rec, meta


# ------------------------------------------------------------------------------------------
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
    extra: dict = field(default_factory=dict)


def _model_time(m) -> float:
    return float(getattr(m, "t", m.state.t))


def run_saltation(scene: Scene, restart: dict[str, Any], checkpoint_path: Path,
                  progress: Callable[[float, float], None] | None = None,
                  checkpoint_interval: float | None = None,
                  interrupt_after_steps: int | None = None) -> SaltationResult:
    """Activate saltation on the spun-up flow ``restart`` and run it, recording on schedule.

    Resumes from ``checkpoint_path`` if it holds a valid checkpoint. ``interrupt_after_steps``
    is a test hook: raise :class:`Interrupted` after that many steps *of this call* (a checkpoint
    is written just before, so the rerun resumes from there).
    """
    from ..solver.diagnostics import flow as dflow
    from ..solver.diagnostics import grains as dpart
    from ..solver.model import Model

    interval = scene.fidelity.checkpoint_interval_wall if checkpoint_interval is None else checkpoint_interval
    schedule = Schedule.from_scene(scene)
    z_plane = archives.plane_heights(scene)
    d_edges = archives.diameter_edges(scene)
    z_ref = archives.z_ref_eff(scene)
    full = scene.fidelity.outputs.full_snapshots
    dt_forced = scene.fidelity.saltation_dt_fixed

    loaded = load_checkpoint(checkpoint_path)
    if loaded is not None:
        ckpt, recorder, meta = loaded
        model = Model.from_scene(scene, saltation=True, restart=ckpt)
        t_act = float(meta["t_activation"])
        if getattr(model, "t_activation", None) is None:
            model.t_activation = t_act
        next_event, wall_before = int(meta["next_event"]), float(meta["wall_time_s"])
        last = (float(meta["last_dt"]), float(meta["last_cfl"]))
        n_steps = int(meta["n_steps"])
        resumed_from = _model_time(model) - t_act
    else:
        model = Model.from_scene(scene, saltation=True, restart=restart)
        model.activate_saltation()
        t_act = float(model.t_activation)
        recorder, next_event, wall_before, n_steps = Recorder(), 0, 0.0, 0
        last = (math.nan, math.nan)
        resumed_from = None

    t0_wall = time.perf_counter()
    last_ckpt_wall = t0_wall
    steps_here = 0

    def write_ckpt() -> None:
        save_checkpoint(checkpoint_path, model.checkpoint(), recorder, {
            "t_activation": t_act, "t_since_activation": _model_time(model) - t_act,
            "next_event": next_event, "n_steps": n_steps,
            "wall_time_s": wall_before + time.perf_counter() - t0_wall,
            "last_dt": last[0], "last_cfl": last[1]})

    # what activation released (a component may round scene.n_initial)
    n_released = int(getattr(model.components[0], "n_initial", 0)) if model.components else 0

    def record(groups: frozenset[str], t_rel: float) -> None:
        if "series" in groups:
            c = dpart.grain_counters(model)
            recorder.add("series", t_rel, {
                "n_parcels": c["n_parcels"], "n_impacts": c["n_impacts"],
                "n_rebounds": c["n_rebounds"], "n_ejections": c["n_ejections"],
                "n_depositions": c["n_depositions"], "G_tot_series": c["G_tot"],
                "u_star_ref": dflow.u_star_at(model, z_ref), "u_drive": model.state.u_drive,
                "dt": last[0], "max_cfl": last[1], "E_impact": c["E_impact"], "E_splash": c["E_splash"],
                "bed_px": c["bed_px"], "bed_pz": c["bed_pz"],
                **health.step_limits(model), **health.coupling_stiffness(model),
                "parcel_balance": health.parcel_balance(c, n_released)})
        if "plane" in groups:
            gp = dpart.grain_planes(model)
            fp = dflow.flow_planes(model, z_plane)
            recorder.add("plane", t_rel, {"C_p": gp["C_p"], "C_p_above": gp["C_p_above"],
                                          "G_col": gp["G_col"], "u_plane": fp["u_plane"]})
        if "sample" in groups:
            uc, vc, wc = dflow.cell_centred_velocity(model)
            fp = dflow.flow_profiles(model)
            gp = dpart.grain_profiles(model)
            rec = {"u": uc.astype(np.float32), "v": vc.astype(np.float32), "w": wc.astype(np.float32),
                   "e": model.state.e.astype(np.float32),
                   "C_p_s": dpart.grain_planes(model)["C_p"],
                   "uw_res": fp["uw_res"], "uw_sgs": fp["uw_sgs"], "u_mean": fp["u"],
                   "tke_res": fp["tke_res"], "e_sgs": fp["e_sgs"], "eps_sgs": fp["eps_sgs"],
                   "sgs_transfer": fp["sgs_transfer"],
                   "size_hist": dpart.grain_size_hist(model, d_edges),
                   **dpart.impact_record(model)}
            missing = [k for k in archives.GRAIN_PROFILES if k not in gp]
            if missing:
                raise KeyError(f"grain_profiles() lacks {missing} required by samples.nc")
            rec.update({k: gp[k] for k in archives.GRAIN_PROFILES})
            if full:
                rec["p"] = model.state.p.astype(np.float32)
            recorder.add("sample", t_rel, rec)

    try:
        events = schedule.events
        while next_event < len(events):
            t_event, groups = events[next_event]
            target = t_act + t_event
            while _model_time(model) - t_act < t_event - TIME_EPS:
                dt = model.next_dt(limit=target - _model_time(model))
                if dt_forced is not None:
                    dt = min(dt_forced, target - _model_time(model))
                info = model.step(dt)
                last = (float(info.dt), float(info.max_cfl))
                n_steps += 1
                steps_here += 1
                if progress is not None:
                    progress(_model_time(model) - t_act, schedule.duration)
                now = time.perf_counter()
                hook = interrupt_after_steps is not None and steps_here >= interrupt_after_steps
                if now - last_ckpt_wall >= interval or hook:
                    write_ckpt()
                    last_ckpt_wall = time.perf_counter()
                if hook:
                    raise Interrupted(f"test hook: stopped after {steps_here} steps")
            record(groups, t_event)
            next_event += 1
    finally:
        close = getattr(model, "close", None)
        if close is not None:
            close()

    return SaltationResult(
        records={g: recorder.stacked(g) for g in GROUPS}, grid=model.state.grid, z_plane=z_plane,
        d_edges=d_edges, t_activation=t_act, wall_time_s=wall_before + time.perf_counter() - t0_wall,
        n_steps=n_steps, resumed_from=resumed_from)
