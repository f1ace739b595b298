"""The package's identity, which every part may import: its version and the source key, the hash
of the numerical sources a run executes. Importing it points numba's on-disk cache at a
directory of that key before any kernel compiles (``_jit.py``)."""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

__version__ = "0.1.0"


def numerical_sources(here: Path | None = None) -> list[Path]:
    """The sources a run executes: ``_jit.py``, ``physics/``, ``solver/``."""
    here = here or Path(__file__).resolve().parent
    return [here / "_jit.py", *sorted((here / "physics").rglob("*.py")),
            *sorted((here / "solver").rglob("*.py"))]


def source_key(here: Path | None = None) -> str:
    """Hash of the numerical sources, which keys the workflow's cache and numba's on-disk cache."""
    here = here or Path(__file__).resolve().parent
    h = hashlib.sha256(__version__.encode())
    for f in numerical_sources(here):
        h.update(f.relative_to(here).as_posix().encode())   # a moved file is another source
        h.update(f.read_bytes())
    if os.environ.get("SALTSTUDY_STRICT_IEEE", "") not in ("", "0"):   # _jit.STRICT_IEEE
        h.update(b"strict-ieee")
    return h.hexdigest()[:12]


SOURCE_KEY = source_key()

if "NUMBA_CACHE_DIR" not in os.environ:
    _base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "saltstudy" / "numba"
    os.environ["NUMBA_CACHE_DIR"] = str(_base / SOURCE_KEY)
# numba's workqueue layer aborts when kernels are called from several threads (dask threads);
# prefer OpenMP, then TBB.
os.environ.setdefault("NUMBA_THREADING_LAYER_PRIORITY", "omp tbb workqueue")
# OpenMP workers sleep when a parallel region ends instead of spinning: the pressure solve's FFTs
# run on other threads between regions (docs/BENCHMARKS.md, "Single precision and the flow's
# threads": `NUMBA_NUM_THREADS=1|2 saltstudy bench flow --fidelity paper`).
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
