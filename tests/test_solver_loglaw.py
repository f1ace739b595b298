"""Slow physics check: a spun-up neutral surface layer on the reduced grid (Lz = 6 m).

Runs case 1 (u*s = 0.41 m/s, z0 = 10 um) at the reduced fidelity for T_SPIN s, then averages
horizontally and in time over T_AVG s (a sample every 0.5 s). Checks, one test each on the same run:
the free log-law fit between 0.3 m and Lz/3 (u* within 5 % of the target, z0 within a factor 2 of
10 um: an expected failure, strict -- the mean shear dips below the log law at 0.5-1.5 m); the
paper's own reading (section 3.1 [33]: u* from the stress at z_ref held at the target, z0 regressed
with that u* within a factor 2); resolved stress above SGS stress above the first few levels and an
interior peak of the premultiplied spanwise spectrum of u at 0.1 m. Prints the non-dimensional
shear phi = kappa z / u* dU/dz. Run with ``pytest -m slow -s tests/test_solver_loglaw.py``
(15-40 min on a 2-core machine).

The free fit comes out low after 600 s (phi below 0.85 somewhere in 0.5-1.5 m, reports/investigations/loglaw/);
a shorter spin-up flatters it, because the flow starts from the exact log law and drifts into the
dip over ~H U / u*^2 ~ 400 s. Neither the dynamic Smagorinsky closure nor a three times longer
box (which unlocks the x-uniform rolls) brings phi into [0.85, 1.15] at 0.2-1.5 m: reports/investigations/loglaw/,
repeated with `saltstudy probe loglaw`.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from solver_helpers import smoke_scene  # noqa: F401  (imports saltstudy first)
from saltstudy.config import load_case, load_fidelity, resolve_scene
from saltstudy.instruments.loglaw_probe import CO_HEIGHT, streamwise_cospectrum_uw

# the column leaves its initial log law over ~H U / u*^2 ~ 400 s (module doc: 240 s flattered)
T_SPIN = 600.0
T_AVG = 90.0
KAPPA = 0.40
DRIVE = "pressure_gradient"


def run_surface_layer(t_spin: float = T_SPIN, t_avg: float = T_AVG, every: float = 0.5,
                      log=print, drive: str = DRIVE, case: int = 1, fidelity="reduced",
                      grid_overrides: dict | None = None) -> dict:
    from saltstudy.solver.diagnostics import flow as df
    from saltstudy.solver.model import Model

    fid = load_fidelity(fidelity)
    if grid_overrides:
        fid = fid.model_validate({**fid.model_dump(), "grid": {**fid.grid.model_dump(), **grid_overrides}})
    scene = resolve_scene(load_case(case, overrides={"forcing": {"drive": drive}}), fid)
    m = Model.from_scene(scene)
    acc: dict[str, np.ndarray] = {}
    spec = None
    co_x = None
    k_co = int(np.argmin(np.abs(m.grid.z_f - CO_HEIGHT)))
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
            c = streamwise_cospectrum_uw(m.state, k_co)
            co_x = c if co_x is None else co_x + c
            ustar_ref.append(df.u_star_at(m, m.z_ref))
            n += 1
            t_next += every
    out = {k: v / n for k, v in acc.items()}
    out["spec_u01"] = spec / n
    out["co_uw_x"] = co_x / n
    out["z_co"] = float(m.grid.z_f[k_co])
    out["ky"] = np.arange(spec.size) / m.grid.Ly
    out["u_star_ref"] = np.asarray(ustar_ref)
    out["Lz"] = m.grid.Lz
    out["drive"] = drive
    out["G"] = m.body_force
    out["z_ref"] = m.z_ref
    out["damping_depth"] = m.damping_depth
    out["u_star_target"] = scene.case.forcing.u_star_s
    out["z0"] = scene.case.surface.z0
    return out


def summarize(layer: dict, log=print) -> dict:
    """Fits, expected friction velocities, phi table, stress ratio and spectral peak of a run.

    Pressure-gradient drive: the steady stress is G (H - z), so the fit is ``fit_log_law`` with
    H = Lz (u*(z) = u*_0 sqrt(1 - z/H)); the target is the surface value u*_0 = sqrt(G H), which is
    u*s (the drive holds the stress at the bed, forcing.PG_HOLD_HEIGHT = 0), and the stress-based u*
    at z_ref must be sqrt(G (H - z_ref)). Top drive: plain log law, u* = u*s at every height.
    phi = kappa z / u*(z) dU/dz with the local expected u*(z).
    """
    from saltstudy.solver.diagnostics.flow import fit_log_law

    z, u, zw = layer["z"], layer["u"], layer["z_w"]
    Lz, target = float(layer["Lz"]), float(layer["u_star_target"])
    pg = str(layer.get("drive", "top")) == "pressure_gradient"
    G = float(layer.get("G", 0.0))
    z_ref = float(layer.get("z_ref", 2.0))
    H = Lz if pg else None
    u0_expect = math.sqrt(G * Lz) if pg else target
    uref_expect = math.sqrt(G * (Lz - z_ref)) if pg else target
    zmin, zmax = 0.3, Lz / 3
    fit = fit_log_law(z, u, KAPPA, H, zmin, zmax, z_eval=[z_ref])
    plain = fit_log_law(z, u, KAPPA, None, zmin, zmax)
    us_loc = u0_expect * (np.sqrt(1 - z / Lz) if pg else np.ones_like(z))
    phi = KAPPA * z / us_loc * np.gradient(u, z)
    tau_c = np.interp(z, zw, np.abs(np.asarray(layer["uw_res"]) + np.asarray(layer["uw_sgs"])))
    phi_m = KAPPA * z / np.sqrt(np.maximum(tau_c, 1e-12)) * np.gradient(u, z)
    log(f"\ndrive = {layer.get('drive', 'top')}, G = {G:.5f} m s-2, target u*s = {target} "
        f"(expected u*_0 = {u0_expect:.4f}, u*(z_ref = {z_ref:g} m) = {uref_expect:.4f})")
    log(f"fit {zmin} .. {zmax:.2f} m with H = {H}: u*_0 = {fit['u_star0']:.4f} m/s "
        f"({100 * (fit['u_star0'] / u0_expect - 1):+.1f} %), u*(z_ref) = {fit['u_star_at'][0]:.4f}, "
        f"z0 = {fit['z0']:.3g} m (case {layer['z0']:g}), rms {fit['rms']:.3f} m/s")
    log(f"plain log fit {zmin} .. {zmax:.2f} m: u* = {plain['u_star0']:.4f} m/s, z0 = {plain['z0']:.3g} m, "
        f"rms {plain['rms']:.3f} m/s")
    log(f"u* at z_ref from the stress: mean {np.mean(layer['u_star_ref']):.4f} m/s")
    log(" z [m]   <u> [m/s]  phi  phi_m   uw_res   uw_sgs (on the face below)  res/sgs")
    log("   (phi: with the expected u*(z) of the drive; phi_m: with the measured total stress)")
    for k in range(len(z)):
        r = layer["uw_res"][k] / layer["uw_sgs"][k] if layer["uw_sgs"][k] != 0 else math.inf
        log(f"{z[k]:6.3f}  {u[k]:7.3f}  {phi[k]:5.2f}  {phi_m[k]:5.2f}  {layer['uw_res'][k]:8.4f}  "
            f"{layer['uw_sgs'][k]:8.4f}  {r:7.2f}")
    ky, S = layer["ky"], layer["spec_u01"]
    pre = ky * S
    n_peak = int(np.argmax(pre[1:])) + 1
    co = np.asarray(layer["co_uw_x"])
    log(f"resolved u'w' at z = {layer['z_co']:.2f} m: {co.sum():.4f} m2/s2, share at kx = 0 (uniform in x) "
        f"{co[0] / co.sum():.2f}, at the domain length {co[1] / co.sum():.2f}")
    log(f"premultiplied spanwise spectrum of u(0.1 m): peak at lambda_y = {1 / ky[n_peak]:.2f} m "
        f"(index {n_peak} of {len(ky)})")
    return {"fit": fit, "plain": plain, "phi": phi, "phi_m": phi_m, "n_peak": n_peak, "u0_expect": u0_expect,
            "uref_expect": uref_expect}


@pytest.fixture(scope="module")
def layer():
    return run_surface_layer()


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="the LES's mean shear dips to phi ~0.7 at "
                   "0.6-1.5 m at equilibrium, so the free fit is 11-25 % low (reports/investigations/loglaw/)")
def test_free_log_law_fit_gives_u_star_and_z0(layer):
    sm = summarize(layer)
    fit = sm["fit"]
    # fitted surface u*_0 (= u*s, see summarize) and z0
    assert abs(fit["u_star0"] - sm["u0_expect"]) < 0.05 * sm["u0_expect"]
    assert 0.5 * layer["z0"] < fit["z0"] < 2.0 * layer["z0"]


@pytest.mark.slow
def test_paper_reading_u_star_from_the_stress_and_z0_with_it(layer):
    """Dupont et al. (2013) section 3.1 [33]: u* from <u'w'> at 2 m, z0 regressed with it."""
    from saltstudy.physics.laws import z0_at_fixed_u_star

    sm = summarize(layer)
    u_ref = float(layer["u_star_ref"].mean())
    # the stress-based u* at z_ref is what the drive prescribes there
    assert abs(u_ref - sm["uref_expect"]) < 0.05 * sm["uref_expect"]
    pg = str(layer.get("drive", "top")) == "pressure_gradient"
    Lz, z_ref = float(layer["Lz"]), float(layer.get("z_ref", 2.0))
    u0 = u_ref / math.sqrt(1.0 - z_ref / Lz) if pg else u_ref
    z0 = z0_at_fixed_u_star(layer["z"], layer["u"], u0, KAPPA, 0.3, Lz / 3, Lz if pg else None)
    print(f"paper's reading: u*_0 = {u0:.4f} m/s from the stress at {z_ref:g} m, z0 = {z0:.3g} m")
    assert 0.5 * layer["z0"] < z0 < 2.0 * layer["z0"]


@pytest.mark.slow
def test_resolved_stress_dominates_and_streaks_have_a_spacing(layer):
    zw, ky = layer["z_w"], layer["ky"]
    sm = summarize(layer, log=lambda *_: None)
    above = (zw > 0.3) & (zw < layer["Lz"] / 2)
    assert np.all(np.abs(layer["uw_res"][above]) > np.abs(layer["uw_sgs"][above]))
    assert 1 < sm["n_peak"] < len(ky) - 2
