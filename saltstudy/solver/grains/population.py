"""The grain population between steps: release from the bed, the dead removed (compaction), the
parcels reordered by cell, and the wind read at the parcels.
"""
from __future__ import annotations

from numba import prange

from ..._jit import jit, jit_borrow, pjit
from ...physics.soil import draw_diameter
from .interp import interp_fluid, level_of, locate, wrap_index


@jit_borrow
def collect_events(n, flag, ev):
    """ev[:m] = indices of the parcels with flag 1, in increasing order; returns m."""
    m = 0
    for p in range(n):
        if flag[p] == 1:
            ev[m] = p
            m += 1
    return m


@jit_borrow
def compact(dead, n_dead, n, x, y, z, u, v, w, d, kd, flag, trem, tl, xl, yl):
    """Swap-remove the dead parcels; ``dead`` sorted in decreasing order. Returns the new count."""
    for i in range(n_dead):
        q = dead[i]
        last = n - 1
        if q != last:
            for a in (x, y, z, u, v, w, d, kd, trem, tl, xl, yl):
                a[q] = a[last]
            flag[q] = flag[last]
        n -= 1
    return n


@jit_borrow
def cell_order(n, x, y, z, geo, z_f, lut, nx, ny, nz, key, perm, count):
    """Stable counting sort of the parcels by cell, perm[new] = old (locality)."""
    nkey = nx * ny * nz
    for c in range(nkey + 1):
        count[c] = 0
    for p in range(n):
        i = wrap_index(int(x[p] / geo[0]), nx)
        j = wrap_index(int(y[p] / geo[1]), ny)
        k = level_of(z[p], z_f, lut, geo[5], nz)
        kk = (i * ny + j) * nz + k
        key[p] = kk
        count[kk + 1] += 1
    for c in range(nkey):
        count[c + 1] += count[c]
    for p in range(n):
        kk = key[p]
        perm[count[kk]] = p
        count[kk] += 1


@pjit
def gather(n, perm, a, out):
    """out[q] = a[perm[q]] for q < n (the parcels reordered, one field)."""
    for q in prange(n):
        out[q] = a[perm[q]]


@jit
def release(rng, n0, n_new, x, y, z, u, v, w, d, kd, flag, trem, Lx, Ly, z_lo, z_hi, cum, mu, lnsig):
    """n_new parcels uniformly in [0, Lx) x [0, Ly) x [z_lo, z_hi), at rest, d from the soil."""
    for q in range(n0, n0 + n_new):
        x[q] = rng.random() * Lx
        y[q] = rng.random() * Ly
        z[q] = z_lo + rng.random() * (z_hi - z_lo)
        u[q] = 0.0
        v[q] = 0.0
        w[q] = 0.0
        d[q] = draw_diameter(rng, cum, mu, lnsig)
        kd[q] = 0.0
        flag[q] = 0
        trem[q] = 0.0


@jit_borrow
def _fluid_at_range(lo, hi, x, y, z, uf, vf, wf, G, out):
    nx = uf.shape[0]
    ny = uf.shape[1]
    nz = uf.shape[2]
    for p in range(lo, hi):
        st = locate(x[p], y[p], z[p], G, nx, ny, nz)
        a, b, c = interp_fluid(uf, vf, wf, st, nx, ny)
        out[0, p] = a
        out[1, p] = b
        out[2, p] = c


@pjit
def fluid_at(n, x, y, z, uf, vf, wf, G, out):
    nb = 64
    for b in prange(nb):
        _fluid_at_range((b * n) // nb, ((b + 1) * n) // nb, x, y, z, uf, vf, wf, G, out)
