"""A particle-free flow carried onto a larger grid of the same horizontal spacing: a start for a
grid whose own spin-up cannot be afforded (the paper's 200 x 150 x 100 points need 300-1800 s of
flow, 10-60 h on 2 cores: docs/BENCHMARKS.md). The tiled periodic source is again a solution (no
structure longer than the source box until one develops). Columns are interpolated linearly in
z up to ``z_keep``; above, the fluctuations at z_keep, the mean wind continued by the source's
log law and w tapered to zero at the lid. The pressure is zero: ``project_restart`` before the
first step.
"""
from __future__ import annotations

import math

import numpy as np

#: entries of a particle-free restart that are grid fields: (name, staggered in z)
_FIELDS = (("u", False), ("v", False), ("w", True), ("e", False), ("p", False))


def _interp_weights(z_src: np.ndarray, z_dst: np.ndarray):
    """Index k and weight a with f(z_dst) = (1 - a) f[k] + a f[k + 1], clamped to the source."""
    k = np.clip(np.searchsorted(z_src, z_dst) - 1, 0, len(z_src) - 2)
    a = np.clip((z_dst - z_src[k]) / (z_src[k + 1] - z_src[k]), 0.0, 1.0)
    return k, a


def _column_interp(f: np.ndarray, z_src: np.ndarray, z_dst: np.ndarray) -> np.ndarray:
    k, a = _interp_weights(z_src, z_dst)
    return f[..., k] * (1.0 - a) + f[..., k + 1] * a


def tile_restart(ck: dict, src, dst, z_keep: float, u_star: float, kappa: float) -> dict:
    """The particle-free restart ``ck`` carried from grid ``src`` onto ``dst`` (module doc), u_star
    [m s^-1] the source's; ValueError when that is not possible."""
    for name, a, b in (("dx", src.dx, dst.dx), ("dy", src.dy, dst.dy)):
        if not math.isclose(a, b, rel_tol=1e-9):
            raise ValueError(f"tile_restart: {name} differs ({a:g} m in the source, {b:g} m in the "
                             f"target); tiling keeps the horizontal spacing")
    mx, rx = divmod(dst.nx, src.nx)
    my, ry = divmod(dst.ny, src.ny)
    if rx or ry or mx < 1 or my < 1:
        raise ValueError(f"tile_restart: the target's {dst.nx} x {dst.ny} points are not a whole "
                         f"multiple of the source's {src.nx} x {src.ny}")
    if not 0.0 < z_keep <= min(src.Lz, dst.Lz):
        raise ValueError(f"tile_restart: z_keep = {z_keep:g} m must lie in (0, {min(src.Lz, dst.Lz):g}] m")
    grains = sorted(k for k in ck if "/" in k and not k.startswith(("controller/", "closure/")))
    if grains:
        raise ValueError(f"tile_restart: only a particle-free state can be tiled; this checkpoint "
                         f"carries {grains[:3]}")
    out = dict(ck)
    for name, staggered in _FIELDS:
        if name not in ck:
            continue
        f = np.tile(np.asarray(ck[name], dtype=np.float64), (mx, my, 1))
        z_s = src.z_f if staggered else src.z_c
        z_d = dst.z_f if staggered else dst.z_c
        low = z_d <= z_keep
        g = np.empty(f.shape[:2] + (len(z_d),))
        g[..., low] = _column_interp(f, z_s, z_d[low])
        top = _column_interp(f, z_s, np.array([z_keep]))[..., 0]
        hi = np.nonzero(~low)[0]
        if name == "u":
            g[..., hi] = top[..., None] + u_star / kappa * np.log(z_d[hi] / z_keep)
        elif name == "w":
            taper = np.clip((dst.Lz - z_d[hi]) / (dst.Lz - z_keep), 0.0, 1.0)
            g[..., hi] = top[..., None] * taper
            g[..., 0] = 0.0
            g[..., -1] = 0.0
        elif name == "p":
            g[...] = 0.0
        else:
            g[..., hi] = top[..., None]
        out[name] = g
    return out


def project_restart(model) -> None:
    """A tiled start made divergence-free, its drive on the feed-forward of the new flow."""
    s = model.state
    model.stepper.pressure.project(s.u, s.v, s.w)
    s.u_drive = model.controller.feed_forward(model.damped_mean_u())
