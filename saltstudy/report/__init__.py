"""Report: figures 1-13, Table 2 beside the paper, summary.json, index.html, convergence and
stability reports, from analysis archives only (see build.py).

``build_report`` is imported lazily so that ``import saltstudy.report`` (the CLI does it) does not
load matplotlib.
"""
from __future__ import annotations

_LAZY = {"build_report": "build", "build_convergence_report": "convergence",
         "build_stability_report": "stability", "make_animation": "animation"}
__all__ = list(_LAZY)


def __getattr__(name: str):
    if name not in _LAZY:
        raise AttributeError(name)
    from importlib import import_module
    return getattr(import_module(f".{_LAZY[name]}", __name__), name)
