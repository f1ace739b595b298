"""Where the workflow keeps its outputs.

The out dir (cache) is ``$SALTSTUDY_OUT``, else ``<project root>/.saltstudy-cache``; every CLI
command takes ``--out DIR``. Layout (``<key>``: :mod:`saltstudy.workflow.keys`)::

    <out>/spinup/<key>/spinup.nc          flow-only spin-up (restart state + profiles)
    <out>/saltation/<key>/samples.nc      saltation run records (+ checkpoint.npz while running)
    <out>/analysis/<key>/analysis.nc      statistics of one case
    <out>/report/<key>/task.json          marker of a built report (the report: reports/<study>/)
    <out>/<task>/<key>/task.json|progress.json   what the task was; live progress
    <out>/studies/<study>/runs.json       label -> keys of the last completed tasks of each run
"""
from __future__ import annotations

import json
import os
from pathlib import Path

from ..config import Study, load_study, project_root
from ..faults import write_atomic

#: the archive each task writes into its directory
OUTPUT_NAMES = {"spinup": "spinup.nc", "saltation": "samples.nc", "analysis": "analysis.nc",
                "report": "task.json"}


def default_out_dir() -> Path:
    """The cache directory: ``$SALTSTUDY_OUT``, else ``<project root>/.saltstudy-cache``."""
    env = os.environ.get("SALTSTUDY_OUT")
    return Path(env).expanduser() if env else project_root() / ".saltstudy-cache"


def default_report_dir(study_name: str) -> Path:
    """Where a study's report is built: ``<project root>/reports/<study>`` (see reports/README.md)."""
    return project_root() / "reports" / study_name


def task_dir(out_dir: Path, task: str, key: str) -> Path:
    return Path(out_dir) / task / key


def output_path(out_dir: Path, task: str, key: str) -> Path:
    """The archive of task ``task`` with cache key ``key``."""
    return task_dir(out_dir, task, key) / OUTPUT_NAMES[task]


def study_dir(out_dir: Path, study_name: str) -> Path:
    return Path(out_dir) / "studies" / study_name


def runs_file(out_dir: Path, study_name: str) -> Path:
    return study_dir(out_dir, study_name) / "runs.json"


def read_json(path: Path) -> dict | None:
    """A JSON file's content; None if absent or unreadable (being replaced, or cut short)."""
    try:
        return json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None


def read_runs_file(out_dir: Path, study_name: str) -> dict:
    """The study's record of last completed keys per label (empty if none or unreadable)."""
    return read_json(runs_file(out_dir, study_name)) or {}


def read_task_json(directory: Path) -> dict | None:
    return read_json(Path(directory) / "task.json")


def checkpoint_time(directory: Path) -> float | None:
    """The time [s since activation] a saltation task directory's ``checkpoint.npz`` resumes
    from; None if absent, unreadable or not recorded (a spin-up's)."""
    import numpy as np

    try:
        with np.load(Path(directory) / "checkpoint.npz", allow_pickle=False) as z:
            return float(json.loads(str(z["meta"]))["t_since_activation"])
    except Exception:
        return None


def write_json_atomic(path: Path, data: dict) -> None:
    """Write JSON to a temporary name and rename, so a reader never sees half a file."""
    text = json.dumps(data, indent=1, sort_keys=True, default=str)
    write_atomic(path, lambda tmp: tmp.write_text(text), len(text), sync=False)


def recorded_analysis_paths(study_name: str, labels: list[str], out_dir: Path
                            ) -> tuple[dict[str, Path | None], dict[str, dict[str, str]]]:
    """(label -> analysis.nc, label -> {task: key}) of the runs run-all last completed for
    ``labels`` (runs.json), whatever code made them; None where none is recorded or complete."""
    from ..ncio import is_complete

    recorded = read_runs_file(out_dir, study_name).get("labels", {})
    keys = {label: dict(recorded.get(label, {})) for label in labels}
    paths = {label: output_path(out_dir, "analysis", k["analysis"]) if k.get("analysis") else None
             for label, k in keys.items()}
    return {label: p if p is not None and is_complete(p) else None for label, p in paths.items()}, keys


def analysis_paths(study: Study | str | Path, out_dir: Path | None = None) -> dict[str, Path | None]:
    """Label -> analysis.nc of each run of ``study`` for the *current* configuration and code, None
    where missing or incomplete. Raises ConfigError for a bad study or case."""
    from . import keys as _keys
    from ..ncio import is_complete

    if not isinstance(study, Study):
        study = load_study(study)
    out_dir = Path(out_dir) if out_dir is not None else default_out_dir()
    paths = {run: output_path(out_dir, "analysis", k.analysis)
             for run, k in _keys.study_keys(study).items()}
    return {run: p if is_complete(p) else None for run, p in paths.items()}
