"""Compile the numba kernels in a subprocess before a study's solver work, so that every task
loads them from numba's cache and reruns and resumes repeat the first run (docs/USAGE.md, "The
cache, reruns and resumes"): one child per distinct set of code paths among the pending scenes,
each shrunk to the smoke grid (:func:`warm_scene`); a marker keyed by that set and the sources'
paths and time stamps (numba's cache index) makes it a no-op afterwards.
"""
from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from .._identity import numerical_sources
from ..config import Fidelity, Scene
from ..faults import FAULT_ENV

#: the smoke grid's horizontal size and level count (workflows/fidelities/smoke.toml)
_GRID = {"Lx": 2.4, "Ly": 1.6, "nx": 16, "ny": 12, "nz": 16, "dz_top": None}
_SALTATION_S = 2.0
_SAMPLING = {"start": 1.0, "interval": 0.5, "count": 3}


def warm_scene(scene: Scene) -> Scene:
    """``scene`` on the smoke grid for 2 s of spin-up and 2 s of saltation, every option kept."""
    f = scene.fidelity.model_dump()
    g = f["grid"]
    g.update(_GRID)
    g["nz"] = min(g["nz"], _GRID["nz"])
    while g["dz_bottom"] * g["nz"] >= g["Lz"]:  # the stretched grid must fit: thinner levels
        g["dz_bottom"] *= 0.5
    f["spinup"].update(t_min=min(f["spinup"]["t_min"], 1.0), t_max=2.0, window=1.0)
    f["saltation_duration"] = _SALTATION_S
    f["sampling"].update(_SAMPLING)
    f["relaxation"]["until"] = min(f["relaxation"]["until"], _SAMPLING["start"])
    # a fixed step chosen for the real grid is no step for this one (the kernels do not depend on it)
    f["saltation_dt_fixed"] = None
    f["name"] = f"{f['name']}-warmup"
    return Scene(label=f"{scene.label}-warmup", case=scene.case,
                 fidelity=Fidelity.model_validate(f))


def signature(scene: Scene) -> str:
    """What selects code paths (numba specialisations): options, switches; not sizes, constants."""
    w = warm_scene(scene)
    c = scene.case
    sel = {"fidelity": w.fidelity.model_dump(mode="json", exclude={"name", "description"}),
           "physics": c.physics.model_dump(mode="json"),
           "closure": c.closure.model_dump(mode="json"),
           "drive": c.forcing.drive, "soil_modes": len(c.soil.modes)}
    return hashlib.sha256(json.dumps(sel, sort_keys=True).encode()).hexdigest()[:16]


def _source_stamps() -> list[tuple[str, int, int]]:
    """(path, mtime in ns, size) of the sources numba compiles: what its cache index checks."""
    return [(str(f), f.stat().st_mtime_ns, f.stat().st_size) for f in numerical_sources()]


def _marker(sigs: list[str], marker_dir: Path | None) -> Path | None:
    if marker_dir is None:
        base = os.environ.get("NUMBA_CACHE_DIR")
        if not base:
            return None
        marker_dir = Path(base) / "warmup"
    h = hashlib.sha256(json.dumps([_source_stamps(), sorted(sigs)]).encode()).hexdigest()[:16]
    return Path(marker_dir) / f"{h}.json"


def ensure_warm(scenes: list[Scene], log=lambda _: None, marker_dir: Path | None = None) -> bool:
    """Warm the numba cache for ``scenes`` in a child process unless done (markers in
    ``marker_dir``, default ``$NUMBA_CACHE_DIR/warmup``); True if a child ran. A failing child is
    reported and ignored: the tasks then compile in-process."""
    if not scenes or os.environ.get("SALTSTUDY_NO_WARMUP"):
        return False
    reps: dict[str, Scene] = {}
    for s in scenes:
        reps.setdefault(signature(s), s)
    marker = _marker(list(reps), marker_dir)
    if marker is None or marker.exists():
        return False
    log(f"[warm-up] numba kernels for {len(reps)} code path(s), in a child process "
        "(so that every run loads them from the cache: reruns and resumes repeat it)")
    with tempfile.TemporaryDirectory(prefix="saltstudy-warmup-") as tmp:
        spec = Path(tmp) / "scenes.json"
        spec.write_text(json.dumps([warm_scene(s).model_dump(mode="json") for s in reps.values()]))
        # without the fault hook: a test's write point means the run's
        env = {k: v for k, v in os.environ.items() if k != FAULT_ENV}
        proc = subprocess.run([sys.executable, "-m", "saltstudy.workflow.warmup", str(spec), tmp],
                              capture_output=True, text=True, env=env)
    if proc.returncode != 0:
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-3:]
        log("[warm-up] failed (the tasks compile in-process instead): " + " | ".join(tail))
        return True
    marker.parent.mkdir(parents=True, exist_ok=True)
    marker.write_text(json.dumps({"signatures": sorted(reps),
                                  "package": str(Path(__file__).resolve().parents[1])}))
    return True


def _main(spec: str, out: str) -> None:
    from .tasks import saltation_task, spinup_task

    for d in json.loads(Path(spec).read_text()):
        scene = Scene.model_validate(d)
        # the same two tasks as the study graph (graph.py) runs for every scene
        saltation_task(scene, spinup_task(scene, Path(out)), Path(out))


if __name__ == "__main__":
    _main(sys.argv[1], sys.argv[2])
