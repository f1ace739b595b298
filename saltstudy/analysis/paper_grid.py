"""The paper's grid, as far as the analysis reads statistics the way the paper's grid did.

Section 2.4 [26]: 0.10 m x 0.10 m columns, a first level 0.01 m thick; [28] and [31]: about
600,000 airborne parcels on its 20 m x 15 m bed in case 2, a similar number in every case at its
own Q. Read from the package's copy of the paper's numbers (``saltstudy/data/dupont2013.toml``,
``[setup]`` and ``[results]``).
"""
from __future__ import annotations

import tomllib
from importlib import resources

__all__ = ["PAPER", "PAPER_CELL_AREA", "PAPER_FIRST_LAYER", "PAPER_PARCELS_PER_M2"]

#: the package's copy of the paper's numbers
PAPER = tomllib.loads(resources.files("saltstudy").joinpath("data/dupont2013.toml")
                      .read_text(encoding="utf-8"))
_SETUP = PAPER["setup"]
#: bed area of one column of the paper's grid [m2]
PAPER_CELL_AREA = float(_SETUP["dx_m"]) * float(_SETUP["dy_m"])
#: thickness of the paper's first grid level [m]
PAPER_FIRST_LAYER = float(_SETUP["dz_surface_m"])
#: the paper's airborne parcels per m2 of bed at equilibrium [m-2], each of its case's Q grains
PAPER_PARCELS_PER_M2 = (float(PAPER["results"]["fig1_equilibrium_particles_case2"])
                        / (float(_SETUP["domain_m"][0]) * float(_SETUP["domain_m"][1])))
