"""NetCDF I/O under one process-wide lock, written atomically.

netCDF4's pip wheels segfault when several threads of one process read or write NetCDF, even
separate files (netcdf4-python#1405, xarray#7079): every read and write in this package goes
through :data:`NC_LOCK`. Writes go to ``path + ".tmp"`` and are renamed, so an interrupted write
never leaves a file that a rerun would trust.
"""
from __future__ import annotations

import os
import threading
from pathlib import Path

import xarray as xr

__all__ = ["NC_LOCK", "open_dataset", "write_dataset", "is_complete"]

NC_LOCK = threading.RLock()

#: global attribute set last on every archive; a file without it is incomplete
COMPLETE_ATTR = "saltstudy_complete"


def open_dataset(path: str | os.PathLike) -> xr.Dataset:
    """Read a whole NetCDF file into memory (under the lock) and close it."""
    with NC_LOCK:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            return ds.load()


def write_dataset(ds: xr.Dataset, path: str | os.PathLike) -> Path:
    """Write ``ds`` to ``path`` atomically (temporary name, then rename), under the lock."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    ds = ds.copy()
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
