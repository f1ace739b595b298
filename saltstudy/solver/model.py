"""``Model``: one flow state flowing through one stepper, with components built from the scene.

See docs/ARCHITECTURE.md ("Solver API") for the contract. One step (``Model.step``):

1. each component's ``dynamics(state, dt)`` with the flow at t^n (Lie splitting; momentum a component
   adds to u, v, w is made divergence-free by the RK3 stage projections; ``state.tke_sink`` it fills
   is applied implicitly at the end of the flow step),
2. the RK3 flow step (flow/stepper.py: boundary -> advection -> diffusion -> damping -> drive -> pressure
   per stage),
3. the checks (finiteness of u, v, w, e; Courant number), raising ``SolverBlowUp``,
4. top drive only: the drive controller (forcing.py) updates ``state.u_drive`` from the stress at
   z_ref_eff. With ``forcing.drive = "pressure_gradient"`` the flow is driven by the uniform body
   force G = u*s^2 / (Lz - z_hold) (forcing.py) and there is no damping layer and no controller
   (``state.u_drive`` stays 0; the Rayleigh layer of the fidelity is not used).

A scene without saltation never imports the grain component.
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass

import numpy as np

from .diagnostics.checks import check_courant, health, locate_nonfinite
from .flow.forcing import DriveController, pressure_gradient_force, z_ref_effective
from .grid import Grid
from .spinup import SpinupResult, initial_flow, run_spinup
from .state import FlowState, SolverBlowUp
from .closures.closure import make_closure
from .flow.stepper import Boundaries, FlowNumerics, Stepper

__all__ = ["Model", "StepInfo", "SolverBlowUp", "CHECKPOINT_FORMAT"]

CHECKPOINT_FORMAT = "saltstudy-flow-1"
_FIELDS = ("u", "v", "w", "e", "p")


@dataclass(frozen=True)
class StepInfo:
    """What one step did: step number and time after it, dt [s], Courant number, drive and u*,
    its wall time [s] and the part of it spent in the components (the grains)."""
    step: int
    t: float
    dt: float
    max_cfl: float
    u_drive: float
    u_star_ref: float
    wall_time: float
    wall_components: float = 0.0


def build_stepper(scene, grid: Grid, workers: int | None = None) -> Stepper:
    """The flow stepper of a scene: the case's closure (closure.make_closure), its bed, lid and
    drive, and the fidelity's numerics."""
    case, fid = scene.case, scene.fidelity
    pg = case.forcing.drive == "pressure_gradient"
    closure = make_closure(grid, case.closure, kappa=case.air.kappa, z0=case.surface.z0,
                           nu_mol=case.air.nu)
    bounds = Boundaries(z0=case.surface.z0, kappa=case.air.kappa, damping_depth=scene.damping_depth,
                        damping_timescale=fid.grid.damping_timescale, damp_u=not pg,
                        body_force=(pressure_gradient_force(case.forcing.u_star_s, grid.Lz)
                                    if pg else 0.0))
    return Stepper(grid, closure, bounds, FlowNumerics.from_time(fid.time), workers=workers)


class Model:
    """The LES flow (and, optionally, the grain component) of one scene."""

    def __init__(self, scene, grid: Grid, stepper: Stepper, state: FlowState,
                 controller: DriveController, rng: np.random.Generator, components: list):
        self.scene = scene
        self.grid = grid
        self.stepper = stepper
        self.state = state
        self.controller = controller
        self.rng = rng
        self.components = components
        self.t_activation: float | None = None
        #: the column relaxation after activation (relaxation.py), built only when the fidelity asks
        self.relaxation = None
        self._rate_cache: tuple[int, float] | None = None
        self.drive = scene.case.forcing.drive
        #: depth of the active Rayleigh layer [m] (0 with the pressure-gradient drive)
        self.damping_depth = float(scene.damping_depth)
        self.z_ref = z_ref_effective(scene.case.forcing.z_ref, grid.Lz, self.damping_depth)
        #: the pressure-gradient body force G [m s^-2] (0 with the top drive)
        self.body_force = float(stepper.body_force)

    # ---- construction -------------------------------------------------------------------------
    @classmethod
    def from_scene(cls, scene, saltation: bool = False, restart: dict | None = None,
                   workers: int | None = None) -> "Model":
        """Build the model of ``scene``: perturbed initial flow seeded from ``case.seed``, or the
        state of ``restart`` (a ``checkpoint()`` dict) restored bit for bit. With ``saltation`` and
        ``case.physics.saltation`` the grain component is constructed (not yet activated)."""
        case, fid = scene.case, scene.fidelity
        grid = Grid.from_spec(fid.grid)
        pg = case.forcing.drive == "pressure_gradient"
        depth = scene.damping_depth
        stepper = build_stepper(scene, grid, workers)
        G = stepper.body_force
        state = FlowState.zeros(grid)
        z_ref = z_ref_effective(case.forcing.z_ref, grid.Lz, depth)
        controller = DriveController(grid, case.forcing.u_star_s, z_ref,
                                     case.forcing.controller_timescale, stepper.f_c,
                                     case.air.kappa, case.surface.z0)
        rng = np.random.default_rng(case.seed)
        components = []
        if saltation and case.physics.saltation:
            from .grains.particles import Saltation
            components.append(Saltation(grid, scene))
            if stepper.closure.dynamic is not None:
                # the grain sink's Lagrangian time T_L = tlc / sqrt(e) follows the coefficient
                components[-1].tlc = stepper.closure.dynamic.tlc
        model = cls(scene, grid, stepper, state, controller, rng, components)
        if components and fid.relaxation.on:
            from .flow.relaxation import make_relaxation
            model.relaxation = make_relaxation(scene, grid)
        if restart is None:
            if pg:
                from .diagnostics.flow import log_law_profile
                u0 = math.sqrt(G * grid.Lz)       # surface friction velocity u*_0
                prof = log_law_profile(grid.z_c, u0, case.surface.z0, case.air.kappa, H=grid.Lz)
                initial_flow(state, u0, case.surface.z0, case.air.kappa, grid.Lz, rng,
                             stepper.pressure, u_profile=prof)
                state.u_drive = 0.0
            else:
                initial_flow(state, case.forcing.u_star_s, case.surface.z0, case.air.kappa,
                             grid.Lz - fid.grid.damping_depth, rng, stepper.pressure)
                state.u_drive = controller.initial_u_drive()
        else:
            model._restore(restart)
        return model

    @property
    def t(self) -> float:
        return self.state.t

    # ---- stepping ----------------------------------------------------------------------------
    def rates(self) -> tuple[float, float]:
        """(Courant rate, diffusion rate) [s^-1] of the current state (cached per step); raises
        SolverBlowUp if a field holds a non-finite value."""
        if self._rate_cache is not None and self._rate_cache[0] == self.state.step:
            return self._rate_cache[1]
        st, clo = self.stepper, self.stepper.closure
        # the implicit vertical diffusion has no limit: only the horizontal rate counts
        c, d, nbad = health(self.grid, self.state, clo.cml, clo.cml_v, clo.nu_mol,
                            vertical=not st.implicit)
        if nbad:
            locate_nonfinite(self.state)
        self._rate_cache = (self.state.step, (c, d))
        return c, d

    def next_dt(self, limit: float = math.inf) -> float:
        """The next step [s]: min(CFL, diffusion, dt_max, components' limits, limit), or dt_fixed.

        When ``limit`` lies between dt and 2 dt, two equal steps of limit/2 are proposed rather than
        a full step followed by a sliver.
        """
        if not limit > 0:
            raise ValueError(f"next_dt: limit must be positive (got {limit!r})")
        ts = self.scene.fidelity.time
        if ts.dt_fixed is not None:
            dt = ts.dt_fixed
        else:
            rate, drate = self.rates()
            dt = ts.dt_max
            if rate > 0:
                dt = min(dt, ts.cfl / rate)
            if drate > 0:
                dt = min(dt, ts.diffusion_number / drate)
        for c in self.components:
            dt = min(dt, float(c.max_dt(self.state)))
        if limit <= dt:
            return float(limit)
        if limit < 2.0 * dt:
            return float(0.5 * limit)
        return float(dt)

    def step(self, dt: float) -> StepInfo:
        """Advance the model by dt [s]; raises SolverBlowUp on a non-finite field or CFL runaway."""
        if not (dt > 0 and math.isfinite(dt)):
            raise ValueError(f"step: dt must be positive and finite (got {dt!r})")
        t0 = time.perf_counter()
        s = self.state
        for c in self.components:
            c.dynamics(s, dt)
        t_comp = time.perf_counter() - t0
        self.stepper.step(s, dt)
        s.t += dt
        s.step += 1
        self._rate_cache = None
        rate, _ = self.rates()          # finiteness of u, v, w, e and the Courant number
        cfl = check_courant(s, rate, dt)
        tau = self._measure_stress()
        if self.relaxation is not None and self.t_activation is not None:
            self.relaxation.step(self, dt)
        if self.drive == "top":
            self.controller.update(s, dt, self.damped_mean_u(), tau)
        return StepInfo(step=s.step, t=s.t, dt=dt, max_cfl=cfl, u_drive=s.u_drive,
                        u_star_ref=math.sqrt(abs(tau)), wall_time=time.perf_counter() - t0,
                        wall_components=t_comp)

    def _measure_stress(self) -> float:
        s, st = self.state, self.stepper
        if st.wall:
            st.bed_stress_into(s.u, s.v, st.taux, st.tauy)
        return self.controller.measure(s, st.closure.cml_v, st.closure.nu_mol, st.taux)

    def damped_mean_u(self) -> np.ndarray:
        """Horizontal-mean u on the levels the drive sees (zeros elsewhere: weight zero there)."""
        out = np.zeros(self.grid.nz)
        kd = np.nonzero(self.controller.f_dz > 0)[0]
        if kd.size:
            out[kd[0]:] = self.state.u[:, :, kd[0]:].mean(axis=(0, 1))
        return out

    def spinup(self, progress=None) -> SpinupResult:
        """Flow-only spin-up until steady or t_max (spinup.py); ``progress(t, t_max)`` after every
        step. A resumable spin-up with checkpoints: ``spinup.spinup_simulation``."""
        return run_spinup(self, progress=progress)

    # ---- saltation ---------------------------------------------------------------------------
    def activate_saltation(self, reference_profile: np.ndarray | None = None) -> None:
        """Release the initial parcels (the component's ``activate``); sets ``t_activation``.
        ``reference_profile`` (nz,) [m s^-1]: the particle-free mean profile of u at this case's
        u*s, which the relaxation's profile target follows (flow/relaxation.py)."""
        if not self.components:
            raise RuntimeError("activate_saltation: this model has no grain component "
                               "(saltation=False or case.physics.saltation = false)")
        if self.relaxation is not None:
            self.relaxation.start(self, reference_profile)
        for c in self.components:
            c.activate(self.state)
        self.t_activation = float(self.state.t)

    # ---- checkpoint --------------------------------------------------------------------------
    def checkpoint(self) -> dict:
        """Pure-data restart state: fields, clock, drive, controller, RNG and components' data."""
        s = self.state
        out: dict = {"format": CHECKPOINT_FORMAT}
        for name in _FIELDS:
            out[name] = np.array(getattr(s, name), copy=True)
        out["t"] = float(s.t)
        out["step"] = int(s.step)
        out["u_drive"] = float(s.u_drive)
        out["t_activation"] = math.nan if self.t_activation is None else float(self.t_activation)
        out["rng_state"] = json.dumps(self.rng.bit_generator.state)
        if s.tke_sink is not None:
            out["tke_sink"] = np.array(s.tke_sink, copy=True)
        for k, v in self.controller.checkpoint().items():
            out[f"controller/{k}"] = v
        for k, v in self.stepper.closure.checkpoint().items():
            out[f"closure/{k}"] = v
        for c in self._checkpointed_parts():
            for k, v in c.checkpoint().items():
                out[f"{c.name}/{k}"] = v
        return out

    def _checkpointed_parts(self) -> list:
        """Parts with their own ``name``, ``checkpoint()`` and ``restore()`` (keys ``name/...``)."""
        return self.components + ([self.relaxation] if self.relaxation is not None else [])

    def _restore(self, ck: dict) -> None:
        fmt = ck.get("format", CHECKPOINT_FORMAT)
        if str(fmt) != CHECKPOINT_FORMAT:
            raise ValueError(f"restart: unknown checkpoint format {fmt!r} (expected {CHECKPOINT_FORMAT})")
        s = self.state
        for name in _FIELDS:
            a = np.asarray(ck[name], dtype=np.float64)
            dst = getattr(s, name)
            if a.shape != dst.shape:
                raise ValueError(f"restart: field '{name}' has shape {a.shape}, the scene's grid "
                                 f"needs {dst.shape}")
            dst[...] = a
        s.t = float(ck["t"])
        s.step = int(ck["step"])
        s.u_drive = float(ck["u_drive"])
        ta = float(ck.get("t_activation", math.nan))
        self.t_activation = None if math.isnan(ta) else ta
        if "rng_state" in ck:
            self.rng.bit_generator.state = json.loads(str(ck["rng_state"]))
        if "tke_sink" in ck:
            s.tke_sink = np.array(ck["tke_sink"], dtype=np.float64)
        ctl = {k.split("/", 1)[1]: v for k, v in ck.items() if k.startswith("controller/")}
        if ctl:
            self.controller.restore(ctl)
        clo = {k.split("/", 1)[1]: v for k, v in ck.items() if k.startswith("closure/")}
        if clo:
            self.stepper.closure.restore(clo)
        for c in self._checkpointed_parts():
            pre = f"{c.name}/"
            data = {k[len(pre):]: v for k, v in ck.items() if k.startswith(pre)}
            if data:
                c.restore(data)

    def close(self) -> None:
        self.stepper.close()
