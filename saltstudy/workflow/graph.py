"""The dask graph of a study and its execution (docs/USAGE.md, "On a cluster").

Per run: spin-up -> saltation -> analysis; one report task over all runs, keyed by cache key, so
runs with an equal spin-up key share one spin-up task. Locally, dask's threaded scheduler runs
``workers`` tasks at once (default 1: on 2 cores one flow step on 2 numba threads is 1.74x faster
than on 1, ``NUMBA_NUM_THREADS=1|2 saltstudy bench flow --no-big``); with more than one, a
running solver task takes cores // (tasks running now) as others start and end
(``workflow/cores.py``): a study's shared spin-up, which every other task waits for, or its last
saltation run gets every core. A failed task is recorded (``task.json``) and its dependents
skipped; the other runs go on, except after a full disk (``faults.DiskFull``), when a local run
starts no further task.
"""
from __future__ import annotations

import time
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .._identity import SOURCE_KEY, __version__
from ..config import Scene, Study
from ..faults import DiskFull
from . import cores
from ..ncio import is_complete
from . import keys as K
from .paths import (default_report_dir, output_path, read_runs_file, runs_file, study_dir, task_dir,
                    write_json_atomic)
from .progress import ProgressDisplay, TaskRef, emit
from .report_meta import study_meta
from .lock import hold_out_dir
from .tasks import (analysis_task, continuation_task, report_done, report_task, saltation_task,
                    spinup_task, tidy_leftovers)
from .warmup import ensure_warm


@dataclass
class Outcome:
    """What one task did: ``computed``, ``cached`` (complete output found), ``failed`` or
    ``skipped`` (an input failed, or a full disk stopped a local run)."""
    task: str
    key: str
    labels: list[str]
    status: str
    path: str | None = None
    error: str | None = None
    wall_s: float = 0.0

    @property
    def ok(self) -> bool:
        return self.status in ("computed", "cached")


class _DiskFullStop:
    """In a local run, the first full disk stops the tasks not yet started (their archives could
    not be written); armed by :func:`run_study` for a local run only."""
    armed = False
    error: str | None = None


def _call(task: str, key: str, labels: list[str], out_path: Path, fn, *args, **kw) -> Outcome:
    """Run one task function, turning any error into a failed Outcome (the graph goes on)."""
    name = f"{task} {','.join(labels)}"
    if task != "report" and is_complete(out_path):
        return Outcome(task, key, labels, "cached", str(out_path))
    if _DiskFullStop.error is not None:
        return Outcome(task, key, labels, "skipped", None, f"not run: {_DiskFullStop.error}")
    emit(f"[start] {name} ({key})")
    t0 = time.perf_counter()
    try:
        path = fn(*args, **kw)
    except BaseException as exc:  # noqa: BLE001 — record everything, incl. KeyboardInterrupt
        wall = time.perf_counter() - t0
        emit(f"[FAILED] {name}: {type(exc).__name__}: {exc}")
        if not isinstance(exc, Exception):
            raise
        if isinstance(exc, DiskFull) and _DiskFullStop.armed:
            _DiskFullStop.error = str(exc)
        return Outcome(task, key, labels, "failed", None, f"{type(exc).__name__}: {exc}", wall)
    wall = time.perf_counter() - t0
    emit(f"[done] {name} in {wall:.1f} s")
    return Outcome(task, key, labels, "computed", str(path), None, wall)


#: the folder of each task's archive (a staggered start's link is a spin-up archive)
_FOLDER = {"continuation": "spinup"}


def _node(task: str, key: str, labels: list[str], out_dir: Path, share_cores: bool, fn,
          *args) -> Outcome:
    """``fn(*args)`` as one task of the graph, each Outcome among ``args`` handed over as its
    archive; skipped if one of those failed. ``share_cores``: counted among the tasks sharing
    the cores (``workflow/cores.py``)."""
    failed = [a.task for a in args if isinstance(a, Outcome) and not a.ok]
    if failed:
        return Outcome(task, key, labels, "skipped", error=f"{' and '.join(failed)} failed")
    path = output_path(out_dir, _FOLDER.get(task, task), key)
    inputs = [Path(a.path) if isinstance(a, Outcome) else a for a in args]
    if not share_cores:
        return _call(task, key, labels, path, fn, *inputs)
    with cores.running():
        return _call(task, key, labels, path, fn, *inputs)


def _report(study: Study, analyses: list[tuple[str, Outcome]], out_dir: Path, report_dir: Path,
            meta: dict[str, Any]) -> Outcome:
    """The study's report over (label, analysis outcome) pairs: two labels of the same physics
    share one outcome."""
    runs = {label: (Path(a.path) if a.ok else None) for label, a in analyses}
    rkey = K.report_key(study, {label: (a.key if a.ok else None) for label, a in analyses})
    if report_done(out_dir, rkey, report_dir):
        return Outcome("report", rkey, [study.name], "cached", str(report_dir))
    return _call("report", rkey, [study.name], Path(report_dir), report_task, study, runs, out_dir,
                 report_dir, rkey, meta)


def run_case(rk: "K.RunKeys", out_dir: Path, wait: bool = False) -> list[Outcome]:
    """One run's tasks in order, in this process (``saltstudy run``), the out dir held as by
    :func:`run_study`; returns [spin-up, saltation, analysis]."""
    with hold_out_dir(out_dir, wait=wait, log=emit):
        _tidy(out_dir, [rk])
        scene, labels = rk.scene, [rk.label]
        sp = st = _node("spinup", rk.spinup, labels, out_dir, None, spinup_task, scene, out_dir,
                        SOURCE_KEY)
        for link in rk.links:     # a staggered start: its continuation links in order
            st = _node("continuation", link, labels, out_dir, None, continuation_task, scene, st,
                       out_dir, link, SOURCE_KEY)
        sa = _node("saltation", rk.saltation, labels, out_dir, None, saltation_task, scene, st,
                   out_dir, SOURCE_KEY)
        an = _node("analysis", rk.analysis, labels, out_dir, None, analysis_task, sa, st, out_dir,
                   rk.analysis)
    return [sp, sa, an]


def run_scene(scene: Scene, out_dir: Path, quiet: bool = False) -> tuple["K.RunKeys", list[Outcome]]:
    """One scene's run as ``saltstudy run`` makes it (kernels warmed, progress displayed)."""
    rk = K.run_keys(scene.label, scene)
    refs = [TaskRef(f"{task} {rk.label}", task_dir(out_dir, task, getattr(rk, task)))
            for task in ("spinup", "saltation")]
    with ProgressDisplay(refs, quiet=quiet):
        warm_for([rk], out_dir)
        return rk, run_case(rk, Path(out_dir))


@dataclass
class StudyPlan:
    study: Study
    runs: dict[str, K.RunKeys]
    graph: dict[str, Any]            # final dask.delayed objects by name
    task_refs: list[TaskRef]
    report_dir: Path


def build_graph(study: Study, out_dir: Path, report_dir: Path | None = None,
                share_cores: bool = False, root: Path | None = None,
                run_started: float | None = None) -> StudyPlan:
    """dask.delayed graph of ``study``; raises ConfigError. ``run_started`` (epoch s) is the
    origin of the report's ``total_wall_time_s``."""
    import dask

    out_dir = Path(out_dir)
    report_dir = Path(report_dir) if report_dir else default_report_dir(study.name)
    runs = K.study_keys(study, root)
    node = dask.delayed(_node, pure=False)
    spin_nodes, salt_nodes, an_nodes, finals = {}, {}, {}, {}   # dask.delayed by key or name
    refs: list[TaskRef] = []
    analyses = []
    sharing: dict[str, list[str]] = {}
    for label, rk in runs.items():
        sharing.setdefault(rk.spinup, []).append(label)
    for label, rk in runs.items():
        if rk.spinup not in spin_nodes:
            spin_nodes[rk.spinup] = node(
                "spinup", rk.spinup, sharing[rk.spinup], out_dir, share_cores, spinup_task,
                rk.scene, out_dir, SOURCE_KEY, dask_key_name=f"spinup-{rk.spinup}")
            refs.append(TaskRef(f"spinup {'+'.join(sharing[rk.spinup])}",
                                task_dir(out_dir, "spinup", rk.spinup)))
        sp = spin_nodes[rk.spinup]
        # a staggered start: the chain of continuation links, each shared by the cases after it
        for link in rk.links:
            if link not in spin_nodes:
                spin_nodes[link] = node(
                    "continuation", link, [rk.label], out_dir, share_cores, continuation_task,
                    rk.scene, sp, out_dir, link, SOURCE_KEY, dask_key_name=f"continuation-{link}")
                refs.append(TaskRef(f"continuation {rk.label}", task_dir(out_dir, "spinup", link)))
            sp = spin_nodes[link]
        # scenes of the same physics under two labels share one run (its key leaves names out)
        if rk.saltation not in salt_nodes:
            salt_nodes[rk.saltation] = node(
                "saltation", rk.saltation, [label], out_dir, share_cores, saltation_task,
                rk.scene, sp, out_dir, SOURCE_KEY,
                dask_key_name=f"saltation-{rk.saltation}-{label}")
            an_nodes[rk.analysis] = node(
                "analysis", rk.analysis, [label], out_dir, None, analysis_task,
                salt_nodes[rk.saltation], sp, out_dir, rk.analysis,
                dask_key_name=f"analysis-{rk.analysis}-{label}")
            refs.append(TaskRef(f"saltation {label}", task_dir(out_dir, "saltation", rk.saltation)))
        sa, an = salt_nodes[rk.saltation], an_nodes[rk.analysis]
        finals[f"spinup:{label}"] = sp
        finals[f"saltation:{label}"] = sa
        finals[f"analysis:{label}"] = an
        analyses.append((label, an))
    # which of the study's distinct tasks this run finds done: a stopwatch of a run-all means
    # the study's cost only when none was (summary.json "tasks_from_cache")
    distinct = ({("spinup", r.spinup) for r in runs.values()}
                | {("spinup", k) for r in runs.values() for k in r.links}
                | {(t, getattr(r, t)) for r in runs.values() for t in ("saltation", "analysis")})
    cached = sum(is_complete(output_path(out_dir, t, key)) for t, key in distinct)
    if study.report:
        meta = {**study_meta(study, study.name, out_dir, runs), "source_key": SOURCE_KEY,
                "run_started": run_started, "tasks_from_cache": cached,
                "tasks_total": len(distinct)}
        finals["report"] = dask.delayed(_report, pure=False)(study, analyses, out_dir, report_dir,
                                                             meta, dask_key_name=f"report-{study.name}")
    return StudyPlan(study, runs, finals, refs, report_dir)


@dataclass
class StudySummary:
    study: str
    outcomes: list[Outcome] = field(default_factory=list)
    report_dir: Path | None = None
    wall_s: float = 0.0
    expect_blowup: frozenset[str] = frozenset()

    def _blew_up_as_expected(self, o: Outcome) -> bool:
        return (o.task == "saltation" and bool(set(o.labels) & self.expect_blowup)
                and (o.error or "").startswith("SolverBlowUp"))

    @property
    def failed(self) -> list[Outcome]:
        return [o for o in self.outcomes if o.status == "failed" and not self._blew_up_as_expected(o)]

    @property
    def expected_blowups(self) -> list[Outcome]:
        return [o for o in self.outcomes if o.status == "failed" and self._blew_up_as_expected(o)]

    @property
    def unexpected_completions(self) -> list[str]:
        """Scenes that should have blown up but whose saltation run completed."""
        return sorted(l for o in self.outcomes if o.task == "saltation" and o.ok
                      for l in o.labels if l in self.expect_blowup)

    @property
    def computed(self) -> list[Outcome]:
        return [o for o in self.outcomes if o.status == "computed"]

    @property
    def solver_work(self) -> bool:
        return any(o.task in ("spinup", "saltation") for o in self.computed)

    @property
    def exit_code(self) -> int:
        # a task skipped because its input failed implies a failure already counted
        return 1 if (self.failed or self.unexpected_completions) else 0


def _record_runs(out_dir: Path, plan: StudyPlan, by_name: dict[str, Outcome]) -> None:
    """Update runs.json: for each label, the keys of its tasks that completed (last good)."""
    data = read_runs_file(out_dir, plan.study.name)
    labels = data.get("labels", {})
    for label in plan.runs:
        entry = labels.get(label, {})
        for task in ("spinup", "saltation", "analysis"):
            o = by_name.get(f"{task}:{label}")
            if o is not None and o.ok:
                entry[task] = o.key
        labels[label] = entry
    # keep only the labels the study names
    data.update({"study": plan.study.name, "labels": {l: labels[l] for l in plan.runs},
                 "updated": time.time(), "package_version": __version__})
    rep = by_name.get("report")
    if rep is not None and rep.ok:
        data["report"] = {"key": rep.key, "dir": rep.path}
    write_json_atomic(runs_file(out_dir, plan.study.name), data)


def _pending_scenes(runs, out_dir: Path) -> list[Scene]:
    return [rk.scene for rk in runs
            if not (is_complete(output_path(out_dir, "saltation", rk.saltation))
                    and is_complete(output_path(out_dir, "spinup", rk.spinup)))]


def warm_for(runs, out_dir: Path) -> None:
    """Compile the kernels of the runs that still need solver work (warmup.py)."""
    ensure_warm(_pending_scenes(runs, out_dir), log=emit)


def _warm_here(scenes: list[Scene]) -> str:
    """Run on a dask worker: warm that machine's numba cache (warmup.py) for ``scenes``."""
    import platform

    ensure_warm(scenes)
    return platform.node()


def warm_workers(client, runs, out_dir: Path) -> None:
    """:func:`warm_for` on a ``dask.distributed`` cluster, once per worker host (warmup.py)."""
    scenes = _pending_scenes(runs, out_dir)
    if not scenes:
        return
    from distributed.comm import get_address_host

    hosts: dict[str, str] = {}
    for addr in client.nthreads():          # every worker's address
        hosts.setdefault(get_address_host(addr), addr)
    if not hosts:   # no worker yet: workers that join later compile for themselves
        return
    emit(f"[warm-up] numba kernels on {len(hosts)} worker host(s)")
    futures = [client.submit(_warm_here, scenes, workers=[addr], allow_other_workers=False, pure=False)
               for addr in hosts.values()]
    try:
        client.gather(futures)
    except Exception as exc:  # noqa: BLE001 — the tasks then compile in-process, as without it
        emit(f"[warm-up] on the workers failed ({type(exc).__name__}: {exc}); tasks compile in-process")


def _tidy(out_dir: Path, runs, study_name: str | None = None) -> None:
    """Remove what killed processes left in the task directories of ``runs`` and the study's
    record folder (locks, temporary files, a checkpoint beside a complete archive). Called with
    the out dir held."""
    for rk in runs:
        for task, key in (("spinup", rk.spinup), *(("spinup", k) for k in rk.links),
                          ("saltation", rk.saltation), ("analysis", rk.analysis)):
            tidy_leftovers(task_dir(out_dir, task, key), output_path(out_dir, task, key))
    if study_name is not None:
        for tmp in study_dir(out_dir, study_name).glob("*.tmp"):
            tmp.unlink(missing_ok=True)
        for d in Path(out_dir).glob("report/*"):
            tidy_leftovers(d, None)


def run_study(study: Study, out_dir: Path, workers: int = 1, scheduler: str | None = None,
              quiet: bool = False, report_dir: Path | None = None, root: Path | None = None,
              started: float | None = None, wait: bool = False) -> StudySummary:
    """Build and execute the study's graph; never raises for a failed task (see summary).

    The out dir is held (``lock.hold_out_dir``): another holder raises ``lock.Busy``, or with
    ``wait`` is waited for. ``started`` (epoch s, default now) is the origin of the report's wall
    time; time spent waiting for the out dir is not counted."""
    started = time.time() if started is None else float(started)
    with hold_out_dir(out_dir, wait=wait, log=emit) as lock:
        if lock.waited_s > 1.0:
            started = time.time()
        _DiskFullStop.armed, _DiskFullStop.error = scheduler is None, None
        try:
            return _run_study(study, out_dir, workers, scheduler, quiet, report_dir, root, started)
        finally:
            _DiskFullStop.armed, _DiskFullStop.error = False, None


def _run_study(study: Study, out_dir: Path, workers: int, scheduler: str | None, quiet: bool,
               report_dir: Path | None, root: Path | None, started: float) -> StudySummary:
    import dask

    share_cores = scheduler is None and workers > 1
    plan = build_graph(study, out_dir, report_dir, share_cores, root, run_started=started)
    names = list(plan.graph)
    study_dir(out_dir, study.name).mkdir(parents=True, exist_ok=True)
    _tidy(out_dir, plan.runs.values(), study.name)
    results: dict[str, Outcome] = {}
    with ProgressDisplay(plan.task_refs, quiet=quiet):
        if scheduler is None:
            warm_for(plan.runs.values(), out_dir)
            with (cores.sharing() if share_cores else nullcontext()):
                values = dask.compute(*[plan.graph[n] for n in names], scheduler="threads",
                                      num_workers=workers)
            results = dict(zip(names, values))
        else:
            from distributed import Client

            with Client(scheduler) as client:
                warm_workers(client, plan.runs.values(), out_dir)
                futures = client.compute([plan.graph[n] for n in names])
                for n, f in zip(names, futures):
                    try:
                        results[n] = f.result()
                    except Exception as exc:  # a worker died (killed, out of memory, ...)
                        error = f"{type(exc).__name__}: {exc}"
                        if type(exc).__name__ == "KilledWorker":
                            error += (" (the workers running it died: killed, out of memory or "
                                      "their node lost; rerun the command: a spin-up or saltation "
                                      "run resumes from its last checkpoint)")
                        results[n] = Outcome(n.split(":")[0], "?", [n.split(":")[-1]], "failed",
                                             error=error)
    try:
        _record_runs(out_dir, plan, results)
    except OSError as exc:   # a full disk: the archives are what counts, the record is a summary
        emit(f"[warning] {runs_file(out_dir, study.name)} not updated: {exc}")
    # shared spin-ups appear once per label in `results`: report each task once
    seen: dict[tuple[str, str], Outcome] = {}
    for n in names:
        o = results[n]
        seen.setdefault((o.task, o.key if o.key != "?" else n), o)
    rep = results.get("report")
    return StudySummary(study.name, list(seen.values()),
                        Path(rep.path) if rep is not None and rep.ok else None,
                        time.time() - started,
                        frozenset(s.label for s in study.scenes if s.expect == "blow-up"))
