"""The particle-free column's momentum budget above z_ref in the spin-up's own record.

With the top drive, the controller moves u_drive at du_drive/dt = (u*^2 - M) / (F T_c)
(solver/flow/forcing.py), so the momentum the Rayleigh layer feeds in over a window is read from
u_drive's change alone: <M> = u*^2 - F T_c (u_drive(t1) - u_drive(t0)) / (t1 - t0). The stress at
z_ref is the record's u_star_hist (every 0.4 s on the reduced grid); the storage -dP/dt of the air
above z_ref is <tau(z_ref)> - <M> (the residual the saltation runs' probe shows, <= 0.02 u*s^2, is
neglected). All three in units of u*^2.

    python reports/reduced/spinup_column_budget.py SPINUP.nc [FIDELITY] [WINDOW_S] [STEP_S]

SPINUP.nc: the last link of a study's staggered chain (its record spans the whole chain).
"""
import sys

import numpy as np
import xarray as xr

from saltstudy.config import load_case, load_fidelity, resolve_scene
from saltstudy.solver.flow.damping import damping_profiles
from saltstudy.solver.grid import Grid


def main(path: str, fidelity: str = "reduced", window: float = 30.0, step: float = 6.0) -> None:
    scene = resolve_scene(load_case(2), load_fidelity(fidelity)).spinup_scene()
    grid = Grid.from_spec(scene.fidelity.grid)
    f_c, _ = damping_profiles(grid, scene.damping_depth, scene.fidelity.grid.damping_timescale)
    F = float((f_c * grid.dz_c).sum())                    # [m s^-1]
    T_c = scene.case.forcing.controller_timescale         # [s]
    u2 = scene.case.forcing.u_star_s ** 2                 # [m^2 s^-2]
    ds = xr.open_dataset(path)
    t, us, ud = (ds[k].values for k in ("time_hist", "u_star_hist", "u_drive_hist"))
    print(f"F = {F:.4f} m/s, T_c = {T_c:g} s, u* = {scene.case.forcing.u_star_s:g} m/s")
    print("| window [s] | tau(z_ref) | M, the drive | storage |")
    print("|---|---|---|---|")
    for t0 in np.arange(t[0], t[-1] - window + 1e-9, step):
        sel = (t >= t0) & (t < t0 + window)
        tau = float(np.mean(us[sel] ** 2)) / u2
        M = 1.0 - F * T_c * (np.interp(t0 + window, t, ud) - np.interp(t0, t, ud)) / window / u2
        print(f"| {t0:.0f}-{t0 + window:.0f} | {tau:.2f} | {M:.2f} | {tau - M:+.2f} |")


if __name__ == "__main__":
    a = sys.argv[1:]
    main(a[0], *(a[1:2]), *(float(x) for x in a[2:4]))
