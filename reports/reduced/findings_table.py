"""Table 2 of reports/reduced/FINDINGS.md from the study's summary.json, beside the paper's values.

    python reports/reduced/findings_table.py reports/reduced/summary.json

u*s: the stress at 2 m (the paper's reading); the Fig. 4 line: z_m from 0.22 m at u*s = 0.41 to
0.55 m at 1.10 m/s (Dupont et al. 2013, section 3.2), read at the run's own stress u*s; Bagnold
(1937) and Sørensen (2004) as drawn in the paper's Fig. 8, at the run's stress u*s and u*t, for the
200 um cases; the paper's parcel count, about 2,000 airborne per m2 ([28] and Fig. 1).
"""
from __future__ import annotations

import json
import math
import sys
import tomllib
from pathlib import Path

from saltstudy.config import load_case

REF = tomllib.loads((Path(__file__).resolve().parents[2] / "saltstudy" / "data" / "dupont2013.toml")
                    .read_text("utf-8"))
PAPER = {r["case"]: r for r in REF["table2"]}


def fig4_line(u: float) -> float:
    return 0.22 + (u - 0.41) * (0.55 - 0.22) / (1.10 - 0.41)


def bagnold(u: float, d: float, rho: float, g: float) -> float:
    return 1.5 * math.sqrt(d / 250e-6) * rho * u ** 3 / g


def sorensen(u: float, ut: float, rho: float, g: float) -> float:
    r = ut / u
    return rho * u ** 3 * (1 - r * r) * (3.0 * r + 3.9 * r * r) / g


def fmt(x: float | None, spec: str = ".2f") -> str:
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def main(path: str) -> None:
    cases = json.loads(Path(path).read_text("utf-8"))["cases"]
    print("| case | u*s stress at 2 m (paper) | z_m [m] (/ Fig. 4 line) | parcels per m² at Q (× 2,000)"
          " | in the first cell | G_tot [g/m/s] (× Bagnold; × Sørensen) | τp(0)/ρu*² | λx [m] (paper)"
          " | λy [m] (paper) | δy: C_p; u at 0.1 m [m] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    excess = []
    for k in sorted(cases, key=int):
        c, n = cases[k], int(k)
        p, case = PAPER[n], load_case(n)
        u = c["u_star_s_stress"]
        excess.append(u / p["u_star_s"] - 1)
        d = case.soil.modes[0].mu
        zm = f"{c['z_m']:.3f}" + (f" ({c['z_m'] / fig4_line(u):.2f})" if n <= 6 else "")
        g = c["G_tot"]
        flux = f"{1e3 * g:.0f}"
        if n <= 6:
            rho, grav = case.air.rho, case.air.g
            flux += (f" ({g / bagnold(u, d, rho, grav):.2f}; "
                     f"{g / sorensen(u, c['u_star_t'], rho, grav):.2f})")
        label = f"{n}" if n <= 6 else f"{n} ({p['mu1_um']} µm)"
        print(f"| {label} | {u:.3f} ({p['u_star_s']}, {100 * excess[-1]:+.0f} %) | {zm} | "
              f"{c['n_parcels_per_m2_at_Q']:,.0f} ({c['n_parcels_per_m2_at_Q'] / 2000:.1f}) | "
              f"{c['first_cell_parcel_fraction']:.2f} | {flux} | {c['tau_p_surface_fraction']:.2f} | "
              f"{fmt(c['lambda_x'], '.1f')} ({p['lambda_x_m']}) | {fmt(c['lambda_y'])} "
              f"({p['lambda_y_m']}) | {fmt(c['delta_y_premultiplied'])}; {fmt(c['delta_y_u_premultiplied'])} |")
    m = sum(excess) / len(excess)
    print(f"\nu*s excess over the paper's: mean {100 * m:+.1f} %, {min(excess) * 100:+.0f} to "
          f"{max(excess) * 100:+.0f} %, within 10 % in {sum(abs(e) <= 0.10 for e in excess)} of "
          f"{len(excess)}, within 25 % in {sum(abs(e) <= 0.25 for e in excess)}")


if __name__ == "__main__":
    main(sys.argv[1])
