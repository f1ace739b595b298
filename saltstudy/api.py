"""The study from Python: load and change a case, run it, read the results as xarray objects,
through the workflow of ``saltstudy run-all`` and ``run`` (same cache, resume and progress
display); the names are importable from ``saltstudy`` (examples: docs/USAGE.md, "From Python").
Lengths in m, times in s, velocities in m s-1, as in the archives.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Mapping

import xarray as xr

from .config import (Case, Fidelity, Scene, Study, load_case, load_fidelity,
                     load_study, resolve_scene)
from .ncio import is_complete, open_dataset, open_lazy
from .workflow import keys as K
from .workflow.graph import Outcome, StudySummary, run_scene
from .workflow.graph import run_study as _run_study_graph
from .workflow.paths import default_out_dir, output_path

PathLike = str | os.PathLike


def _out(out: PathLike | None) -> Path:
    return Path(out).expanduser() if out is not None else default_out_dir()


def _loaded(value, model, load):
    """``value`` if it is a ``model`` already, else ``load(value)`` (a number, name or file)."""
    return value if isinstance(value, model) else load(value)


@dataclass
class Run:
    """One run in the cache: a case at a fidelity, under its label; ``paths`` names its archives
    (existing or not), ``outcomes`` what each task did when the run was made from here."""
    label: str
    scene: Scene
    keys: K.RunKeys
    out: Path
    outcomes: list[Outcome] = field(default_factory=list)

    @classmethod
    def of(cls, scene: Scene, out: PathLike | None = None, label: str | None = None) -> "Run":
        """The run of ``scene`` in the cache ``out`` (computed or not)."""
        label = label or scene.label
        return cls(label, scene, K.run_keys(label, scene), _out(out))

    @property
    def case(self) -> Case:
        return self.scene.case

    @property
    def fidelity(self) -> Fidelity:
        return self.scene.fidelity

    @property
    def paths(self) -> dict[str, Path]:
        k = self.keys
        return {"spinup": output_path(self.out, "spinup", k.start),
                "samples": output_path(self.out, "saltation", k.saltation),
                "analysis": output_path(self.out, "analysis", k.analysis)}

    @property
    def ok(self) -> bool:
        """True once the run's analysis.nc is complete in the cache."""
        return is_complete(self.paths["analysis"])

    def _archive(self, name: str) -> Path:
        p = self.paths[name]
        if not is_complete(p):
            failed = [f"{o.task}: {o.error}" for o in self.outcomes if o.error]
            why = f" ({'; '.join(failed)})" if failed else ""
            raise FileNotFoundError(
                f"{self.label}: no complete {p.name} in {self.out} for this case, fidelity and "
                f"code{why}; run it (saltstudy.run, or run_study) or see `saltstudy status`")
        return p

    def analysis(self) -> xr.Dataset:
        """analysis.nc (every statistic of the run, SI units), read into memory."""
        return open_dataset(self._archive("analysis"))

    def samples(self) -> xr.Dataset:
        """samples.nc, opened lazily (dask); close it when done: ``with run.samples() as s:``."""
        return open_lazy(self._archive("samples"))

    def spinup(self) -> xr.Dataset:
        """spinup.nc (the particle-free flow the saltation starts from), opened lazily."""
        return open_lazy(self._archive("spinup"))


class Results:
    """Runs read together: a study's (:func:`open_results`, :func:`run_study`) or any runs
    (``Results([run_a, run_b])``); ``runs``: label -> :class:`Run`."""

    def __init__(self, runs: Iterable[Run] | Mapping[str, Run], study: str = "runs",
                 summary: StudySummary | None = None):
        items = runs.values() if isinstance(runs, Mapping) else runs
        self.runs: dict[str, Run] = {}
        for r in items:
            if r.label in self.runs:
                raise ValueError(f"two runs labelled {r.label!r}: give one a name "
                                 f"(case.replace(name=...))")
            self.runs[r.label] = r
        self.study = study
        #: what run_study did (outcomes, failures, where the report went); None when only opened
        self.summary = summary

    def __repr__(self) -> str:
        done = sum(r.ok for r in self.runs.values())
        return f"<Results {self.study}: {len(self.runs)} runs, {done} analysed: {', '.join(self.runs)}>"

    @property
    def labels(self) -> list[str]:
        return list(self.runs)

    def __getitem__(self, label: str) -> Run:
        try:
            return self.runs[label]
        except KeyError:
            raise KeyError(f"{label!r}: not a run of {self.study} (runs: {', '.join(self.runs)})") from None

    def analysis(self, label: str) -> xr.Dataset:
        return self[label].analysis()

    def samples(self, label: str) -> xr.Dataset:
        return self[label].samples()

    def spinup(self, label: str) -> xr.Dataset:
        return self[label].spinup()

    def table2(self) -> xr.Dataset:
        """Table 2 as the report shows it, along ``run``, with the paper's values beside the
        paper's cases (``report.tables.table2_dataset``; ``.to_dataframe()`` for pandas)."""
        from .report.data import ReportContext, load_runs
        from .report.tables import table2_dataset

        paths = {label: (r.paths["analysis"] if r.ok else None) for label, r in self.runs.items()}
        return table2_dataset(ReportContext(self.study, load_runs(paths)))


def run(case: Case | int | PathLike, fidelity: Fidelity | PathLike, out: PathLike | None = None,
        label: str | None = None, quiet: bool = True) -> Run:
    """Run one case at one fidelity in this process as ``saltstudy run`` does (cached, resumed).
    ``case``: a :class:`Case`, number or file; ``fidelity``: a :class:`Fidelity`, name or file;
    ``out``: the cache (default ``$SALTSTUDY_OUT``); ``label``: the run's name. A failed task
    does not raise: ``Run.outcomes`` holds its error. ``quiet=False`` shows the progress."""
    c = _loaded(case, Case, load_case)
    c = c.replace(name=label) if label else c         # the archives' label, as a study's scene
    scene = resolve_scene(c, _loaded(fidelity, Fidelity, load_fidelity))
    r = Run.of(scene, out)
    _, r.outcomes = run_scene(scene, r.out, quiet=quiet)
    return r


def _runs_of(study: Study, out: Path) -> dict[str, Run]:
    return {label: Run(label, rk.scene, rk, out) for label, rk in K.study_keys(study).items()}


def run_study(study: Study | PathLike, out: PathLike | None = None, workers: int = 1,
              quiet: bool = True, report_dir: PathLike | None = None) -> Results:
    """Run a study (a name, file or :class:`Study`) as ``saltstudy run-all`` does, the report in
    ``report_dir`` (default ``reports/<study>``), and open its results. Failed tasks do not raise:
    ``Results.summary`` lists them."""
    started = time.time()
    st, out_dir = _loaded(study, Study, load_study), _out(out)
    runs = _runs_of(st, out_dir)            # a bad case reference raises before anything runs
    summary = _run_study_graph(st, out_dir, workers=workers, quiet=quiet,
                               report_dir=Path(report_dir) if report_dir is not None else None,
                               started=started)
    return Results(runs, st.name, summary)


def open_results(study: Study | PathLike, out: PathLike | None = None) -> Results:
    """A study's runs in the cache ``out`` for the current configuration and code, without running
    anything: ``Run.ok`` says which are there."""
    st = _loaded(study, Study, load_study)
    return Results(_runs_of(st, _out(out)), st.name)
