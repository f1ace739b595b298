"""Statistics of one case from its archives: ``samples.nc`` (+ ``spinup.nc``) -> ``analysis.nc``.

Entry point: :func:`saltstudy.analysis.analyse.analyse_case` (``saltstudy analyse``); each
module defines its statistics in its docstring, with the paper's section and equation.
"""
