"""Windowed log-law probe of the particle-free surface layer (``saltstudy probe loglaw``; the tables
of reports/investigations/loglaw/README.md).

Runs one case without grains and, at the end of every ``window`` seconds, reports window means of:
the log-law fit over 0.3 m to 2 m and to Lz/3 (u*_0 over its expected value, z0 [m]); phi = kappa z
/ u*(z) dU/dz at fixed heights and on every level below Lz/2; the paper's reading (section 3.1
[33]: u* from the total stress at 2 m, z0 at that u*); u* from the total stress over the expected
u*(z); the share of u'w' at ~0.8 m in kx = 0 motions; the spanwise spectrum of u near 0.1 m and
its peak wavelength; with the dynamic closure, C_s(z) and beta(z).

``--roll-damping RATE`` [s^-1] is a diagnostic: after every step it relaxes the x-means of v and w
towards zero (still divergence-free), removing the box-locked rolls. One window scatters by about
+-0.05 in the fit ratio; compare variants over at least two windows.
"""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

#: heights [m] of the phi and stress tables
HEIGHTS = (0.1, 0.2, 0.3, 0.45, 0.6, 0.8, 1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0)
#: height [m] of the streamwise u'w' cospectrum (the middle of the shear dip)
CO_HEIGHT = 0.8
#: height [m] of the spanwise spectrum of u (the paper's u plane of its Figs. 9b and 10b)
STREAK_HEIGHT = 0.1
#: the fit's lower end [m] (the issue's log-law range starts at 0.3 m)
FIT_Z_MIN = 0.3
#: where the paper reads u* from the stress, and the top of its z0 regression here [m]
PAPER_Z_REF = 2.0


def streamwise_cospectrum_uw(state, k: int) -> np.ndarray:
    """One-sided streamwise cospectrum of the resolved u'w' on the w face k, averaged over y
    (nx//2 + 1,) [m^2 s^-2]: its sum is <u'w'> there; entry 0 the part uniform in x."""
    uf = 0.5 * (state.u[:, :, k - 1] + state.u[:, :, k])
    uc = 0.5 * (uf + np.roll(uf, -1, axis=0))        # x face -> cell centre, where w lives
    up = uc - uc.mean()
    wp = state.w[:, :, k] - state.w[:, :, k].mean()
    nx = up.shape[0]
    c = (np.fft.rfft(up, axis=0) * np.conj(np.fft.rfft(wp, axis=0))).real.mean(axis=1) / nx ** 2
    c[1:(nx + 1) // 2] *= 2.0                       # the conjugate half (not the Nyquist entry)
    return c


def spanwise_spectrum_u(state, k: int) -> np.ndarray:
    """One-sided spanwise power spectrum of u' on level k, averaged over x (ny//2 + 1,) [m^2 s^-2]:
    its sum is the plane variance of u; entry 0 the part uniform in y."""
    up = state.u[:, :, k] - state.u[:, :, k].mean()
    ny = up.shape[1]
    p = (np.abs(np.fft.rfft(up, axis=1)) ** 2).mean(axis=0) / ny ** 2
    p[1:(ny + 1) // 2] *= 2.0
    return p


def spectral_peak_wavelength(power: np.ndarray, length: float, premultiplied: bool = False) -> float:
    """Wavelength [m] of the peak (index m >= 1) of a one-sided spectrum over ``length`` [m];
    ``premultiplied``: of m P(m), whose peak is the streak spacing (a red spectrum's raw maximum
    is at the box scale)."""
    p = np.asarray(power, dtype=np.float64)[1:]
    if premultiplied:
        p = p * np.arange(1, p.size + 1)
    return length / (1 + int(np.argmax(p)))


def damp_x_uniform_circulation(v: np.ndarray, w: np.ndarray, a: float) -> None:
    """v -= a (x-mean of v less its plane mean), w -= a (x-mean of w), in place (0 <= a <= 1)."""
    vbar = v.mean(axis=0, keepdims=True)
    v -= a * (vbar - vbar.mean(axis=1, keepdims=True))
    w -= a * w.mean(axis=0, keepdims=True)


def _merge_json(text: str | None, option: str) -> dict:
    if not text:
        return {}
    try:
        val = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{option}: not valid JSON ({exc.msg} at character {exc.pos})") from None
    if not isinstance(val, dict):
        raise ValueError(f"{option}: expected a JSON object such as '{{\"nx\": 100}}', got {text!r}")
    return val


def build_scene(case: int = 1, fidelity: str = "reduced", drive: str = "top",
                grid_json: str | None = None, overrides_json: str | None = None):
    """The probe's scene; raises ConfigError (naming the field) or ValueError (the option)."""
    from ..config import Fidelity, load_case, load_fidelity, resolve_scene, validate_model

    gov = _merge_json(grid_json, "--grid")
    cov = _merge_json(overrides_json, "--overrides")
    fid = load_fidelity(fidelity)
    if gov:
        data = fid.model_dump()
        data["grid"] = {**data["grid"], **gov}
        fid = validate_model(Fidelity, data, "--grid")
    forcing = {**cov.pop("forcing", {}), "drive": drive}
    return resolve_scene(load_case(case, overrides={**cov, "forcing": forcing}), fid)


def probe_loglaw(scene, t_end: float, window: float, roll_damping: float = 0.0,
                 log=print, on_window=None) -> dict:
    """Run ``scene`` without grains to ``t_end`` [s]; a summary per ``window`` [s] (module doc)."""
    from ..physics.laws import z0_at_fixed_u_star
    from ..solver.diagnostics.flow import fit_log_law, flow_profiles
    from ..solver.model import Model
    from ..solver.simulation import IterationInterval, Simulation, TimeInterval

    if not (window > 0 and t_end >= window):
        raise ValueError(f"window = {window} s, t_end = {t_end} s: need 0 < window <= t_end")
    if roll_damping < 0:
        raise ValueError(f"roll_damping = {roll_damping} s^-1: must be >= 0")
    m = Model.from_scene(scene)  # saltation=False: the grain component is not constructed
    g = m.grid
    Lz = g.Lz
    pg = m.drive == "pressure_gradient"
    target = scene.case.forcing.u_star_s
    u0 = math.sqrt(m.body_force * Lz) if pg else target
    kappa = m.stepper.kappa

    def u_star_expected(zz):   # u*_0 sqrt(1 - z/H) (pressure gradient) or u*s (top) [m s^-1]
        return u0 * (np.sqrt(np.clip(1 - zz / Lz, 0, 1)) if pg else np.ones_like(zz))

    hs = np.asarray(HEIGHTS)
    us_exp = u_star_expected(hs)
    k_co = int(np.argmin(np.abs(g.z_f - CO_HEIGHT)))
    k_st = int(np.argmin(np.abs(g.z_c - STREAK_HEIGHT)))
    from .._identity import __version__
    out = {"grid": [g.nx, g.ny, g.nz], "L": [g.Lx, g.Ly, Lz], "drive": m.drive,
           "heights": list(HEIGHTS), "closure": scene.case.closure.model_dump(mode="json"),
           "package_version": __version__,
           "z_ref": m.z_ref, "target": target, "roll_damping": roll_damping, "windows": []}
    log(f"log-law probe: {g.nx}x{g.ny}x{g.nz} cells, {g.Lx:g} x {g.Ly:g} x {Lz:g} m, drive {m.drive}, "
        f"target u* {target} m/s, roll damping {roll_damping} s^-1")
    acc: dict[str, np.ndarray] = {}
    n, t_win = 0, window
    wall0 = time.perf_counter()

    def damp(sim) -> None:
        damp_x_uniform_circulation(m.state.v, m.state.w, min(1.0, roll_damping * sim.last_step.dt))

    def each_second(sim) -> None:
        nonlocal acc, n, t_win
        p, dyn = flow_profiles(m), m.stepper.closure.dynamic
        new = {"u": p["u"], "uw_res": p["uw_res"], "uw_sgs": p["uw_sgs"],
               "co": streamwise_cospectrum_uw(m.state, k_co),
               "sy": spanwise_spectrum_u(m.state, k_st),
               **({"c_s": dyn.c_s, "beta": np.nan_to_num(dyn.beta)} if dyn is not None else {})}
        for key, v in new.items():
            acc[key] = acc.get(key, 0.0) + v
        n += 1
        if m.t < t_win - 1e-9:
            return
        mean = {k: v / n for k, v in acc.items()}
        z, zw, u = p["z"], p["z_w"], mean["u"]
        H = Lz if pg else None
        fits = {f"{zmax:.2f}": fit_log_law(z, u, kappa, H, FIT_Z_MIN, zmax)
                for zmax in (2.0, Lz / 3)}
        inside = hs < z[-1]                             # heights above the top level: NaN
        phi_z = kappa * z / u_star_expected(z) * np.gradient(u, z)
        phi = np.where(inside, np.interp(hs, z, phi_z), np.nan)
        tau = np.abs(acc["uw_res"] + acc["uw_sgs"]) / n
        ust = np.full(hs.size, np.nan)
        ust[inside] = np.sqrt(np.interp(hs[inside], zw, tau)) / us_exp[inside]
        co, sy = mean["co"], mean["sy"]
        lam = spectral_peak_wavelength(sy, g.Ly, premultiplied=True)
        lam_raw = spectral_peak_wavelength(sy, g.Ly)
        low = z < 0.5 * Lz
        u0_paper = math.sqrt(float(np.interp(PAPER_Z_REF, zw, tau)))
        if pg:
            u0_paper /= math.sqrt(1.0 - PAPER_Z_REF / Lz)
        z0_paper = z0_at_fixed_u_star(z, u, u0_paper, kappa, FIT_Z_MIN, PAPER_Z_REF, H)
        row = {"t": float(m.t),
               "fit": {k: {"u_star_ratio": f["u_star0"] / u0, "z0": f["z0"]} for k, f in fits.items()},
               "paper": {"u_star_ratio": u0_paper / u0, "z0": z0_paper},
               "phi": phi.tolist(),
               "u_star_stress_ratio": ust.tolist(),
               "kx0_share": float(co[0] / co.sum()) if co.sum() != 0 else math.nan,
               "phi_profile": {"z": z[low].tolist(), "phi": phi_z[low].tolist()},
               "u_spanwise": {"z": float(g.z_c[k_st]), "power": sy.tolist(),
                              "peak_wavelength": lam, "peak_over_dx": lam / g.dy,
                              "peak_wavelength_raw": lam_raw},
               "wall_s": time.perf_counter() - wall0}
        if "c_s" in mean:
            row["dynamic"] = {"z": z[low].tolist(), "c_s": mean["c_s"][low].tolist(),
                              "beta": mean["beta"][low].tolist()}
        out["windows"].append(row)
        if on_window is not None:
            on_window(out)
        fit_txt = "  ".join(f"fit 0.3-{k} m: {v['u_star_ratio']:.3f} (z0 {v['z0']:.2g} m)"
                            for k, v in row["fit"].items())
        log(f"t = {m.t - window:.0f}-{m.t:.0f} s  {fit_txt}  kx=0 share at {g.z_f[k_co]:.2f} m: "
            f"{row['kx0_share']:.2f}  wall {row['wall_s']:.0f} s")
        if "dynamic" in row:
            log("   C_s          " + " ".join(f"{v:5.3f}" for v in np.interp(hs, z, mean["c_s"])))
        log(f"   spanwise peak of u at {g.z_c[k_st]:.2f} m: {lam:.2f} m = {lam / g.dy:.1f} dy")
        log(f"   paper's reading: u* from the stress at {PAPER_Z_REF:g} m "
            f"{row['paper']['u_star_ratio']:.3f}, z0 with it {z0_paper:.2g} m")
        log("   z [m]        " + " ".join(f"{h:5.2f}" for h in hs))
        log("   phi          " + " ".join(f"{v:5.2f}" for v in row["phi"]))
        log("   u*(stress)/  " + " ".join(f"{v:5.2f}" for v in row["u_star_stress_ratio"]))
        acc, n = {}, 0
        t_win += window

    sim = Simulation(m, stop_time=t_end)
    sim.add_callback("profiles", each_second, TimeInterval(1.0, start=1.0))
    if roll_damping:
        sim.add_callback("roll_damping", damp, IterationInterval(1))
    sim.run()
    return out


def _writer(path: str):
    """A callback writing the probe's result to ``path`` atomically, or None."""
    from ..workflow.paths import write_json_atomic

    return (lambda res: write_json_atomic(Path(path), res)) if path else None


def register_probe(app) -> None:
    """Add the ``saltstudy probe`` group to the given typer app: ``loglaw`` and the other probes."""
    import typer

    from ..config import ConfigError
    from ..workflow.cli_commands import fail

    probe_app = typer.Typer(no_args_is_help=True, help="Diagnostic runs of the model (the flow "
                            "alone, the grains' layer, a run's archives).")

    @probe_app.command("loglaw")
    def loglaw(case: int = typer.Option(1, "--case", help="case number (its u*s and z0)"),
               fidelity: str = typer.Option("reduced", "--fidelity", help="fidelity (grid, time step)"),
               drive: str = typer.Option("top", "--drive", help="top or pressure_gradient"),
               t_end: float = typer.Option(300.0, "--t-end", help="simulated time, s"),
               window: float = typer.Option(100.0, "--window", help="averaging window, s"),
               grid: str = typer.Option("", "--grid", help="JSON merged into the fidelity's grid"),
               overrides: str = typer.Option("", "--overrides", help="JSON merged into the case"),
               roll_damping: float = typer.Option(0.0, "--roll-damping",
                                                  help="diagnostic: damp x-uniform v, w at this rate, 1/s"),
               as_json: bool = typer.Option(False, "--json", help="the result as one JSON object"),
               out: str = typer.Option("", "--out", help="write the result as JSON to this file after "
                                       "every window (a stopped run keeps its windows)")) -> None:
        """Windowed log-law fit, phi and stress of the particle-free surface layer."""
        try:
            scene = build_scene(case, fidelity, drive, grid, overrides)
            res = probe_loglaw(scene, t_end, window, roll_damping, on_window=_writer(out),
                               log=(lambda s: typer.echo(s, err=True)) if as_json else typer.echo)
        except (ConfigError, ValueError) as exc:
            fail(str(exc))
        if as_json:
            typer.echo(json.dumps(res))

    from .coherence_probe import register_coherence
    register_coherence(probe_app)
    from .steady_layer import register_steady_layer
    register_steady_layer(probe_app)
    from .column_budget import register_column_budget
    register_column_budget(probe_app)
    app.add_typer(probe_app, name="probe")
