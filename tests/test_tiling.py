"""A particle-free flow carried onto a larger grid of the same spacing (solver/tiling.py)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from saltstudy.solver.grid import Grid
from saltstudy.solver.tiling import tile_restart

KAPPA = 0.4


def _restart(g: Grid, rng) -> dict:
    nx, ny, nz = g.shape
    zc, zf = g.z_c, g.z_f
    return {"u": 3.0 + 0.5 * zc + rng.normal(size=(nx, ny, 1)),   # linear in z per column
            "v": rng.normal(size=(nx, ny, nz)),
            "w": np.broadcast_to(0.1 * zf, (nx, ny, nz + 1)).copy(),   # linear, 0 at the bed
            "e": np.full((nx, ny, nz), 0.2),
            "p": rng.normal(size=(nx, ny, nz)),
            "t": 12.0, "u_drive": 7.0, "controller/integral": 0.0}


def test_tiles_horizontally_and_interpolates_in_z_below_z_keep():
    rng = np.random.default_rng(3)
    src = Grid.uniform(8, 6, 20, 0.8, 0.6, 2.0)
    dst = Grid.uniform(16, 18, 40, 1.6, 1.8, 4.0)
    ck = _restart(src, rng)
    out = tile_restart(ck, src, dst, z_keep=1.5, u_star=0.4, kappa=KAPPA)
    assert out["u"].shape == (16, 18, 40) and out["w"].shape == (16, 18, 41)
    low = dst.z_c <= 1.5
    # each of the 2 x 3 tiles is the source, and a profile linear in z is interpolated exactly
    col = ck["u"][:, :, 0] - 3.0 - 0.5 * src.z_c[0]   # the column's offset
    for a in range(2):
        for b in range(3):
            blk = out["u"][8 * a:8 * a + 8, 6 * b:6 * b + 6]
            expect = 3.0 + 0.5 * dst.z_c[low] + col[..., None]
            assert np.allclose(blk[..., low], expect, rtol=0, atol=1e-12)
    # above z_keep: the value at z_keep plus the log law of u*
    top = 3.0 + 0.5 * 1.5 + col
    hi = ~low
    expect = top[..., None] + 0.4 / KAPPA * np.log(dst.z_c[hi] / 1.5)
    assert np.allclose(out["u"][:8, :6][..., hi], expect, atol=1e-12)
    # w: zero at the bed and the lid, tapered above z_keep; p left to the projection
    assert np.all(out["w"][..., 0] == 0.0) and np.all(out["w"][..., -1] == 0.0)
    assert np.allclose(out["w"][..., dst.z_f <= 1.5], 0.1 * dst.z_f[dst.z_f <= 1.5], atol=1e-12)
    assert np.all(out["p"] == 0.0)
    # scalars and the drive's state are carried as they are
    assert out["t"] == 12.0 and out["controller/integral"] == 0.0
    assert np.all(out["e"] == 0.2)


@pytest.mark.parametrize("dst, field", [
    (Grid.uniform(16, 12, 20, 0.8, 0.6, 2.0), "dx"),          # finer spacing
    (Grid.uniform(12, 6, 20, 1.2, 0.6, 2.0), "multiple"),     # 1.5 tiles
])
def test_refuses_another_spacing_or_a_partial_tile(dst, field):
    src = Grid.uniform(8, 6, 20, 0.8, 0.6, 2.0)
    ck = _restart(src, np.random.default_rng(0))
    with pytest.raises(ValueError, match=field):
        tile_restart(ck, src, dst, z_keep=1.5, u_star=0.4, kappa=KAPPA)


def test_refuses_grain_state_and_a_z_keep_outside_the_columns():
    src = Grid.uniform(8, 6, 20, 0.8, 0.6, 2.0)
    dst = Grid.uniform(16, 6, 30, 1.6, 0.6, 3.0)
    ck = _restart(src, np.random.default_rng(0))
    with pytest.raises(ValueError, match="particle-free"):
        tile_restart({**ck, "saltation/x": np.zeros(3)}, src, dst, 1.5, 0.4, KAPPA)
    with pytest.raises(ValueError, match="z_keep"):
        tile_restart(ck, src, dst, 2.5, 0.4, KAPPA)
    assert math.isfinite(tile_restart(ck, src, dst, 2.0, 0.4, KAPPA)["u"].sum())
