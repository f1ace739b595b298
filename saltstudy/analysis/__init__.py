"""Statistics of one case from its archives: ``samples.nc`` (+ ``spinup.nc``) -> ``analysis.nc``.

Entry point: :func:`saltstudy.analysis.analyse.analyse_case` (also ``saltstudy analyse``).
Each module defines its statistics in its docstring, with the paper's section and equation, and
holds the functions that compute them for one case (each returns its variables of analysis.nc);
``analyse`` calls them in the order their definitions need, ``schema`` is the contract of
analysis.nc (``SPEC``).

The package reads archives only (never the solver); it imports nothing heavy at import time.
"""


def analyse_case(*args, **kwargs):
    """See :func:`saltstudy.analysis.analyse.analyse_case`."""
    from .analyse import analyse_case as _impl
    return _impl(*args, **kwargs)


__all__ = ["analyse_case"]
