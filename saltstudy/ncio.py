"""NetCDF I/O under one process-wide lock, written atomically.

netCDF4's pip wheels segfault when several threads of one process read or write NetCDF, even
separate files (netcdf4-python#1405, xarray#7079): every read and write in this package goes
through :data:`NC_LOCK`. Writes go to ``path + ".tmp"`` and are renamed, so an interrupted write
never leaves a file that a rerun would trust.

Every archive written declares the CF conventions (:func:`cf_attributes`): ``Conventions``, the
axes of the grid's coordinates and the CF standard names of the variables that have one. The
attributes only: the arrays are written as given.
"""
from __future__ import annotations

import os
import threading
from datetime import datetime, timezone
from pathlib import Path

import xarray as xr

from ._identity import __version__

__all__ = ["NC_LOCK", "CF_VERSION", "CF_COORDINATES", "CF_STANDARD_NAMES", "cf_attributes",
           "open_dataset", "open_lazy", "write_dataset", "is_complete"]

NC_LOCK = threading.RLock()

#: global attribute set last on every archive; a file without it is incomplete
COMPLETE_ATTR = "saltstudy_complete"

#: the version of the CF conventions the archives follow (checked with the IOOS compliance
#: checker, tests/test_cf_archives.py)
CF_VERSION = "CF-1.10"

_X = {"axis": "X", "standard_name": "projection_x_coordinate"}
_Y = {"axis": "Y", "standard_name": "projection_y_coordinate"}
_Z = {"axis": "Z", "positive": "up", "standard_name": "height"}
#: the grid's coordinates, by name in every archive: the model's plane x (streamwise) and y
#: (spanwise) axes are CF's projection coordinates (with axis X/Y alone a CF checker takes them
#: for longitude and latitude), z is the height above the bed. The times are seconds since an
#: event of the run (the activation, the spin-up's start): CF's time axis needs a calendar epoch
#: ("s since 2000-01-01"), and xarray would then read every time as a date, so they carry units
#: and long_name and no axis.
CF_COORDINATES: dict[str, dict[str, str]] = {
    "x": _X, "x_u": _X, "y": _Y, "y_v": _Y, "z": _Z, "z_w": _Z, "z_plane": _Z, "z_band": _Z}
#: name -> (CF standard name, the units it takes); set only where a variable has those units,
#: so a name of another meaning elsewhere is never mislabelled. The kinematic pressure p/rho
#: (m2 s-2) has no CF standard name.
CF_STANDARD_NAMES: dict[str, tuple[str, str]] = {
    "u": ("x_wind", "m s-1"), "v": ("y_wind", "m s-1"), "w": ("upward_air_velocity", "m s-1"),
    "u_plane": ("x_wind", "m s-1"),
    # "the kinetic energy of all eddy-induced motion that is not resolved on the grid scale"
    "e": ("specific_turbulent_kinetic_energy_of_air", "m2 s-2"),
}


def cf_attributes(ds: xr.Dataset, history: str | None = None) -> xr.Dataset:
    """A shallow copy of ``ds`` with the CF attributes of :data:`CF_COORDINATES` and
    :data:`CF_STANDARD_NAMES` added (a caller's own attributes win), ``Conventions`` set, the
    line ``history`` appended to the global ``history`` (CF's audit trail: an analysis.nc keeps
    the line of the samples.nc it was made from) and no ``_FillValue`` on the coordinates (CF: a
    coordinate has no missing values). The arrays are the same objects."""
    ds = ds.copy()
    ds.attrs["Conventions"] = CF_VERSION
    if history:
        ds.attrs["history"] = "\n".join(h for h in (ds.attrs.get("history"), history) if h)
    for name, var in ds.variables.items():
        extra: dict[str, str] = {}
        if name in ds.coords and name in CF_COORDINATES:
            extra = CF_COORDINATES[name]
        elif name in CF_STANDARD_NAMES and var.attrs.get("units") == CF_STANDARD_NAMES[name][1]:
            extra = {"standard_name": CF_STANDARD_NAMES[name][0]}
        var.attrs = {**extra, **var.attrs}
        if name in ds.sizes:
            var.encoding["_FillValue"] = None
    return ds


def open_dataset(path: str | os.PathLike) -> xr.Dataset:
    """Read a whole NetCDF file into memory (under the lock) and close it."""
    with NC_LOCK:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            return ds.load()


def open_lazy(path: str | os.PathLike) -> xr.Dataset:
    """Open a NetCDF file lazily: dask arrays read on demand, each read under :data:`NC_LOCK`
    (a run's samples.nc is several GB at the paper's fidelity). Close it when done
    (``with open_lazy(p) as ds: ...``)."""
    with NC_LOCK:
        return xr.open_dataset(path, engine="netcdf4", chunks={}, lock=NC_LOCK)


def write_dataset(ds: xr.Dataset, path: str | os.PathLike) -> Path:
    """Write ``ds`` to ``path`` atomically (temporary name, then rename), under the lock, with
    the CF attributes (:func:`cf_attributes`)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    stamp = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    ds = cf_attributes(ds, f"{stamp} saltstudy {__version__}: {path.name}")
    ds.attrs[COMPLETE_ATTR] = 1
    with NC_LOCK:
        if tmp.exists():
            tmp.unlink()
        ds.to_netcdf(tmp, engine="netcdf4")
    os.replace(tmp, path)
    return path


def is_complete(path: str | os.PathLike) -> bool:
    """True if ``path`` is a readable archive that was completely written by this package."""
    path = Path(path)
    if not path.is_file():
        return False
    try:
        with NC_LOCK:
            with xr.open_dataset(path, engine="netcdf4") as ds:
                return int(ds.attrs.get(COMPLETE_ATTR, 0)) == 1
    except Exception:  # truncated, corrupt, or not NetCDF: never trusted
        return False
