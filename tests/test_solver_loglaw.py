"""Slow physics check: a spun-up neutral surface layer on the reduced grid (Lz = 6 m).

Runs case 1 (u*s = 0.41 m/s, z0 = 10 um) at the reduced fidelity for T_SPIN s, then averages
horizontally and in time over T_AVG s (a sample every 0.5 s). Checks: the log law between 0.3 m and
Lz/3 (fitted u* within 5 % of the target, z0 within a factor 2 of 10 um), resolved stress above SGS
stress above the first few levels, the u* read at z_ref held at the target, and an interior peak of
the premultiplied spanwise spectrum of u at 0.1 m. Prints the non-dimensional shear
phi = kappa z / u* dU/dz. Run with ``pytest -m slow -s tests/test_solver_loglaw.py`` (tens of
minutes on 2 cores).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from solver_helpers import smoke_scene  # noqa: F401  (imports saltstudy first)
from saltstudy.config import load_case, load_fidelity, resolve_scene

T_SPIN = 150.0
T_AVG = 60.0
KAPPA = 0.40


def run_surface_layer(t_spin: float = T_SPIN, t_avg: float = T_AVG, every: float = 0.5,
                      log=print) -> dict:
    from saltstudy.solver import diagnostics_flow as df
    from saltstudy.solver.model import Model

    scene = resolve_scene(load_case(1), load_fidelity("reduced"))
    m = Model.from_scene(scene)
    acc: dict[str, np.ndarray] = {}
    spec = None
    n = 0
    ustar_ref = []
    t_next = t_spin
    t_log = 0.0
    while m.t < t_spin + t_avg - 1e-9:
        info = m.step(m.next_dt(limit=t_next - m.t))
        if m.t >= t_log:
            log(f"t = {m.t:6.1f} s  u*(z_ref) = {info.u_star_ref:.3f}  u_drive = {info.u_drive:.2f}"
                f"  dt = {info.dt:.4f}")
            t_log += 10.0
        if m.t >= t_next - 1e-9:
            p = df.flow_profiles(m)
            for k, v in p.items():
                acc[k] = acc.get(k, 0.0) + v
            up = df.flow_planes(m, [0.1])["u_plane"][..., 0]
            f = np.fft.rfft(up - up.mean(axis=1, keepdims=True), axis=1)
            s = (np.abs(f) ** 2).mean(axis=0)
            spec = s if spec is None else spec + s
            ustar_ref.append(df.u_star_at(m, m.z_ref))
            n += 1
            t_next += every
    out = {k: v / n for k, v in acc.items()}
    out["spec_u01"] = spec / n
    out["ky"] = np.arange(spec.size) / m.grid.Ly
    out["u_star_ref"] = np.asarray(ustar_ref)
    out["Lz"] = m.grid.Lz
    out["u_star_target"] = scene.case.forcing.u_star_s
    out["z0"] = scene.case.surface.z0
    return out


def log_fit(z, u, zmin, zmax):
    """(u*, z0) from a least-squares fit of u = (u*/kappa) ln(z/z0) on zmin <= z <= zmax."""
    sel = (z >= zmin) & (z <= zmax)
    slope, icpt = np.polyfit(np.log(z[sel]), u[sel], 1)
    us = KAPPA * slope
    return us, math.exp(-icpt / slope)


@pytest.fixture(scope="module")
def layer():
    return run_surface_layer()


@pytest.mark.slow
def test_log_law_and_surface_layer_statistics(layer):
    z, u = layer["z"], layer["u"]
    target = layer["u_star_target"]
    us_fit, z0_fit = log_fit(z, u, 0.3, layer["Lz"] / 3)
    zw = layer["z_w"]
    dudz = np.gradient(u, z)
    phi = KAPPA * z / target * dudz
    print(f"\nlog-law fit 0.3 m .. {layer['Lz'] / 3:.1f} m: u* = {us_fit:.4f} m/s "
          f"(target {target}), z0 = {z0_fit:.3g} m (case {layer['z0']:g})")
    print(f"u* at z_ref from the stress: mean {layer['u_star_ref'].mean():.4f} m/s")
    print(" z [m]   <u> [m/s]  phi    uw_res   uw_sgs (on the face below)")
    for k in range(len(z)):
        print(f"{z[k]:6.3f}  {u[k]:7.3f}  {phi[k]:5.2f}  {layer['uw_res'][k]:8.4f}  {layer['uw_sgs'][k]:8.4f}")
    ky, S = layer["ky"], layer["spec_u01"]
    pre = ky * S
    n_peak = int(np.argmax(pre[1:])) + 1
    print(f"premultiplied spanwise spectrum of u(0.1 m): peak at lambda_y = {1 / ky[n_peak]:.2f} m")

    assert abs(us_fit - target) < 0.05 * target
    assert 0.5 * layer["z0"] < z0_fit < 2.0 * layer["z0"]
    assert abs(layer["u_star_ref"].mean() - target) < 0.05 * target
    above = (zw > 0.3) & (zw < layer["Lz"] / 2)
    assert np.all(np.abs(layer["uw_res"][above]) > np.abs(layer["uw_sgs"][above]))
    assert 1 < n_peak < len(ky) - 2
