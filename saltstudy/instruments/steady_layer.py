"""The splash law's own steady saltation layer, in 1-D and without the LES
(``saltstudy probe steady-layer``; docs/USAGE.md).

Test grains hop over a flat bed in a horizontally uniform wind u(z): each impact is splashed by the
paper's law (eqs. 6-9, physics.splash.splash_impacts), each grain flown with its drag (eqs. 3-4,
physics.drag) to its next impact on the 0.5 mm layer, and the wind is the mixing-length profile of
the stress the grains leave to the air (Owen 1964; as in Werner 1990 and Kok & Renno 2009)::

    du/dz = sqrt(tau_a(z) / rho) / (kappa z),    tau_a(z) = rho u*s^2 - tau_g(z),   u(z0) = 0.

Where the grains would take more than rho u*s^2 the air stress is clipped at zero and the layer is
not converged (from u*s ~ 0.65 m/s up with the paper's law). The unknown is the impact rate R
[m^-2 s^-1]; each generation R is multiplied by lambda^BETA (lambda: grains launched per impact)
and the wind relaxed towards its profile, until lambda = 1.
"""
from __future__ import annotations

import json
import math
from collections import deque
from dataclasses import asdict, dataclass, field

import numpy as np

from .._jit import jit
from ..config import Soil, SoilMode, Splash
from ..physics.drag import (drag_correction, particle_response_time, particle_reynolds,
                            relaxation, relaxed_position)
from ..physics.soil import sample_diameters, soil_arrays
from ..physics.splash import splash_constants, splash_impacts

#: multiplier exponent of the impact rate per generation: R <- R lambda^BETA
BETA = 0.5
#: relaxation of the wind towards the profile of the present drag, per generation
OMEGA = 0.3
#: a grain still flying after this long [s] is left out (suspension; not reached by sand)
T_MAX = 5.0


@dataclass(frozen=True)
class LayerParams:
    """Everything the steady layer depends on (SI): wind, one-mode soil, air, splash."""
    u_star: float = 0.54
    mu: float = 200e-6
    sigma: float = 1.2
    rho_p: float = 2650.0
    rho: float = 1.2
    nu: float = 1.5e-5
    g: float = 9.81
    kappa: float = 0.40
    z0: float = 1.0e-5
    splash: Splash = field(default_factory=Splash)
    n_impacts: int = 4000
    dt: float = 5.0e-5
    z_top: float = 3.0
    n_levels: int = 240

    def __post_init__(self):
        for name in ("u_star", "mu", "rho_p", "rho", "nu", "g", "z0", "dt"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name}={getattr(self, name)!r}: must be > 0")
        if self.sigma < 1.0:
            raise ValueError(f"sigma={self.sigma!r}: a geometric standard deviation is >= 1")
        if self.n_impacts < 100:
            raise ValueError(f"n_impacts={self.n_impacts!r}: at least 100 for a statistic")

    @classmethod
    def from_case(cls, case, u_star: float | None = None, **kw) -> "LayerParams":
        """The steady layer of a config.Case with a one-mode soil (at ``u_star`` if given)."""
        if len(case.soil.modes) != 1:
            raise ValueError("soil.modes: the steady layer takes a one-mode soil")
        mode, air = case.soil.modes[0], case.air
        return cls(u_star=case.forcing.u_star_s if u_star is None else u_star, mu=mode.mu,
                   sigma=mode.sigma, rho_p=case.soil.rho_p, rho=air.rho, nu=air.nu, g=air.g,
                   kappa=air.kappa, z0=case.surface.z0, splash=case.splash, **kw)

    @property
    def h_imp(self) -> float:
        """The impact layer's depth [m]."""
        return self.splash.impact_layer

    def soil(self) -> Soil:
        return Soil(modes=(SoilMode(mu=self.mu, sigma=self.sigma),), rho_p=self.rho_p)


@dataclass
class SteadyLayer:
    """The steady layer (module doc); per unit bed area, SI."""
    params: dict
    converged: bool
    generations: int
    growth: float                 # mean launched grains per impact over the averaging window
    growth_se: float
    impact_rate: float            # R [m^-2 s^-1]
    bed_fluid_fraction: float     # tau_a(0) / (rho u*^2)
    u_star_bed: float             # sqrt(tau_a(0) / rho) [m s^-1]
    airborne_mass: float          # M [kg m^-2]
    flux: float                   # G_tot [kg m^-1 s^-1]
    tau_g_bed: float              # tau_g(0) = R x the drag a generation's grains receive [Pa]
    tau_g_impacts: float          # R <m du> at the bed [Pa] (equal to tau_g_bed when steady)
    mu_b: float                   # tau_g(0) / (M g)
    mu_b_impacts: float           # <m du> / <m dw> at the bed
    impact_speed_mean: float      # [m s^-1], over impacts
    impact_angle_mean: float      # [deg]
    hop_time_mean: float          # [s], over launched grains (mass-weighted)
    grain_speed_mean: float       # G_tot / M [m s^-1]
    decay_height: float           # e-folding height of the mass flux profile above 1 cm [m]
    replacement_by_speed: dict = field(default_factory=dict)
    wind: dict = field(default_factory=dict)


def log_wind(zn: np.ndarray, u_star: float, kappa: float, z0: float) -> np.ndarray:
    """u(z) = u*/kappa ln(z/z0) on the nodes (0 at and below z0)."""
    return np.maximum(u_star / kappa * np.log(np.maximum(zn, z0) / z0), 0.0)


def wind_from_stress(zn: np.ndarray, tau_a: np.ndarray, rho: float, kappa: float) -> np.ndarray:
    """The mixing-length profile: u(z0) = 0 and du/dln z = sqrt(tau_a / rho) / kappa, integrated
    by the trapezoidal rule in ln z on the nodes (tau_a clipped at zero)."""
    us = np.sqrt(np.maximum(tau_a, 0.0) / rho) / kappa
    dl = np.diff(np.log(zn))
    return np.concatenate([[0.0], np.cumsum(0.5 * (us[1:] + us[:-1]) * dl)])


@jit
def _wind_at(z, lz0, idl, nz, un, u_star_top, kappa, z_top):
    """Wind at height z from the nodes (linear in ln z); the log law of u*s above the top."""
    if z <= 0.0:
        return 0.0
    s = (math.log(z) - lz0) * idl
    if s <= 0.0:
        return 0.0
    i = int(s)
    if i >= nz - 1:
        return un[nz - 1] + u_star_top / kappa * math.log(z / z_top)
    f = s - i
    return un[i] * (1.0 - f) + un[i + 1] * f


@jit
def fly_grains(u0, v0, w0, d, un, lz0, idl, u_star_top, z_top, kappa, rho, nu, rho_p, g, h_imp, dt,
               t_max, drag_bin, mass_time_bin, flux_bin, out):
    """Fly each grain from the impact layer's top until it crosses it downwards, the drag
    integrated exactly over each step (physics.drag). ``out`` per grain: (flight time, impact u,
    v, w, hop length, landed); the ln-z bins collect the drag impulse m du, m dt and m u dt."""
    nz = un.shape[0]
    for i in range(u0.shape[0]):
        di = d[i]
        m = math.pi / 6.0 * rho_p * di * di * di
        tp = particle_response_time(di, rho_p, rho, nu)
        x, z, u, v, w, t, landed = 0.0, h_imp, u0[i], v0[i], w0[i], 0.0, 0.0
        while t < t_max:
            uf = _wind_at(z, lz0, idl, nz, un, u_star_top, kappa, z_top)
            rel = math.sqrt((uf - u) ** 2 + v * v + w * w)
            ik = tp / drag_correction(particle_reynolds(rel, di, nu))
            wt = -g * ik
            un_, vn, wn, omk = relaxation(math.expm1(-dt / ik), ik, uf, 0.0, wt, u, v, w)
            zn = relaxed_position(z, wt, w, dt, omk)
            xn = relaxed_position(x, uf, u, dt, omk)
            s = (math.log(z) - lz0) * idl if z > 0.0 else -1.0
            b = int(s) if s >= 0.0 else -1
            if b >= 0 and b < nz - 1:
                drag_bin[b] += m * (un_ - u)
                mass_time_bin[b] += m * dt
                flux_bin[b] += m * 0.5 * (u + un_) * dt
            if zn < h_imp:
                f = (z - h_imp) / (z - zn)
                out[i, 0] = t + f * dt
                out[i, 1] = u + f * (un_ - u)
                out[i, 2] = v + f * (vn - v)
                out[i, 3] = w + f * (wn - w)
                out[i, 4] = x + f * (xn - x)
                landed = 1.0
                break
            x, z, u, v, w = xn, zn, un_, vn, wn
            t += dt
        out[i, 5] = landed


def splash_generation(rng, p: LayerParams, ui, vi, wi, di):
    """Splash the impacts by eqs. 6-9: (launch u, v, w, d, parent index, per-impact streamwise
    and vertical momentum given to the bed)."""
    n = ui.size
    soil = p.soil()
    launch, parent = splash_impacts(rng, ui, vi, wi, di, splash_constants(p.splash, soil, p.g),
                                    *soil_arrays(soil))
    u, v, w, d = launch.T
    m_imp = np.pi / 6.0 * p.rho_p * di ** 3
    m_out = np.pi / 6.0 * p.rho_p * d ** 3
    px = m_imp * ui - np.bincount(parent, weights=m_out * u, minlength=n)
    pz = m_imp * np.abs(wi) + np.bincount(parent, weights=m_out * w, minlength=n)
    return u, v, w, d, parent, px, pz


def solve_steady_layer(p: LayerParams, seed: int = 1, generations: int = 160, average: int = 60,
                       bed_fluid_fraction: float | None = None) -> SteadyLayer:
    """Relax the layer to its steady state and average over the last ``average`` generations.
    With ``bed_fluid_fraction`` the impact rate is held where the grains take (1 - it) rho u*^2,
    and ``growth`` says whether the splash law sustains that layer."""
    if bed_fluid_fraction is not None and not 0.0 <= bed_fluid_fraction < 1.0:
        raise ValueError(f"bed_fluid_fraction={bed_fluid_fraction!r}: must be in [0, 1)")
    rng = np.random.default_rng(seed)
    # log-spaced wind nodes from z0 to z_top (the bins between them collect the drag)
    zn = np.exp(np.linspace(math.log(p.z0), math.log(p.z_top), p.n_levels))
    nz = zn.size
    lz0 = math.log(zn[0])
    idl = 1.0 / (math.log(zn[1]) - lz0)
    dz = np.diff(zn)
    rho_u2 = p.rho * p.u_star ** 2
    un = log_wind(zn, p.u_star, p.kappa, p.z0)
    # first impacts: grains falling at 1 m/s at 20 degrees
    n = p.n_impacts
    ui, vi, wi = np.full(n, 0.94), np.zeros(n), np.full(n, -0.34)
    di = sample_diameters(p.soil(), rng, n)
    m_mean = np.pi / 6.0 * p.rho_p * p.mu ** 3
    R = 0.05 * rho_u2 / (m_mean * 1.0)   # a twentieth of Owen's rate: the layer grows from below
    keep: deque[dict] = deque(maxlen=average)
    for _ in range(generations):
        u, v, w, d, parent, px, pz = splash_generation(rng, p, ui, vi, wi, di)
        drag_bin, mt_bin, fl_bin = np.zeros(nz - 1), np.zeros(nz - 1), np.zeros(nz - 1)
        out = np.zeros((u.size, 6))
        fly_grains(u, v, w, d, un, lz0, idl, p.u_star, p.z_top, p.kappa, p.rho, p.nu, p.rho_p, p.g,
                   p.h_imp, p.dt, T_MAX, drag_bin, mt_bin, fl_bin, out)
        landed = out[:, 5] > 0
        lam = landed.sum() / n
        m_l = np.pi / 6.0 * p.rho_p * d ** 3
        # per impact: the bed's share and what the launched grains do until they land
        rec = {"lam": lam, "R": R, "px": px.mean(), "pz": pz.mean(),
               "mT": float(np.sum(m_l[landed] * out[landed, 0])) / n,
               "m": float(np.sum(m_l[landed])) / n,
               "mL": float(np.sum(m_l[landed] * out[landed, 4])) / n,
               "drag": drag_bin / n, "mt": mt_bin / n, "fl": fl_bin / n,
               "v_imp": np.sqrt(ui ** 2 + vi ** 2 + wi ** 2),
               "angle": np.degrees(np.arctan2(-wi, np.hypot(ui, vi))),
               "offspring": np.bincount(parent, minlength=n)}
        keep.append(rec)
        # the layer's response: the impact rate follows the growth, the wind the drag
        if bed_fluid_fraction is None:
            R *= min(max(lam, 0.5), 2.0) ** BETA
        else:
            drag_per_impact = float(rec["drag"].sum())
            if drag_per_impact > 0:
                target = (1.0 - bed_fluid_fraction) * rho_u2 / drag_per_impact
                R *= min(max(target / R, 0.5), 2.0) ** BETA
        tau_g = R * np.concatenate([np.cumsum(rec["drag"][::-1])[::-1], [0.0]])
        u_new = wind_from_stress(zn, rho_u2 - tau_g, p.rho, p.kappa)
        un = (1.0 - OMEGA) * un + OMEGA * u_new
        # the next generation: n impacts drawn from the landings
        idx = np.nonzero(landed)[0]
        if idx.size == 0:
            break
        pick = rng.choice(idx, n, replace=True)
        ui, vi, wi, di = out[pick, 1], out[pick, 2], out[pick, 3], d[pick]

    def mean(name: str):
        """The mean of a record over the averaged generations."""
        return np.mean([k[name] for k in keep], axis=0)

    lam_k = np.array([k["lam"] for k in keep])
    Rm = float(mean("R"))
    tau_g0 = Rm * float(mean("drag").sum())
    M, G = Rm * float(mean("mT")), Rm * float(mean("mL"))
    px, pz = float(mean("px")), float(mean("pz"))
    fl = Rm * mean("fl") / dz        # mass flux density [kg m-2 s-1]
    zc = np.sqrt(zn[1:] * zn[:-1])
    sel = (zc > 0.01) & (fl > 1e-6 * max(fl.max(), 1e-300))
    decay = math.nan
    if sel.sum() >= 4:
        slope = np.polyfit(zc[sel], np.log(fl[sel]), 1)[0]
        decay = -1.0 / slope if slope < 0 else math.nan
    v_imp = np.concatenate([k["v_imp"] for k in keep])
    offs = np.concatenate([k["offspring"] for k in keep])
    edges = np.arange(0.0, 4.01, 0.25)
    b = np.digitize(v_imp, edges) - 1
    rep = {f"{edges[j]:.2f}-{edges[j + 1]:.2f}": float(offs[b == j].mean())
           for j in range(edges.size - 1) if (b == j).sum() >= 50}
    tau_bed = max(rho_u2 - tau_g0, 0.0)
    lam_se = float(lam_k.std(ddof=1) / math.sqrt(lam_k.size)) if lam_k.size > 1 else math.nan
    return SteadyLayer(
        # a layer whose grains take more than rho u*^2 has a wind the clipped air stress cannot
        # give (momentum is not conserved there): not a steady state of the model
        params={**asdict(p), "splash": p.splash.model_dump()},
        converged=bool(tau_g0 <= 1.02 * rho_u2 and (
            abs(lam_k.mean() - 1.0) < 3 * lam_se + 0.01 if bed_fluid_fraction is None
            else abs(tau_bed / rho_u2 - bed_fluid_fraction) < 0.02)),
        generations=len(keep), growth=float(lam_k.mean()), growth_se=lam_se,
        impact_rate=Rm, bed_fluid_fraction=tau_bed / rho_u2, u_star_bed=math.sqrt(tau_bed / p.rho),
        airborne_mass=M, flux=G, tau_g_bed=tau_g0, tau_g_impacts=Rm * px,
        mu_b=tau_g0 / (M * p.g) if M > 0 else math.nan,
        mu_b_impacts=px / pz if pz > 0 else math.nan,
        impact_speed_mean=float(v_imp.mean()),
        impact_angle_mean=float(np.concatenate([k["angle"] for k in keep]).mean()),
        hop_time_mean=float(mean("mT")) / float(mean("m")),
        grain_speed_mean=G / M if M > 0 else math.nan, decay_height=decay,
        replacement_by_speed=rep,
        wind={"z": zn[::8].tolist(), "u": un[::8].tolist()})


def register_steady_layer(probe_app) -> None:
    """``saltstudy probe steady-layer``."""
    import typer

    from ..config import ConfigError, load_case
    from ..workflow.cli_commands import fail

    @probe_app.command("steady-layer")
    def steady_layer_cmd(
        case: int = typer.Option(2, "--case", help="case number (its u*s, soil, splash)"),
        u_star: float = typer.Option(None, "--u-star", help="u*s above the layer [m s^-1] "
                                     "(default: the case's)"),
        overrides: str = typer.Option("", "--overrides", help="JSON merged into the case, e.g. "
                                      '\'{"splash": {"impact_speed": "normal"}}\''),
        n_impacts: int = typer.Option(4000, "--n", help="impacts per generation"),
        generations: int = typer.Option(160, "--generations", help="generations in all"),
        average: int = typer.Option(60, "--average", help="the last generations averaged"),
        bed_fluid_fraction: float = typer.Option(None, "--bed-fluid-fraction", help="hold the "
                                                 "bed's share of rho u*^2 here and report the "
                                                 "growth per generation instead"),
        seed: int = typer.Option(1, "--seed"),
        as_json: bool = typer.Option(False, "--json", help="one JSON object on stdout"),
    ):
        """The splash law's steady layer in 1-D (mixing-length wind, no LES): the bed's fluid
        stress, airborne mass, flux and mu_b the law holds at u*s."""
        try:
            c = load_case(case, overrides=json.loads(overrides) if overrides else None)
            p = LayerParams.from_case(c, u_star, n_impacts=n_impacts)
            if not 0 < average <= generations:
                raise ValueError(f"--average {average}: between 1 and --generations "
                                 f"({generations})")
        except (ConfigError, ValueError) as e:
            fail(str(e))
        res = solve_steady_layer(p, seed=seed, generations=generations, average=average,
                                 bed_fluid_fraction=bed_fluid_fraction)
        d = asdict(res)
        if as_json:
            typer.echo(json.dumps(d))
            return
        for k in ("growth", "impact_rate", "bed_fluid_fraction", "u_star_bed", "airborne_mass",
                  "flux", "mu_b", "mu_b_impacts", "impact_speed_mean", "impact_angle_mean",
                  "hop_time_mean", "grain_speed_mean", "decay_height"):
            typer.echo(f"{k:>20}: {d[k]:.4g}")
