"""The paper's grid, as far as the analysis reads statistics the way the paper's grid did.

Section 2.4 [26]: 0.10 m x 0.10 m columns, a first level 0.01 m thick. Read from the package's
copy of the paper's numbers (``saltstudy/data/dupont2013.toml``, ``[setup]``).
"""
from __future__ import annotations

import tomllib
from importlib import resources

__all__ = ["PAPER_CELL_AREA", "PAPER_FIRST_LAYER"]


def _setup() -> dict:
    text = resources.files("saltstudy").joinpath("data/dupont2013.toml").read_text(encoding="utf-8")
    return tomllib.loads(text)["setup"]


_SETUP = _setup()
#: bed area of one column of the paper's grid [m2]
PAPER_CELL_AREA = float(_SETUP["dx_m"]) * float(_SETUP["dy_m"])
#: thickness of the paper's first grid level [m]
PAPER_FIRST_LAYER = float(_SETUP["dz_surface_m"])
