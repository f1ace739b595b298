"""Two variants, two seeds each: |mean_a - mean_b| against the larger seed scatter, per statistic.

    python reports/investigations/two_seeds.py SUMMARY.json PREFIX_A PREFIX_B [PREFIX_A PREFIX_B ...]

Runs are labelled PREFIX_s1 / PREFIX_s2 in the study's summary.json.
"""
import json
import sys

STATS = ("u_star_s", "u_star_s_stress", "z_m", "G_tot", "tau_p_surface_fraction", "lambda_x",
         "lambda_y", "delta_y", "n_parcels_mean", "airborne_mass_per_m2")
summary = json.load(open(sys.argv[1]))
runs = {r["label"]: r for r in summary["cases"].values()}
pairs = sys.argv[2:]
for a, b in zip(pairs[::2], pairs[1::2]):
    print(f"\n{a} vs {b}")
    print(f"| statistic | {a} s1, s2 | {b} s1, s2 | mean difference | larger seed scatter | verdict |")
    print("|---|---|---|---|---|---|")
    for st in STATS:
        try:
            va = [runs[f"{a}_s{k}"][st] for k in (1, 2)]
            vb = [runs[f"{b}_s{k}"][st] for k in (1, 2)]
        except KeyError:
            continue
        if None in va + vb:
            continue
        d = abs(sum(va) / 2 - sum(vb) / 2)
        sc = max(abs(va[0] - va[1]), abs(vb[0] - vb[1]))
        print(f"| {st} | {va[0]:.4g}, {va[1]:.4g} | {vb[0]:.4g}, {vb[1]:.4g} | {d:.3g} | {sc:.3g} | "
              f"{'within' if d < sc else 'OUTSIDE'} |")
