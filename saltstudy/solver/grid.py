"""The staggered (Arakawa-C) grid: uniform in x and y, stretched in z, periodic in x and y, no
ghost cells (layout: docs/ARCHITECTURE.md, "Grid layout"). u[i, j, k] at (x_f[i], y_c[j],
z_c[k]), v at (x_c, y_f, z_c), w (nx, ny, nz + 1) at (x_c, y_c, z_f) with w = 0 on faces 0 and
nz, p and e at the centres; z_f[0] = 0 (the bed), z_f[nz] = Lz.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..config import GridSpec


def stretched_levels(Lz: float, nz: int, dz_bottom: float, dz_top: float | None = None) -> np.ndarray:
    """Face heights z_f (nz + 1,) [m], cubic in k: z_f(1) = dz_bottom, z_f(nz) = Lz and, given
    ``dz_top``, the top thickness (the paper: 1 cm, 0.23 m at 12 m over 100 levels)."""
    n = float(nz)
    if dz_top is None:
        # a + c = dz_b ; a n + c n^3 = Lz
        A = np.array([[1.0, 1.0], [n, n**3]])
        a, c = np.linalg.solve(A, [dz_bottom, Lz])
        b = 0.0
    else:
        A = np.array([[1.0, 1.0, 1.0], [n, n**2, n**3], [1.0, 2 * n - 1, 3 * n**2 - 3 * n + 1]])
        a, b, c = np.linalg.solve(A, [dz_bottom, Lz, dz_top])
    k = np.arange(nz + 1, dtype=np.float64)
    z_f = a * k + b * k**2 + c * k**3
    z_f[0] = 0.0
    z_f[-1] = Lz
    if np.any(np.diff(z_f) <= 0):
        raise ValueError(f"no monotonic cubic grid with nz={nz}, Lz={Lz}, dz_bottom={dz_bottom}, "
                         f"dz_top={dz_top}")
    return z_f


class _cached_array(cached_property):
    """A per-grid cached derived array, read-only since every caller shares it."""

    def __get__(self, instance, owner=None):
        a = super().__get__(instance, owner)
        if instance is not None and a.flags.writeable:
            a.setflags(write=False)
        return a


@dataclass(frozen=True, eq=False)
class Grid:
    """Geometry of the staggered grid (module doc)."""

    nx: int
    ny: int
    nz: int
    Lx: float
    Ly: float
    z_f: np.ndarray = field(repr=False)

    @classmethod
    def from_spec(cls, spec: GridSpec) -> "Grid":
        z_f = stretched_levels(spec.Lz, spec.nz, spec.dz_bottom, spec.dz_top)
        return cls(spec.nx, spec.ny, spec.nz, spec.Lx, spec.Ly, z_f)

    @classmethod
    def uniform(cls, nx: int, ny: int, nz: int, Lx: float, Ly: float, Lz: float) -> "Grid":
        return cls(nx, ny, nz, Lx, Ly, np.linspace(0.0, Lz, nz + 1))

    def __post_init__(self) -> None:
        z_f = np.ascontiguousarray(self.z_f, dtype=np.float64)
        object.__setattr__(self, "z_f", z_f)
        if z_f.shape != (self.nz + 1,) or z_f[0] != 0.0 or np.any(np.diff(z_f) <= 0):
            raise ValueError("z_f must hold nz + 1 increasing heights starting at 0")

    @property
    def dx(self) -> float:
        return self.Lx / self.nx

    @property
    def dy(self) -> float:
        return self.Ly / self.ny

    @_cached_array
    def x_f(self) -> np.ndarray:
        return np.arange(self.nx) * self.dx

    @_cached_array
    def x_c(self) -> np.ndarray:
        return (np.arange(self.nx) + 0.5) * self.dx

    @_cached_array
    def y_f(self) -> np.ndarray:
        return np.arange(self.ny) * self.dy

    @_cached_array
    def y_c(self) -> np.ndarray:
        return (np.arange(self.ny) + 0.5) * self.dy

    @property
    def Lz(self) -> float:
        return float(self.z_f[-1])

    @_cached_array
    def z_c(self) -> np.ndarray:
        """Cell-centre heights (nz,) [m]."""
        return 0.5 * (self.z_f[1:] + self.z_f[:-1])

    @_cached_array
    def dz_c(self) -> np.ndarray:
        """Cell thickness z_f[k+1] - z_f[k] (nz,) [m]."""
        return np.diff(self.z_f)

    @_cached_array
    def dz_f(self) -> np.ndarray:
        """Distance between the centres either side of face k (nz + 1,) [m]; end faces: half cells."""
        zc = self.z_c
        d = np.empty(self.nz + 1)
        d[1:-1] = np.diff(zc)
        d[0] = zc[0]
        d[-1] = self.Lz - zc[-1]
        return d

    @_cached_array
    def rdz_c(self) -> np.ndarray:
        """1 / dz_c (nz,) [m^-1]: the stencils multiply (a division per point and level costs)."""
        return 1.0 / self.dz_c

    @_cached_array
    def rdz_f(self) -> np.ndarray:
        """1 / dz_f (nz + 1,) [m^-1]."""
        return 1.0 / self.dz_f

    @_cached_array
    def cell_volume(self) -> np.ndarray:
        """Volume of each layer's cells (nz,) [m^3]."""
        return self.dx * self.dy * self.dz_c

    @property
    def shape(self) -> tuple[int, int, int]:
        return (self.nx, self.ny, self.nz)

    @property
    def n_cells(self) -> int:
        return self.nx * self.ny * self.nz

