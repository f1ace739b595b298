"""A study's total flux against a measured flux law, each run at its own friction velocity.

A guardrail independent of the paper (``FLUX_LAWS``: the wind-tunnel law of Creyssels et al.
2009, with its flux e-folding height of ~1 cm), asked for by a study's ``flux_law``. Each run is
read at the u* of its own stress at the reference height (``u_star_s_stress``: the wind the grains
had, whatever the drive's target), so the comparison tests the grain layer, not the controller.
"""
from __future__ import annotations

import html
import math
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from ..physics import laws
from .plotting import save_figure
from .tables import figure_html, fmt, html_table, md_table, write_json

__all__ = ["FLUX_LAWS", "TOLERANCE", "flux_law_rows", "build_fluxlaw_report"]

#: name -> (law of u* [kg m^-1 s^-1], measured (u*, Q) points, e-folding height [m], citation)
FLUX_LAWS: dict[str, tuple[Any, tuple, tuple, float, str]] = {
    "creyssels2009": (laws.creyssels2009_flux, laws.CREYSSELS2009_U_STAR, laws.CREYSSELS2009_Q,
                      laws.CREYSSELS2009_DECAY_HEIGHT,
                      "Creyssels et al. (2009), J. Fluid Mech. 625: Q = 1.38 (ρ/g)(u*² − 0.206²), "
                      "242 µm, 2500 kg m⁻³"),
}
#: the acceptance band of G_tot / law [-]
TOLERANCE = 0.25


def flux_law_rows(runs: dict, law: str) -> list[dict[str, Any]]:
    """One row per run with an analysis: label, u* of the stress [m s^-1], G_tot and the law at
    that u* [kg m^-1 s^-1], their ratio, within TOLERANCE or not, and G's e-folding height [m]."""
    func, _, _, _, _ = FLUX_LAWS[law]
    rows = []
    for label, r in runs.items():
        if not r.ok:
            continue
        us, g = r.scalar("u_star_s_stress"), r.scalar("G_tot")
        q = float(func(us)) if math.isfinite(us) else math.nan
        ratio = g / q if (math.isfinite(g) and q > 0) else math.nan
        rows.append({"label": label, "u_star_stress": us, "G_tot": g, "law": q, "ratio": ratio,
                     "within": bool(math.isfinite(ratio) and abs(ratio - 1) <= TOLERANCE),
                     "G_decay_height": r.scalar("G_decay_height")})
    rows.sort(key=lambda row: (row["u_star_stress"] if math.isfinite(row["u_star_stress"]) else 0.0))
    return rows


def build_fluxlaw_report(runs: dict, report_dir: Path, law: str) -> dict[str, Any]:
    """fluxlaw.json, fluxlaw.md, fluxlaw.png/pdf in ``report_dir``; returns {"rows", "html"}."""
    if law not in FLUX_LAWS:
        raise ValueError(f"flux_law: {law!r} is none of {sorted(FLUX_LAWS)}")
    func, us_data, q_data, h_data, cite = FLUX_LAWS[law]
    rows = flux_law_rows(runs, law)
    report_dir = Path(report_dir)
    write_json(report_dir / "fluxlaw.json", {"law": law, "citation": cite, "tolerance": TOLERANCE,
                                             "decay_height_measured_m": h_data, "rows": rows})
    heads = ["run", "u* (stress at z_ref) [m/s]", "G_tot [g/m/s]", "law at that u* [g/m/s]",
             f"G_tot / law (within ±{TOLERANCE:.0%})",
             f"G e-folding height [cm] (measured {100 * h_data:g})"]
    cells = [[r["label"], fmt(r["u_star_stress"]), fmt(1e3 * r["G_tot"]), fmt(1e3 * r["law"]),
              f"{fmt(r['ratio'])} {'yes' if r['within'] else 'NO'}", fmt(100 * r["G_decay_height"])]
             for r in rows]
    lines = [f"G_tot against {cite}.", "", *md_table(heads, cells)]
    (report_dir / "fluxlaw.md").write_text("\n".join(lines) + "\n", encoding="utf-8")

    fig = Figure(figsize=(5.5, 4.0))
    ax = fig.add_subplot()
    u = np.linspace(0.2, max([0.75] + [r["u_star_stress"] for r in rows
                                       if math.isfinite(r["u_star_stress"])]), 100)
    law_u = 1e3 * np.asarray(func(u))
    ax.plot(u, law_u, color="0.5", label="law")
    ax.fill_between(u, (1 - TOLERANCE) * law_u, (1 + TOLERANCE) * law_u, color="0.9",
                    label=f"±{TOLERANCE:.0%}")
    ax.plot(us_data, 1e3 * np.asarray(q_data), "s", mfc="none", color="0.4", label="measured")
    ax.plot([r["u_star_stress"] for r in rows], [1e3 * r["G_tot"] for r in rows], "o",
            color="tab:red", label="this study")
    ax.set(xlabel="u* [m s⁻¹] (runs: their stress at z_ref)", ylabel="G_tot [g m⁻¹ s⁻¹]")
    ax.set_title(cite.split(":")[0], fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, report_dir, "fluxlaw", 110)
    table = html_table(heads, cells,
                       lambda i, j: "bad" if i >= 0 and j == 4 and not rows[i]["within"] else "")
    return {"rows": rows, "html": f"<p>G_tot of each run against {html.escape(cite)}, at the u* of "
            "the run's own stress at the reference height.</p>"
            + figure_html("fluxlaw", "flux against the law") + table}
