"""Report: figures 1-13, Table 2 beside the paper, summary.json, index.html, convergence and
stability reports, from analysis archives only (see build.py).

``build_report`` is imported lazily so that ``import saltstudy.report`` (the CLI does it) does not
load matplotlib.
"""
from __future__ import annotations

__all__ = ["build_report", "build_convergence_report", "build_stability_report", "make_animation"]


def __getattr__(name: str):
    if name == "build_report":
        from .build import build_report
        return build_report
    if name == "build_convergence_report":
        from .convergence import build_convergence_report
        return build_convergence_report
    if name == "build_stability_report":
        from .stability import build_stability_report
        return build_stability_report
    if name == "make_animation":
        from .animation import make_animation
        return make_animation
    raise AttributeError(name)
