"""What the cache records about a study's runs, for its report (``report.build_report``'s
``meta``). Given ``meta["out_dir"]`` and ``meta["keys"]``, :func:`cache_meta` adds, where absent:
``failures`` (label -> first failed task's error), ``samples`` (label -> samples.nc),
``checkpoints`` (a stopped saltation run's checkpoint and time) and ``source_key`` (of the
archives' ``task.json``: one string, or the sorted distinct keys).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

from .._identity import __version__
from ..config import study_file
from .paths import checkpoint_time, output_path, read_task_json, task_dir


def study_meta(study, name: str, out_dir: Path, runs: dict) -> dict[str, Any]:
    """The report's meta of a study's runs (``keys.RunKeys`` by label) in the cache ``out_dir``:
    the cache keys let the report find failure records and samples.nc (stability, animation)."""
    sfile = study_file(study)
    return {"study": name, "out_dir": str(out_dir), "package_version": __version__,
            "study_file": str(sfile) if sfile is not None else None,
            "keys": {label: {t: getattr(rk, t) for t in ("spinup", "saltation", "analysis")}
                     for label, rk in runs.items()}}


def cache_meta(meta: dict[str, Any] | None) -> dict[str, Any]:
    """``meta`` with what the cache records about its runs added where absent (module doc)."""
    meta = dict(meta or {})
    out_dir, keys = meta.get("out_dir"), meta.get("keys")
    if not out_dir or not isinstance(keys, dict):
        return meta
    out_dir = Path(out_dir)
    failures = dict(meta.get("failures") or {})
    checkpoints: dict[str, dict] = {}
    samples = dict(meta.get("samples") or {})
    made_by: set[str] = set()
    for label, k in keys.items():
        for task in ("spinup", "saltation", "analysis"):
            key = k.get(task)
            if not key:
                continue
            tj = read_task_json(task_dir(out_dir, task, key)) or {}
            if task != "analysis" and tj.get("source_key"):
                made_by.add(str(tj["source_key"]))
            if tj.get("state") == "failed" and label not in failures:
                failures[label] = f"{task}: {tj.get('error', 'failed')}"
        skey = k.get("saltation")
        if skey:
            d, samples_nc = task_dir(out_dir, "saltation", skey), output_path(out_dir, "saltation", skey)
            if (d / "checkpoint.npz").is_file():   # a stopped run's, kept to resume from
                checkpoints[label] = {"path": str(d / "checkpoint.npz"),
                                      "t_since_activation": checkpoint_time(d)}
            if label not in samples and samples_nc.is_file():
                samples[label] = str(samples_nc)
    meta.update({k: v for k, v in (("failures", failures), ("samples", samples),
                                   ("checkpoints", checkpoints)) if v})
    if not meta.get("source_key") and made_by:
        meta["source_key"] = made_by.pop() if len(made_by) == 1 else sorted(made_by)
    return meta

