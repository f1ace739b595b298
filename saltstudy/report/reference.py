"""The paper's numbers (Dupont et al. 2013, the package's ``data/dupont2013.toml``), placed only
*beside* computed values: grey markers, bands and table columns labelled "Dupont et al. 2013".
"""
from __future__ import annotations

import math
from typing import Any

from ..analysis.paper_grid import PAPER

__all__ = ["paper_table2", "paper_results", "PAPER_LABEL", "PAPER_COLOR",
           "CASES_WIND", "CASES_SOIL", "TABLE2_COLUMNS"]

PAPER_LABEL = "Dupont et al. 2013"
PAPER_COLOR = "0.55"

#: the paper's groupings: (a) cases with various u*s, (b) various mu1 (Figs 6, 7, 10, 11, 12)
CASES_WIND = (1, 2, 3, 4, 5, 6)
CASES_SOIL = (2, 7, 8, 9, 10)

#: Table 2 columns: (analysis.nc scalar, paper key in [[table2]] or None, label, unit)
TABLE2_COLUMNS = (
    # the paper's own reading (section 3.1 [33]): sqrt|<u'w'>| at z_ref, which the drive holds;
    # it leads, and the free log-law fit stands beside it as a diagnostic
    ("u_star_s_stress", "u_star_s", "u*s, stress at z_ref", "m s-1"),
    ("u_star_s", "u_star_s", "u*s, free log fit", "m s-1"),
    ("u_star_t", "u_star_t", "u*t", "m s-1"),
    ("lambda_x", "lambda_x_m", "λx", "m"),
    ("lambda_y", "lambda_y_m", "λy", "m"),
    ("delta_y", "delta_y_m", "δy (premultiplied)", "m"),
    ("z0s_stress", None, "z0s with the stress u*s", "m"),
    ("z0s", None, "z0s, free log fit", "m"),
    ("z_m", None, "z_m", "m"),
    ("G_tot", None, "G_tot", "kg m-1 s-1"),
    ("sigma_G_over_G_tot", None, "σG/G_tot", "1"),
)


def paper_table2() -> dict[int, dict[str, float]]:
    """Table 2 by case number. A value the paper does not give ("-") is NaN."""
    out: dict[int, dict[str, float]] = {}
    for row in PAPER.get("table2", []):
        missing = {key: math.nan for _, key, _, _ in TABLE2_COLUMNS if key}
        out[int(row["case"])] = {**missing, **{k: float(v) for k, v in row.items()
                                               if isinstance(v, (int, float))}}
    return out


def paper_results() -> dict[str, Any]:
    """The [results] section (statements in the text, by figure)."""
    return dict(PAPER.get("results", {}))
