"""Fill the report's ``meta`` from the study configuration and the workflow's records.

``build_report`` works from what it is given. When it is called by the workflow (or the CLI) with
``meta["out_dir"]`` and ``meta["keys"]`` (label -> {"spinup", "saltation", "analysis"} cache keys),
this module adds, where absent:

* ``case_numbers``, ``fidelities``, ``study_config`` and ``fidelity``: from the study file
  (``meta["study_file"]``, else ``workflows/<study>.toml``; saltstudy.config), if it exists;
* ``failures``: label -> error of the first failed task of the run (its ``task.json``);
* ``samples``: label -> ``samples.nc`` of the run, if present (stability report, animation);
* ``source_key``: the solver-source key the archives were computed with (their ``task.json``), one
  string when they agree, else the sorted distinct keys: a report redrawn later by ``figures``
  names the code that made its numbers, not only the code that drew them (``commit``).

Paths come from :mod:`saltstudy.workflow.paths`, imported lazily; without it these are skipped.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

__all__ = ["enrich_meta", "study_meta"]


def study_meta(study_ref: str) -> dict[str, Any]:
    """case_numbers, fidelities, study_config, fidelity, order, reference from the study file
    (``study_ref``: a study's name, or the path of its file).

    ``reference`` is the label of the run at the study's ``reference`` fidelity (None when the
    study names none: the convergence report then compares with the last rung). {} if no file.
    """
    try:
        from ..config import load_study, study_runs
        study = load_study(study_ref)
        runs = study_runs(study)
    except Exception:
        return {}
    ladder = list(study.fidelities) or ([study.fidelity] if study.fidelity else [])
    order = []
    if len(ladder) > 1:  # declared ladder order, coarse -> fine as listed in the study file
        for fname in ladder:
            order += [r.label for r in runs if r.label.endswith(f"@{fname}")]
    reference = None
    if study.reference:
        reference = next((r.label for r in runs if r.label.endswith(f"@{study.reference}")), None)
    return {
        "case_numbers": {r.label: r.scene.case.number for r in runs},
        "fidelities": {r.label: r.scene.fidelity.name for r in runs},
        "study_config": study.model_dump(mode="json"),
        "fidelity": study.fidelity or (", ".join(ladder) if ladder else None),
        "order": order or None,
        "reference": reference,
        "has_scenes": bool(study.scenes),
        "expect_blowup": sorted(sc.label for sc in study.scenes if sc.expect == "blow-up"),
    }


def _task_json(out_dir: Path, task: str, key: str) -> dict[str, Any]:
    try:
        from ..workflow.paths import task_dir
        p = Path(task_dir(out_dir, task, key)) / "task.json"
    except Exception:
        p = Path(out_dir) / task / key / "task.json"
    try:
        return json.loads(p.read_text())
    except (OSError, ValueError):
        return {}


def enrich_meta(study_name: str, runs: dict[str, Any], meta: dict[str, Any] | None) -> dict[str, Any]:
    meta = dict(meta or {})
    for k, v in study_meta(meta.get("study_file") or study_name).items():
        if meta.get(k) is None and v is not None:
            meta[k] = v
    out_dir, keys = meta.get("out_dir"), meta.get("keys")
    if not out_dir or not isinstance(keys, dict):
        return meta
    out_dir = Path(out_dir)
    failures = dict(meta.get("failures") or {})
    checkpoints: dict[str, dict] = {}
    samples = dict(meta.get("samples") or {})
    made_by: set[str] = set()
    for label, k in keys.items():
        if not isinstance(k, dict):
            continue
        for task in ("spinup", "saltation", "analysis"):
            key = k.get(task)
            if not key:
                continue
            tj = _task_json(out_dir, task, key)
            if task != "analysis" and tj.get("source_key"):
                made_by.add(str(tj["source_key"]))
            if tj.get("state") == "failed" and label not in failures:
                failures[label] = f"{task}: {tj.get('error', 'failed')}"
        skey = k.get("saltation")
        ck = _checkpoint(out_dir, skey) if skey else None
        if ck is not None:
            checkpoints[label] = ck
        if skey and label not in samples:
            try:
                from ..workflow.paths import output_path
                p = Path(output_path(out_dir, "saltation", skey))
            except Exception:
                p = out_dir / "saltation" / skey / "samples.nc"
            if p.is_file():
                samples[label] = str(p)
    if failures:
        meta["failures"] = failures
    if samples:
        meta["samples"] = samples
    if checkpoints:
        meta["checkpoints"] = checkpoints
    if not meta.get("commit"):
        meta["commit"] = _commit()
    if not meta.get("source_key") and made_by:
        meta["source_key"] = made_by.pop() if len(made_by) == 1 else sorted(made_by)
    return meta


def _checkpoint(out_dir: Path, key: str) -> dict[str, Any] | None:
    """{"path", "t_since_activation"} of a saltation run's kept checkpoint, or None."""
    try:
        from ..workflow.paths import task_dir
        p = Path(task_dir(out_dir, "saltation", key)) / "checkpoint.npz"
    except Exception:
        p = Path(out_dir) / "saltation" / key / "checkpoint.npz"
    if not p.is_file():
        return None
    t = None
    try:
        import numpy as np
        with np.load(p, allow_pickle=False) as z:
            t = float(json.loads(str(z["meta"])).get("t_since_activation"))
    except Exception:
        pass
    return {"path": str(p), "t_since_activation": t}


def _commit() -> str | None:
    """The checkout's commit (with "+dirty" if tracked files differ from it), or None."""
    import subprocess
    root = Path(__file__).resolve().parent.parent.parent
    try:
        sha = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True,
                             text=True, timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10, check=True).stdout.strip()
    except Exception:
        return None
    return sha + ("+dirty" if dirty else "") if sha else None
