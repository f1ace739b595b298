"""Report: figures 1-13, Table 2 beside the paper, summary.json, index.html, convergence and
stability reports, from analysis archives only (see build.py).

``build_report`` is imported lazily so that ``import saltstudy.report`` (the CLI does it) does not
load matplotlib.
"""
__all__ = ["build_report"]


def __getattr__(name: str):
    if name != "build_report":
        raise AttributeError(name)
    from .build import build_report
    return build_report
