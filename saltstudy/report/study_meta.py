"""Fill the report's ``meta`` from the study file (``meta["study_file"]``, else the study's name)
and the checkout's ``commit``; what the cache records about the runs comes from the workflow
(``workflow/report_meta.py``), which passes it in ``meta``.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["enrich_meta", "study_meta"]


def study_meta(study_ref: str) -> dict[str, Any]:
    """The report's meta from the study file (``study_ref``: a study's name or its file's path);
    ``reference``: the label of the run at the study's ``reference`` fidelity (None when the study
    names none: the convergence report compares with the last rung). {} if no file."""
    try:
        from ..config import ladder_table_path, load_study, study_runs
        study = load_study(study_ref)
        runs = study_runs(study)
    except Exception:
        return {}
    ladder = list(study.fidelities) or ([study.fidelity] if study.fidelity else [])
    # the declared ladder's order, coarse -> fine as listed in the study file
    order = ([r.label for f in ladder for r in runs if r.label.endswith(f"@{f}")]
             if len(ladder) > 1 else [])
    reference = (next((r.label for r in runs if r.label.endswith(f"@{study.reference}")), None)
                 if study.reference else None)
    return {
        "case_numbers": {r.label: r.scene.case.number for r in runs},
        "fidelities": {r.label: r.scene.fidelity.name for r in runs},
        "study_config": study.model_dump(mode="json"),
        "fidelity": study.fidelity or (", ".join(ladder) if ladder else None),
        "order": order or None,
        "reference": reference,
        "has_scenes": bool(study.scenes),
        "expect_blowup": sorted(sc.label for sc in study.scenes if sc.expect == "blow-up"),
        "ladder_table": str(table) if (table := ladder_table_path(study)) else None,
    }


def enrich_meta(study_name: str, meta: dict[str, Any] | None) -> dict[str, Any]:
    """``meta`` with the study file's entries (``study_meta``) and the commit added where absent."""
    meta = dict(meta or {})
    for k, v in study_meta(meta.get("study_file") or study_name).items():
        if meta.get(k) is None and v is not None:
            meta[k] = v
    if not meta.get("commit"):
        meta["commit"] = _commit()
    return meta


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
