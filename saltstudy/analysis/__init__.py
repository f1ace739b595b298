"""Statistics of one case from its archives: ``samples.nc`` (+ ``spinup.nc``) -> ``analysis.nc``.

Entry point: :func:`saltstudy.analysis.analyse.analyse_case` (``saltstudy analyse``); each
module defines its statistics in its docstring, with the paper's section and equation. Nothing
heavy is imported at import time.
"""


def analyse_case(*args, **kwargs):
    """See :func:`saltstudy.analysis.analyse.analyse_case`."""
    from .analyse import analyse_case as _impl
    return _impl(*args, **kwargs)


__all__ = ["analyse_case"]
