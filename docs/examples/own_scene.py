"""Your own scene beside a paper case, from Python.

Case 2 of Dupont et al. (2013) (u*s = 0.54 m s-1 over 200 µm sand) and the same wind over a soil
the paper did not run, 150 µm sand, each run through the same cached workflow as
``saltstudy run``; then Table 2 of the two runs, their Fig. 8 point (the total flux G_tot against
u*s/u*t, u*s read the paper's way from the total stress at the reference height) and their
saltation height z_m on the profile of the flux it bounds, drawn from the xarray objects the API
hands back.

    python docs/examples/own_scene.py                     # the quick fidelity, a few minutes
    python docs/examples/own_scene.py --fidelity smoke    # seconds per run (the tests: half of
                                                          # it, tests/conftest.py)

The figure of the quick fidelity is docs/examples/own_scene.png (docs/USAGE.md, "From Python").
"""
from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib
import xarray as xr

import saltstudy

HERE = Path(__file__).resolve().parent


def own_scene() -> saltstudy.Case:
    """Case 2 over 150 µm sand: a parcel holds (200/150)³ as many grains as case 2's (Q), so a
    parcel weighs the same."""
    case2 = saltstudy.load_case(2)
    return case2.replace(name="sand150um", soil={"modes": [{"mu": 150e-6}]},
                         particles={"Q": round(case2.particles.Q * (200 / 150) ** 3)})


def draw(table2: xr.Dataset, analyses: dict[str, xr.Dataset], names: dict[str, str], fidelity: str):
    """Fig. 8's points and the flux profiles with z_m, one colour per run."""
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(9.0, 3.8), constrained_layout=True)
    colors = dict(zip(table2.run.values, ("#66a61e", "#d95f02", "#7570b3", "#e7298a")))
    ratio = table2.u_star_s_stress / table2.u_star_t          # Fig. 8's abscissa
    for label in table2.run.values:
        row, a, c, name = table2.sel(run=label), analyses[label], colors[label], names[label]
        left.plot(ratio.sel(run=label), row.G_tot, "o", ms=9, color=c, mec="k", label=name)
        right.semilogy(a.G, a.z, "-", color=c, label=f"{name}: G(z)")
        right.axhline(float(a.z_m), color=c, ls="--", lw=1, label=f"z_m = {float(a.z_m):.3g} m")
    left.set_xlabel(r"$u_{*s}/u_{*t}$ ($u_{*s}$ from the total stress at $z_{ref}$)")
    left.set_ylabel(r"$G_{tot}$ [kg m$^{-1}$ s$^{-1}$]")
    left.set_title("Fig. 8's points", fontsize=10)
    left.set_xlim(0, 1.15 * float(ratio.max()))
    left.set_ylim(0, 1.15 * float(table2.G_tot.max()))
    left.grid(alpha=0.3)
    left.legend(fontsize=8)
    right.set_xlabel(r"mass flux density $G$ [kg m$^{-2}$ s$^{-1}$]")
    right.set_ylabel("height z [m]")
    right.set_title("the flux profile and z_m", fontsize=10)
    right.set_ylim(top=3 * max(float(a.z_m) for a in analyses.values()))
    right.grid(alpha=0.3, which="both")
    right.legend(fontsize=7.5)
    fig.suptitle(f"case 2 and the same wind over 150 µm sand, fidelity {fidelity}", fontsize=10)
    return fig


def main(fidelity: str | Path = "quick", out: Path | None = None,
         figure: Path = HERE / "own_scene.png") -> xr.Dataset:
    """Run both scenes (cached), draw ``figure`` and return their Table 2."""
    fid = saltstudy.load_fidelity(fidelity)
    runs = [saltstudy.run(case, fid, out=out) for case in (saltstudy.load_case(2), own_scene())]
    for r in runs:
        if not r.ok:
            raise SystemExit(f"{r.label}: {[o.error for o in r.outcomes if o.error]}")
    results = saltstudy.Results(runs, study="own scene")
    table2 = results.table2()
    names = {r.label: f"{r.label}, {r.case.soil.modes[0].mu * 1e6:.0f} µm" for r in runs}
    fig = draw(table2, {label: results.analysis(label) for label in results.labels}, names, fid.name)
    fig.savefig(figure, dpi=110)
    print(table2[["u_star_s_stress", "u_star_s_stress_paper", "u_star_t", "z_m", "G_tot"]]
          .to_dataframe().to_string())
    print(f"figure: {figure}")
    return table2


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--fidelity", default="quick", help="fidelity name or file (default quick)")
    p.add_argument("--out", type=Path, default=None, help="cache directory (default: saltstudy's)")
    p.add_argument("--figure", type=Path, default=HERE / "own_scene.png", help="the PNG to write")
    a = p.parse_args()
    main(a.fidelity, a.out, a.figure)
