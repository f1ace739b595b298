"""Shared test set-up: a headless matplotlib and the project root for case/study files."""
from __future__ import annotations

import os

os.environ.setdefault("MPLBACKEND", "Agg")


import runpy
from pathlib import Path

import pytest

#: the worked example of docs/USAGE.md, "From Python"
OWN_SCENE_EXAMPLE = Path(__file__).resolve().parent.parent / "docs" / "examples" / "own_scene.py"


@pytest.fixture(scope="session")
def own_scene(tmp_path_factory):
    """docs/examples/own_scene.py run at the smoke fidelity into a fresh cache: its Table 2
    (``table2``), the cache directory (``out``), the figure it drew (``figure``) and the
    example's own scene (``case``)."""
    root = tmp_path_factory.mktemp("own_scene")
    example = runpy.run_path(str(OWN_SCENE_EXAMPLE))
    table2 = example["main"]("smoke", root / "out", root / "own_scene.png")
    return {"table2": table2, "out": root / "out", "figure": root / "own_scene.png",
            "case": example["own_scene"]()}
