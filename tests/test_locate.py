"""interp.locate: the stencil of a point on the staggered, stretched grid, against its definition
computed directly (a search over all faces), on random points and on the faces and centres
themselves."""
from __future__ import annotations

import math

import numpy as np
import pytest

from saltstudy._jit import jit
from saltstudy.config import load_fidelity
from saltstudy.solver.grid import Grid
from saltstudy.solver.grains.interp import (GEO_LOG_TOP, GEO_RDX, GEO_RDY, LOG_LEVEL,
                                           GridGeometry, locate)


@jit
def _locate_all(x, y, z, G, nx, ny, nz, ints, floats):
    for p in range(x.shape[0]):
        st = locate(x[p], y[p], z[p], G, nx, ny, nz)
        iv = (st.ixf, st.ixc, st.jyf, st.jyc, st.kc, st.kf, st.kcell, 1 if st.islog else 0)
        fv = (st.fxf, st.fxc, st.fyf, st.fyc, st.fzc, st.fzf, st.lfac)
        for q in range(8):
            ints[p, q] = iv[q]
        for q in range(7):
            floats[p, q] = fv[q]


def _reference(g: GridGeometry, x, y, z):
    """The stencil's definition (interp.py's Stencil), vectorized with numpy."""
    geo = g.geo
    nx, ny, nz = g.nx, g.ny, g.nz

    def faces_centres(s, n):
        i = np.floor(s).astype(np.int64)
        f = s - i
        hi = f >= 0.5
        return i % n, f, np.where(hi, i, i - 1) % n, np.where(hi, f - 0.5, f + 0.5)

    ixf, fxf, ixc, fxc = faces_centres(x * geo[GEO_RDX], nx)
    jyf, fyf, jyc, fyc = faces_centres(y * geo[GEO_RDY], ny)
    kcell = np.clip(np.searchsorted(g.z_f, z, side="right") - 1, 0, nz - 1)
    kcell = np.where(z <= 0.0, 0, kcell)
    fzf = np.clip((z - g.z_f[kcell]) * g.rdz_f[kcell], 0.0, 1.0)
    kc = np.where(z >= g.z_c[kcell], kcell, kcell - 1)
    above = kc >= nz - 1
    kcs = np.clip(kc, 0, nz - 2)
    fzc = np.where(above, 1.0, np.minimum((z - g.z_c[kcs]) * g.rdz_c[kcs], 1.0))
    islog = z < geo[GEO_LOG_TOP]
    kc = np.where(islog, LOG_LEVEL, kcs)
    fzc = np.where(islog, 0.0, fzc)
    ints = np.stack([ixf, ixc, jyf, jyc, kc, kcell, kcell, islog.astype(np.int64)], axis=1)
    floats = np.stack([fxf, fxc, fyf, fyc, fzc, fzf], axis=1)
    return ints, floats


@pytest.mark.parametrize("fidelity", ["smoke", "reduced", "paper"])
def test_locate_matches_the_stencil_definition(fidelity):
    grid = Grid.from_spec(load_fidelity(fidelity).grid)
    g = GridGeometry(grid, 1e-5)
    assert g.geo[GEO_LOG_TOP] == g.z_f[1]  # the log region is the whole first cell
    rng = np.random.default_rng(7)
    n = 20000
    # random heights, denser near the bed, and every face and centre exactly, and just beside
    zr = np.concatenate([rng.uniform(0.0, grid.Lz, n // 2), grid.Lz * rng.uniform(0, 1, n // 2) ** 4])
    zs = np.concatenate([g.z_f, g.z_c])
    zs = np.concatenate([zs, np.nextafter(zs, -1.0), np.nextafter(zs, 2 * grid.Lz)])
    z = np.concatenate([zr, zs, [0.0, grid.Lz, 1.5 * grid.Lz]])
    z = z[z >= 0.0]
    m = z.size
    x = rng.uniform(0.0, grid.Lx, m)
    y = rng.uniform(0.0, grid.Ly, m)
    ints = np.zeros((m, 8), dtype=np.int64)
    floats = np.zeros((m, 7))
    _locate_all(x, y, z, g.record, g.nx, g.ny, g.nz, ints, floats)
    ri, rf = _reference(g, x, y, z)
    assert np.array_equal(ints, ri)
    assert np.array_equal(floats[:, :6], rf)
    # the log law's factor: ln(z / z0) / ln(z_c[1] / z0) in the log region, 1 above it
    islog = ri[:, 7] == 1
    zz = np.maximum(z[islog], 1.0001e-5)
    want = np.log(zz / 1e-5) / math.log(g.z_c[LOG_LEVEL] / 1e-5)
    np.testing.assert_allclose(floats[islog, 6], want, rtol=1e-13, atol=1e-15)
    assert np.all(floats[~islog, 6] == 1.0)
