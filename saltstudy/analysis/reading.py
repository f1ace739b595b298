"""Reading a case's archives for the analysis: ``samples.nc`` and ``spinup.nc`` as arrays.

The large variables (``LAZY_VARIABLES``) are read slice by slice (:class:`LazyVar`,
:class:`Rows`); :class:`Frame` holds what every statistic shares. The sampling window runs from
the first to the last 3-D sample (one sample: to the end of the run), the planes with it.
"""
from __future__ import annotations

import json
import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..ncio import NC_LOCK

__all__ = ["LAZY_VARIABLES", "PLANE_CHUNK", "LazyVar", "Rows", "read_archive", "attr_float",
           "case_info", "time_mean", "time_sum", "check_parcel_counts", "rescale_spinup_profiles",
           "as_arrays", "Frame", "frame_of"]

log = logging.getLogger(__name__)

#: large variables read slice by slice (a 3-D sample, a plane height, a block of planes) rather
#: than whole: at the paper's fidelity u_plane alone is several GB
LAZY_VARIABLES = ("u", "G_col", "u_plane")
#: planes read at once where a statistic runs over the planes in blocks (memory)
PLANE_CHUNK = 256


class _Shaped:
    shape: tuple[int, ...]

    @property
    def ndim(self) -> int:
        return len(self.shape)


class LazyVar(_Shaped):
    """A variable of an archive whose slices are read on indexing (each read under NC_LOCK)."""

    def __init__(self, path: str | Path, name: str, shape: tuple[int, ...]):
        self.path, self.name, self.shape = str(path), name, tuple(shape)

    def __getitem__(self, key) -> np.ndarray:
        with NC_LOCK, xr.open_dataset(self.path, engine="netcdf4") as ds:
            return np.asarray(ds[self.name][key].values)


def read_archive(path: str | Path, keep: tuple[str, ...] | None,
                 lazy: tuple[str, ...] = ()) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any]]:
    """(attrs, coords, variables) of an archive, reading only ``keep`` variables (all if None);
    the ``lazy`` ones become :class:`LazyVar` handles."""
    with NC_LOCK, xr.open_dataset(path, engine="netcdf4") as ds:
        coords = {k: np.asarray(ds[k].values) for k in ds.coords}
        data = {v: LazyVar(path, v, ds[v].shape) if v in lazy else np.asarray(ds[v].values)
                for v in ds.data_vars if keep is None or v in keep}
        return dict(ds.attrs), coords, data


class Rows(_Shaped):
    """Rows ``start:stop`` of an array or a lazy variable (first axis), indexed like a whole one."""

    def __init__(self, base, start: int, stop: int):
        self.base, self.start, self.stop = base, int(start), int(stop)
        self.shape = (self.stop - self.start,) + tuple(base.shape[1:])

    def __getitem__(self, key):
        k0, rest = (key[0], key[1:]) if isinstance(key, tuple) else (key, ())
        n = self.shape[0]
        if isinstance(k0, slice):
            a, b, st = k0.indices(n)
            k0 = slice(self.start + a, self.start + b, st)
        elif isinstance(k0, (int, np.integer)):
            k0 = self.start + int(k0) % n
        else:
            arr = np.asarray(k0)
            if arr.dtype == bool:
                arr = np.flatnonzero(arr)
            k0 = self.start + np.mod(arr, n)
        return self.base[(k0,) + rest]


def as_arrays(s: dict[str, Any]) -> dict[str, Any]:
    """The archive's variables as numpy arrays, the lazy ones (and their row blocks) left lazy."""
    return {k: v if v is None or isinstance(v, (LazyVar, Rows)) else np.asarray(v)
            for k, v in s.items()}


def attr_float(attrs: dict[str, Any], key: str, default: float = math.nan) -> float:
    """A numeric attribute, ``default`` when absent or not a number."""
    try:
        return float(attrs[key])
    except (KeyError, TypeError, ValueError):
        return default


def case_info(attrs: dict[str, Any]) -> dict[str, Any]:
    """Pieces of the resolved scene (global attribute ``case_json``: a scene, or a case alone)
    the analysis needs."""
    scene = json.loads(attrs.get("case_json") or "{}")
    case, fid = scene.get("case", scene), scene.get("fidelity", {})
    grid = fid.get("grid", {})
    Lz = attr_float(attrs, "Lz", float(grid.get("Lz", math.nan)))
    damping = grid.get("damping_depth")
    if damping is None:
        damping = attr_float(attrs, "damping_depth", min(3.0, 0.5 * Lz) if math.isfinite(Lz) else 0.0)
    forcing = case.get("forcing", {})
    drive = str(forcing.get("drive", "top"))
    if drive == "pressure_gradient":
        damping = 0.0  # the model builds no damping layer with this drive
    return {
        "Lz": Lz,
        "drive": drive,
        # the pressure-gradient drive's stress falls linearly to the lid at Lz: fits use that shape
        "H": Lz if drive == "pressure_gradient" and math.isfinite(Lz) else None,
        "damping_depth": float(damping),
        "z_ref": float(forcing.get("z_ref", 2.0)),
        "soil": case.get("soil"),
        "threshold": case.get("threshold", {}),
        # parcels are q_multiplier x heavier than the case's Q (a cost knob); 1 when unknown
        "q_multiplier": float(fid.get("q_multiplier", 1.0)),
        "Q_case": attr_float(case.get("particles", {}), "Q"),
    }


def time_mean(a: np.ndarray | None, n: int) -> np.ndarray:
    """Time mean over axis 0 (NaN-aware); NaN of length n if absent or empty."""
    if a is None or a.ndim < 1 or a.shape[0] == 0:
        return np.full(n, np.nan)
    a = np.asarray(a, dtype=np.float64)
    if not np.any(np.isfinite(a)):
        return np.full(a.shape[1:], np.nan)
    with np.errstate(invalid="ignore"):
        return np.nanmean(a, axis=0)


def time_sum(a: np.ndarray | None, n: int) -> np.ndarray:
    """Sum over the samples (axis 0, NaN as 0) of a per-sample profile; zeros of length n if
    absent."""
    if a is None or a.ndim < 2:
        return np.zeros(n)
    return np.nansum(np.asarray(a, dtype=np.float64), axis=0)


def check_parcel_counts(planes, grains_per_parcel: float, area: float) -> None:
    """Warn when C_p dx dy / w is not a whole number of parcels: samples.nc stores C_p, not the
    counts, and the Poisson noise is derived from them with this parcel weight."""
    if not (grains_per_parcel > 0 and area > 0) or len(planes) == 0:
        return
    n = np.asarray(planes[-1], dtype=np.float64) * area / grains_per_parcel
    off = np.abs(n - np.rint(n))
    if np.any(off > 1e-6 * np.maximum(1.0, np.abs(n))):
        log.warning("C_p dx dy / Q is not a whole number of parcels (largest remainder %.3g): "
                    "the parcel-count noise assumes parcels of %g grains", float(off.max()),
                    grains_per_parcel)


def rescale_spinup_profiles(sp: dict[str, Any], a: float) -> dict[str, Any]:
    """Spin-up profiles at the case's u*s from a spin-up shared by similarity at u*s / ``a``
    (``solver.similarity``): the mean wind times a, the stresses and TKE times a^2. A NaN factor
    (an archive without ``u_star_target``) leaves them as they are."""
    if not math.isfinite(a) or a == 1.0:
        return sp
    power = {"u_mean": 1, "uw_res": 2, "uw_sgs": 2, "tke_res": 2, "e_sgs": 2}
    return {k: np.asarray(v, dtype=np.float64) * a ** power[k] if k in power else v
            for k, v in sp.items()}


@dataclass(frozen=True, eq=False)
class Frame:
    """The grid, constants, time axes and sampling window of one analysis (see :func:`frame_of`)."""
    attrs: dict[str, Any]
    coords: dict[str, np.ndarray]
    info: dict[str, Any]
    rho: float
    rho_p: float
    nu: float
    g: float
    kappa: float
    z: np.ndarray
    z_w: np.ndarray
    dz: np.ndarray
    x: np.ndarray
    y: np.ndarray
    dx: float
    dy: float
    Lx: float
    Ly: float
    Lz: float
    t_sample: np.ndarray
    t_series: np.ndarray
    t_plane: np.ndarray
    z_plane: np.ndarray
    d_bin: np.ndarray
    t0: float
    t1: float
    H: float | None
    z_ref_eff: float
    plane_mask: np.ndarray

    @property
    def nz(self) -> int:
        return self.z.size

    @property
    def nx(self) -> int:
        return self.x.size

    @property
    def ny(self) -> int:
        return self.y.size

    @property
    def n_t(self) -> int:
        """The number of 3-D samples."""
        return self.t_sample.size

    @property
    def bed_area(self) -> float:
        """The domain's bed area Lx Ly [m2]."""
        return self.Lx * self.Ly

    @property
    def cell_area(self) -> float:
        """A grid column's area dx dy [m2]."""
        return self.dx * self.dy


def frame_of(attrs: dict[str, Any], coords: dict[str, np.ndarray]) -> Frame:
    """The :class:`Frame` of an archive's attributes and coordinates; missing attributes take
    the usual values (rho 1.2, rho_p 2650, nu 1.5e-5, g 9.81, kappa 0.40), missing faces are
    rebuilt from the centres, ``z_ref_eff = min(forcing.z_ref, (Lz - damping)/2)``."""
    info = case_info(attrs)
    z = np.asarray(coords["z"], dtype=np.float64)
    z_w = np.asarray(coords.get("z_w", np.zeros(0)), dtype=np.float64)
    if z_w.size != z.size + 1:  # reconstruct faces from centres: z_w[k+1] = 2 z[k] - z_w[k]
        z_w = np.zeros(z.size + 1)
        for k in range(z.size):
            z_w[k + 1] = 2.0 * z[k] - z_w[k]
    x = np.asarray(coords.get("x", np.zeros(0)), dtype=np.float64)
    y = np.asarray(coords.get("y", np.zeros(0)), dtype=np.float64)
    nx, ny = x.size, y.size
    dx = attr_float(attrs, "dx", float(x[1] - x[0]) if nx > 1 else math.nan)
    dy = attr_float(attrs, "dy", float(y[1] - y[0]) if ny > 1 else math.nan)
    Lz = info["Lz"] if math.isfinite(info["Lz"]) else float(z_w[-1])
    t_sample = np.asarray(coords.get("time", np.zeros(0)), dtype=np.float64)
    t_series = np.asarray(coords.get("time_series", np.zeros(0)), dtype=np.float64)
    t_plane = np.asarray(coords.get("time_plane", np.zeros(0)), dtype=np.float64)
    n_t = t_sample.size

    # sampling window: from the first to the last 3-D sample; one sample -> to the end of the run
    if n_t:
        t0, t1 = float(t_sample[0]), float(t_sample[-1])
        if t1 <= t0:
            t1 = float(max(t_series.max() if t_series.size else t0,
                           t_plane.max() if t_plane.size else t0))
    else:
        t0, t1 = (float(t_series[0]), float(t_series[-1])) if t_series.size else (0.0, 0.0)
    # planes restricted to the sampling window (t >= first 3-D sample)
    in_window = t_plane >= t0 - 1e-9
    plane_mask = in_window if n_t and in_window.any() else np.ones(t_plane.size, bool)

    return Frame(
        attrs=attrs, coords=coords, info=info,
        rho=attr_float(attrs, "rho", 1.2), rho_p=attr_float(attrs, "rho_p", 2650.0),
        nu=attr_float(attrs, "nu", 1.5e-5), g=attr_float(attrs, "g", 9.81),
        kappa=attr_float(attrs, "kappa", 0.40),
        z=z, z_w=z_w, dz=np.diff(z_w), x=x, y=y, dx=dx, dy=dy,
        Lx=attr_float(attrs, "Lx", nx * dx), Ly=attr_float(attrs, "Ly", ny * dy), Lz=Lz,
        t_sample=t_sample, t_series=t_series, t_plane=t_plane,
        z_plane=np.asarray(coords.get("z_plane", np.zeros(0)), dtype=np.float64),
        d_bin=np.asarray(coords.get("d_bin", np.zeros(0)), dtype=np.float64),
        t0=t0, t1=t1, H=info["H"],
        z_ref_eff=attr_float(attrs, "z_ref_eff", min(info["z_ref"], 0.5 * (Lz - info["damping_depth"]))),
        plane_mask=plane_mask,
    )
