"""Shared test set-up: a headless matplotlib, and the worked example of docs/USAGE.md ("From
Python") run once per session at smoke cost, its cache shared by the tests that read it."""
from __future__ import annotations

import os
import runpy
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

#: the worked example of docs/USAGE.md, "From Python"
OWN_SCENE_EXAMPLE = Path(__file__).resolve().parent.parent / "docs" / "examples" / "own_scene.py"

#: the smoke fidelity at half its simulated time, the same numbers test_studies_smoke.py's `home`
#: writes into its copy of smoke.toml: the runs both make (case 2 at this cost) have the same keys,
#: so a study that starts from a copy of the example's cache finds them there
HALF_SMOKE = """based_on = "smoke"
saltation_duration = 1.0

[spinup]
t_min = 0.5
t_max = 1.5
window = 0.5

[sampling]
start = 0.4
interval = 0.3
"""


@pytest.fixture(scope="session")
def own_scene(tmp_path_factory):
    """docs/examples/own_scene.py run at half the smoke fidelity into a fresh cache: its Table 2
    (``table2``), the cache directory (``out``), the fidelity file (``fidelity``), the figure it
    drew (``figure``) and the example's own scene (``case``)."""
    root = tmp_path_factory.mktemp("own_scene")
    fidelity = root / "smoke-half.toml"
    fidelity.write_text(HALF_SMOKE)
    example = runpy.run_path(str(OWN_SCENE_EXAMPLE))
    table2 = example["main"](fidelity, root / "out", root / "own_scene.png")
    return {"table2": table2, "out": root / "out", "fidelity": fidelity,
            "figure": root / "own_scene.png", "case": example["own_scene"]()}

