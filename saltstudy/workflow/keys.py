"""Cache keys: a task's output directory is named by the hash of everything that determines it.

key = SHA-256 of the sorted-key JSON of the task's configuration slice, its inputs' keys, the
package version and ``SOURCE_KEY`` (numerics: ``_jit.py``, ``physics/``, ``solver/``; plus
``analysis/`` or ``report/`` sources for those tasks), and :data:`ARCHIVE_FORMAT` (bumped by hand
when an archive's content changes). Never Python's ``hash()`` (PYTHONHASHSEED); pydantic dumps
with ``mode="json"``. Left out on purpose: descriptions, names (the same physics at the same cost
is one run in any study) and ``checkpoint_interval_wall`` (resume is bit for bit).
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

from .._identity import SOURCE_KEY, __version__
from ..config import Scene, Study, content_hash, equilibrium_roughness, study_runs

#: bump when spinup.nc / samples.nc change layout, so old archives are not mistaken for new ones
ARCHIVE_FORMAT = 2
KEY_LENGTH = 20


def hash_json(data: Any) -> str:
    return content_hash(data, KEY_LENGTH)


@lru_cache(maxsize=None)
def area_source_key(area: str) -> str:
    """Hash of the ``.py`` files of one package area (``analysis``, ``report``); '' if absent."""
    root = Path(__file__).resolve().parent.parent / area
    h = hashlib.sha256()
    for f in sorted(root.rglob("*.py")):
        h.update(str(f.relative_to(root)).encode())
        h.update(f.read_bytes())
    return h.hexdigest()[:12]


def _code(extra: dict[str, str] | None = None) -> dict[str, Any]:
    return {"version": __version__, "source": SOURCE_KEY, "archive_format": ARCHIVE_FORMAT,
            **(extra or {})}


def spinup_key(scene: Scene) -> str:
    return hash_json({"task": "spinup", "config": scene.spinup_slice(), "code": _code()})


def continuation_key(parent: str, duration: float) -> str:
    """One link of a staggered start: archive ``parent`` continued for ``duration`` s."""
    return hash_json({"task": "continuation", "inputs": [parent], "duration": float(duration),
                      "code": _code()})


def start_keys(scene: Scene) -> list[str]:
    """The spin-up's key, then one continuation per link (``Scene.start_links``): the saltation
    starts from the last."""
    out = [spinup_key(scene)]
    for _ in range(scene.start_links):
        out.append(continuation_key(out[-1], scene.fidelity.spinup.stagger))
    return out


def saltation_slice(scene: Scene) -> dict[str, Any]:
    """The whole resolved scene minus what cannot change the samples (see module docstring)."""
    case = scene.case.model_dump(mode="json", exclude={"description", "name"})
    fid = scene.fidelity.model_dump(mode="json",
                                    exclude={"description", "checkpoint_interval_wall", "name"})
    if fid.get("saltation_dt_fixed") is None:
        # absent and None mean the same adaptive step: only a set value may change the key
        fid.pop("saltation_dt_fixed", None)
    for name, unset in (("tiled_from", None), ("equilibrium_roughness", False)):
        if fid["spinup"].get(name) == unset:   # keys of scenes that leave them unset stay as they were
            fid["spinup"].pop(name, None)
    if fid["spinup"].get("equilibrium_roughness"):
        # the start depends on the measured z0s: a new measurement is a new run
        fid["spinup"]["equilibrium_roughness"] = equilibrium_roughness(scene.case)
    return {"case": case, "fidelity": fid}


def saltation_key(scene: Scene, spinup: str) -> str:
    return hash_json({"task": "saltation", "config": saltation_slice(scene), "inputs": [spinup],
                      "code": _code()})


def analysis_key(saltation: str, spinup: str) -> str:
    return hash_json({"task": "analysis", "inputs": [saltation, spinup],
                      "code": _code({"analysis": area_source_key("analysis")})})


def report_key(study: Study, analyses: dict[str, str | None]) -> str:
    """Key of a study's report: its runs' analysis keys (None: run failed) and the report code."""
    return hash_json({"task": "report", "study": study.model_dump(mode="json"),
                      "inputs": analyses, "code": _code({"report": area_source_key("report")})})


@dataclass(frozen=True)
class RunKeys:
    label: str
    scene: Scene
    spinup: str
    saltation: str
    analysis: str
    #: continuation links from the spin-up to the start (empty: the run starts at the spin-up's end)
    links: tuple[str, ...] = ()

    @property
    def start(self) -> str:
        """Key of the particle-free archive the saltation starts from."""
        return self.links[-1] if self.links else self.spinup


def run_keys(label: str, scene: Scene) -> RunKeys:
    chain = start_keys(scene)
    sp, start = chain[0], chain[-1]
    sa = saltation_key(scene, start)
    return RunKeys(label, scene, sp, sa, analysis_key(sa, start), tuple(chain[1:]))


def study_keys(study: Study, root: Path | None = None) -> dict[str, RunKeys]:
    """Label -> keys of every run of ``study`` (raises ConfigError on a bad case reference)."""
    return {r.label: run_keys(r.label, r.scene) for r in study_runs(study, root)}
