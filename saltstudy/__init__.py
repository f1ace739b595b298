"""saltstudy: LES of a saltating sand bed two-way coupled with Lagrangian grains.

A software reproduction of Dupont, Bergametti, Marticorena & Simoens (2013), *Modeling saltation
intermittency*, J. Geophys. Res. Atmos. 118, doi:10.1002/jgrd.50528.

From Python (saltstudy.api; docs/USAGE.md, "From Python"): ``load_case``, ``load_fidelity``,
``load_study``, ``list_case_numbers``, ``run``, ``run_study``, ``open_results``; ``ConfigError``.
Importing ``saltstudy`` loads none of these (nor numba or dask) until one is used.
"""
from __future__ import annotations

from ._identity import SOURCE_KEY, __version__

#: the public names, by the module each comes from (imported on first use)
_CONFIG_NAMES = ("Case", "Fidelity", "Study", "ConfigError", "load_case", "load_fidelity",
                 "load_study", "list_case_numbers")
_API_NAMES = ("Run", "Results", "run", "run_study", "open_results")
__all__ = [*_CONFIG_NAMES, *_API_NAMES, "__version__", "SOURCE_KEY"]


def __getattr__(name: str):
    if name in _CONFIG_NAMES:
        from . import config as module
    elif name in _API_NAMES:
        from . import api as module
    else:
        raise AttributeError(f"module 'saltstudy' has no attribute {name!r}")
    value = getattr(module, name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
