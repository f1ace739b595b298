"""saltstudy: LES of a saltating sand bed two-way coupled with Lagrangian grains.

A software reproduction of Dupont, Bergametti, Marticorena & Simoens (2013), *Modeling saltation
intermittency*, J. Geophys. Res. Atmos. 118, doi:10.1002/jgrd.50528.
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

__version__ = "0.1.0"


def _source_key(here: Path | None = None) -> str:
    """Hash of the numerical sources that a run executes (``_jit.py``, ``physics/``, ``solver/``;
    the instruments that measure the model live outside them, so an edit to a benchmark or a probe
    makes no archive stale and recompiles no kernel): the workflow's cache keys and numba's
    on-disk cache (``_jit.py``) are keyed by it."""
    here = here or Path(__file__).resolve().parent
    h = hashlib.sha256(__version__.encode())
    for sub in ("_jit.py", "physics", "solver"):
        p = here / sub
        files = [p] if p.is_file() else sorted(p.rglob("*.py"))
        for f in files:
            h.update(f.relative_to(here).as_posix().encode())   # a moved file is another source
            h.update(f.read_bytes())
    if os.environ.get("SALTSTUDY_STRICT_IEEE", "") not in ("", "0"):   # _jit.STRICT_IEEE
        h.update(b"strict-ieee")
    return h.hexdigest()[:12]


SOURCE_KEY = _source_key()

if "NUMBA_CACHE_DIR" not in os.environ:
    _base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "saltstudy" / "numba"
    os.environ["NUMBA_CACHE_DIR"] = str(_base / SOURCE_KEY)
# numba's workqueue layer aborts when kernels are called from several threads (dask threads);
# prefer OpenMP, then TBB.
os.environ.setdefault("NUMBA_THREADING_LAYER_PRIORITY", "omp tbb workqueue")
