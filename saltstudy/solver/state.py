"""The model state: the flow fields and clock that flow through the stepper."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .grid import Grid


class SolverBlowUp(RuntimeError):
    """A non-finite or runaway value stopped the run. The message names step, time, field, place."""

    def __init__(self, step: int, t: float, field: str, index: tuple[int, ...], value: float,
                 reason: str = "non-finite value"):
        self.step, self.t, self.field, self.index, self.value, self.reason = step, t, field, index, value, reason
        super().__init__(f"solver blow-up at step {step}, t = {t:.6g} s: {reason} in field '{field}' "
                         f"at index {tuple(int(i) for i in index)} (value {value!r})")


@dataclass
class FlowState:
    """Flow fields (grid.py; float64, or float32 in a single-precision flow) and clock: u, v, w [m
    s^-1], e, p [m^2 s^-2], u_drive [m s^-1], tke_sink None or the grains' rates [s^-1]."""

    grid: Grid
    u: np.ndarray
    v: np.ndarray
    w: np.ndarray
    e: np.ndarray
    p: np.ndarray
    t: float = 0.0
    step: int = 0
    u_drive: float = 0.0
    tke_sink: np.ndarray | None = None

    @classmethod
    def zeros(cls, grid: Grid, dtype=np.float64) -> "FlowState":
        """The fields zero, in ``dtype`` (float64, or float32 for a single-precision flow)."""
        nx, ny, nz = grid.shape
        sh, shw = (nx, ny, nz), (nx, ny, nz + 1)
        return cls(grid=grid, u=np.zeros(sh, dtype), v=np.zeros(sh, dtype), w=np.zeros(shw, dtype),
                   e=np.zeros(sh, dtype), p=np.zeros(sh, dtype))
