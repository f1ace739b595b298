"""A small GIF of C_p over time for one run.

Source: the first archive holding a C_p plane stack (a ``C_p...`` variable on time, x, y; ``C_p``
first): the analysis, else ``samples.nc``. Frames are subsampled to at most ``max_frames`` and
large planes are coarsened, so the file stays small.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from ..ncio import NC_LOCK

__all__ = ["find_cp_stack", "make_animation"]


def find_cp_stack(analysis: str | Path | None, samples: str | Path | None = None,
                  max_frames: int = 60) -> tuple[np.ndarray, np.ndarray, tuple] | None:
    """(frames (t, x, y), times, (Lx, Ly)) or None if no stack exists."""
    for path in (analysis, samples):
        if not path or not Path(path).is_file():
            continue
        try:
            with NC_LOCK, xr.open_dataset(path, engine="netcdf4") as ds:
                names = sorted((n for n in ds.data_vars if str(n).startswith("C_p")),
                               key=lambda n: n != "C_p")
                v = next((ds[n] for n in names if ds[n].ndim == 3
                          and {"x", "y"} <= set(ds[n].dims)), None)
                if v is None:
                    continue
                tdim = next(d for d in v.dims if d not in ("x", "y"))
                nt = v.sizes[tdim]
                idx = np.unique(np.linspace(0, nt - 1, min(nt, max_frames)).round().astype(int))
                sub = v.isel({tdim: idx}).transpose(tdim, "x", "y").load()
                t = ds[tdim].values[idx] if tdim in ds.coords else idx.astype(float)
                lx = float(ds.attrs.get("Lx", ds["x"].values[-1] * 2 if "x" in ds else 1.0))
                ly = float(ds.attrs.get("Ly", ds["y"].values[-1] * 2 if "y" in ds else 1.0))
                return np.asarray(sub.values, float), np.asarray(t, float), (lx, ly)
        except Exception:
            continue
    return None


def _coarsen(a: np.ndarray, max_px: int) -> np.ndarray:
    f = max(1, int(math.ceil(max(a.shape[1:]) / max_px)))
    if f == 1:
        return a
    nx, ny = (a.shape[1] // f) * f, (a.shape[2] // f) * f
    return a[:, :nx, :ny].reshape(a.shape[0], nx // f, f, ny // f, f).mean(axis=(2, 4))


def make_animation(out_path: str | Path, analysis: str | Path | None, samples: str | Path | None = None,
                   title: str = "", max_frames: int = 30, max_px: int = 100, fps: int = 8) -> Path | None:
    """Write a GIF of C_p / C_pmax; return its path, or None if no C_p stack or no pillow."""
    from matplotlib.animation import FuncAnimation, PillowWriter
    found = find_cp_stack(analysis, samples, max_frames)
    if found is None:
        return None
    frames, times, (lx, ly) = found
    frames = _coarsen(frames, max_px)
    vmax = float(np.nanmax(frames)) or 1.0
    fig = Figure(figsize=(5.0, 4.2 * ly / lx + 1.0), dpi=60)
    ax = fig.add_axes((0.12, 0.14, 0.68, 0.76))
    cax = fig.add_axes((0.83, 0.14, 0.03, 0.76))
    im = ax.imshow(frames[0].T / vmax, origin="lower", extent=(0, lx, 0, ly), cmap="YlOrBr",
                   vmin=0, vmax=1, aspect="equal")
    fig.colorbar(im, cax=cax, label="C_p / C_p,max (whole movie)")
    ax.set(xlabel="x [m] (wind →)", ylabel="y [m]")
    ttl = ax.set_title(title)

    def update(i):
        im.set_data(frames[i].T / vmax)
        ttl.set_text(f"{title}  t = {times[i]:.1f} s")
        return im, ttl

    anim = FuncAnimation(fig, update, frames=frames.shape[0], blit=False)
    out_path = Path(out_path)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    try:
        anim.save(out_path, writer=PillowWriter(fps=fps))
    except Exception:
        return None
    return out_path
