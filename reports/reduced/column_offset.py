"""The saltating column's mean wind against the particle-free shape it started from.

(U - S) / u*s at a few heights, in consecutive windows of the run's 3-D samples: U the horizontal
mean of u (``u_mean``), S the spin-up's window-mean profile rescaled to the case's u*s (the shape
the run started on). A column at its saltation equilibrium holds a constant offset above the layer
(the same stress, hence the same shear, over a rougher bed); its log-law roughness is z0s = z0
exp(-kappa offset), z0 the spin-up bed's.

    python reports/reduced/column_offset.py RUN_DIR [RUN_DIR ...] [--window N_SAMPLES]

RUN_DIR: a saltation task's folder (``<out>/saltation/<key>``, its task.json names the spin-up).
"""
import json
import sys
from pathlib import Path

import numpy as np
import xarray as xr

HEIGHTS = (0.05, 0.1, 0.2, 0.3, 0.5, 1.0, 2.0, 3.0, 4.0)   # [m]


def offsets(run: Path, window: int) -> None:
    task = json.loads((run / "task.json").read_text())
    ds = xr.open_dataset(run / "samples.nc")
    sp = xr.open_dataset(task["inputs"]["spinup"])
    us = float(ds.attrs["u_star_target"])
    S = sp["u_mean"].values * us / float(sp.attrs.get("u_star_target", us))
    t, z, U = ds["time"].values, ds["z"].values, ds["u_mean"].values
    starts = range(0, len(t) - window + 1, window)
    print(f"{task.get('label')}  u*s {us:g} m/s; (U - S)/u*s over the windows "
          + ", ".join(f"{t[a]:.0f}-{t[a + window - 1]:.0f} s" for a in starts))
    for h in HEIGHTS:
        j = int(np.argmin(abs(z - h)))
        print(f"  z = {z[j]:5.2f} m " + " ".join(f"{(U[a:a + window, j].mean() - S[j]) / us:7.2f}"
                                              for a in starts))
    # the column above 2 m that the storage reads, below the Rayleigh layer: its mean offset and
    # the roughness a log law with that offset has over the spin-up's bed
    run = json.loads(ds.attrs["case_json"])
    top = float(ds.attrs["Lz"]) - float(run["fidelity"]["grid"]["damping_depth"])
    sel = (z >= 2.0) & (z <= top)
    dz = np.diff(ds["z_w"].values)[sel]
    z0, kappa = float(run["case"]["surface"]["z0"]), float(run["case"]["air"]["kappa"])
    means = [float(((U[a:a + window, :].mean(axis=0) - S)[sel] * dz).sum() / dz.sum() / us)
             for a in starts]
    print(f"  2-{top:g} m " + " ".join(f"{m:7.2f}" for m in means) + "   (dz-weighted mean)")
    print("  z0s [mm]   " + " ".join(f"{1e3 * z0 * np.exp(-kappa * m):7.3f}" for m in means))


if __name__ == "__main__":
    args = sys.argv[1:]
    n = 3
    if "--window" in args:
        i = args.index("--window")
        n = int(args[i + 1])
        del args[i:i + 2]
    for r in args:
        offsets(Path(r), n)
