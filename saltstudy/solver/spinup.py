"""Initial state of the flow and the flow-only spin-up with its steadiness test.

``initial_flow``: the log law up to the top of the free region (constant above), e = u*^2 (1 -
z/z_top), and perturbations that trip turbulence quickly: Gaussian noise (the case's seed)
smoothed over a few cells, r.m.s. ``amplitude`` u* tapered to zero at z_top, and streamwise
streaks (the paper's 0.7 m streamer spacing), made divergence-free; the sheared profile does the
rest within a few turnover times (H/u* ~ 10 s).

``SteadinessRecord``: u* at z_ref_eff and the volume-mean resolved TKE of the free region,
recorded at intervals; after t_min the spin-up is steady when both means over the last window
and the one before differ by less than spinup.tolerance (relative), else it stops at t_max.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class SpinupResult:
    """Outcome of a spin-up: converged, end time [s], why it stopped, history ``t`` [s],
    ``u_star`` [m s^-1], ``tke`` [m^2 s^-2], ``u_drive`` [m s^-1]."""
    converged: bool
    t: float
    reason: str
    history: dict[str, np.ndarray] = field(default_factory=dict)


def smooth_noise(rng: np.random.Generator, shape: tuple[int, int, int], passes: int = 3) -> np.ndarray:
    """Unit-variance Gaussian noise smoothed by ``passes`` 1-2-1 filters in x and y (periodic)."""
    a = rng.standard_normal(shape)
    for _ in range(passes):
        a = 0.25 * (np.roll(a, 1, 0) + 2 * a + np.roll(a, -1, 0))
        a = 0.25 * (np.roll(a, 1, 1) + 2 * a + np.roll(a, -1, 1))
    return a / max(a.std(), 1e-300)


def initial_flow(state, u_star: float, z0: float, kappa: float, z_top: float,
                 rng: np.random.Generator, pressure, amplitude: float = 1.0,
                 streak_spacing: float = 0.7, u_profile: np.ndarray | None = None) -> None:
    """Fill ``state`` with the perturbed log profile, or ``u_profile`` (nz,) (module doc)."""
    g = state.grid
    zc, zf = g.z_c, g.z_f
    nx, ny, nz = g.shape
    if u_profile is None:
        u_log = u_star / kappa * np.log(np.maximum(np.minimum(zc, z_top), 2 * z0) / z0)
    else:
        u_log = np.asarray(u_profile, dtype=np.float64)
    taper_c = np.clip(1.0 - zc / z_top, 0.0, 1.0) ** 2
    taper_f = np.clip(1.0 - zf / z_top, 0.0, 1.0) ** 2
    amp = amplitude * u_star
    state.u[...] = u_log + amp * taper_c * smooth_noise(rng, (nx, ny, nz))
    state.v[...] = amp * taper_c * smooth_noise(rng, (nx, ny, nz))
    wn = smooth_noise(rng, (nx, ny, nz + 1))
    state.w[...] = 0.5 * amp * taper_f * wn
    state.w[..., 0] = 0.0
    state.w[..., -1] = 0.0
    # streamwise streaks: u' ~ cos(2 pi y / lambda) with a random phase, strongest near z ~ 0.2-1 m
    n_streak = max(1, int(round(g.Ly / streak_spacing)))
    phase = rng.uniform(0, 2 * np.pi)
    yy = g.y_c
    prof = (zc / 0.5) * np.exp(1.0 - zc / 0.5) * taper_c
    state.u[...] += amp * np.cos(2 * np.pi * n_streak * yy / g.Ly + phase)[None, :, None] * prof[None, None, :]
    pressure.project(state.u, state.v, state.w)
    state.e[...] = np.maximum(u_star**2 * np.clip(1.0 - zc / z_top, 0.0, 1.0), 1e-10)
    state.p[...] = 0.0


def window_steadiness(t: np.ndarray, series: dict[str, np.ndarray], t_now: float, window: float
                      ) -> dict[str, float] | None:
    """Relative change of each series' mean between [t-2W, t-W) and [t-W, t]; None if too short."""
    if t.size == 0 or t_now - t[0] < 2 * window - 1e-9:
        return None
    m1 = (t >= t_now - 2 * window) & (t < t_now - window)
    m2 = t >= t_now - window
    if m1.sum() < 2 or m2.sum() < 2:
        return None
    out = {}
    for k, s in series.items():
        a, b = float(np.mean(s[m1])), float(np.mean(s[m2]))
        out[k] = abs(b - a) / max(abs(b), 1e-300)
    return out


#: the spin-up's record series (``SpinupResult.history``)
HISTORY_KEYS = ("t", "u_star", "tke", "u_drive")


def record_interval(spinup) -> float:
    """Model time between the spin-up's records [s] (``spinup``: the fidelity's SpinUp)."""
    return min(spinup.window / 50.0, 1.0)


class SteadinessRecord:
    """The spin-up's record and steadiness test (module doc); stops the simulation once steady."""

    def __init__(self, model):
        self.model = model
        self.spinup = model.scene.fidelity.spinup
        self.series: dict[str, list[float]] = {k: [] for k in HISTORY_KEYS}
        self.why: str | None = None

    def __call__(self, sim) -> None:
        from .diagnostics.flow import resolved_tke_volume_mean, u_star_at

        m, h = self.model, self.series
        t_rel = sim.t
        h["t"].append(t_rel)
        h["u_star"].append(u_star_at(m, m.z_ref))
        h["tke"].append(resolved_tke_volume_mean(m))
        h["u_drive"].append(m.state.u_drive)
        self.why = self._steady(t_rel)
        if self.why is not None:
            sim.stop(self.why)

    def _steady(self, t_rel: float) -> str | None:
        sp, h = self.spinup, self.series
        if t_rel < sp.t_min - 1e-9:
            return None
        ch = window_steadiness(np.asarray(h["t"]), {"u_star": np.asarray(h["u_star"]),
                                                    "tke": np.asarray(h["tke"])}, t_rel, sp.window)
        if ch is None or max(ch.values()) >= sp.tolerance:
            return None
        return (f"steady at t = {t_rel:.1f} s: window-mean change of u* {100 * ch['u_star']:.2f} %, "
                f"resolved TKE {100 * ch['tke']:.2f} % (< {100 * sp.tolerance:g} %)")

    def checkpoint(self) -> dict[str, np.ndarray]:
        return {k: np.asarray(v, dtype=np.float64) for k, v in self.series.items()}

    def restore(self, data: dict[str, np.ndarray]) -> None:
        self.series = {k: [float(x) for x in np.asarray(data[k])] for k in HISTORY_KEYS}

    def result(self, sim) -> SpinupResult:
        """What the spin-up did, once ``sim.run()`` has returned."""
        hist = {k: np.asarray(v) for k, v in self.series.items()}
        return SpinupResult(converged=self.why is not None, t=float(sim.t),
                            reason=self.why or f"t_max = {self.spinup.t_max:g} s reached",
                            history=hist)


def spinup_simulation(model, record_every: float | None = None):
    """(Simulation, SteadinessRecord) of the spin-up to t_max; callers add their own callbacks."""
    from .simulation import Simulation, TimeInterval

    sp = model.scene.fidelity.spinup
    every = record_every if record_every is not None else record_interval(sp)
    sim = Simulation(model, stop_time=sp.t_max)
    rec = SteadinessRecord(model)
    sim.add_callback("steadiness", rec, TimeInterval(every, from_last=True))
    return sim, rec


def run_spinup(model, progress=None, record_every: float | None = None) -> SpinupResult:
    """Step ``model`` until steady or t_max; ``progress(t, t_max)`` after every step."""
    from .simulation import IterationInterval

    sim, rec = spinup_simulation(model, record_every)
    if progress is not None:
        sim.add_callback("progress", lambda s: progress(s.t, s.stop_time), IterationInterval(1))
    sim.run()
    return rec.result(sim)
