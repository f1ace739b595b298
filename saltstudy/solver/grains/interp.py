"""Grid <-> parcel transfer on the staggered grid: trilinear weights, log-law extrapolation near the bed.

The same weights interpolate the air at a parcel (paper section 2.1, "first order trilinear
interpolation") and deposit its drag reaction (eq. 2): momentum is conserved to round-off.
The log-law region is the whole first cell, ``z < z_f[1]`` (the paper's [12]: "In the lower grid
cell, the horizontal wind velocity components at the particle position were extrapolated from the
resolved fluid components of the second grid cell using a logarithmic profile")::

    u(z) = u(z_c[1]) ln(z / z0) / ln(z_c[1] / z0)           (z clipped to >= 1.0001 z0)

bilinear at level ``LOG_LEVEL`` = 1, where the parcel's reaction and TKE sink go too; above,
trilinear. The seen wind jumps at ``z_f[1]``: in an exact log profile (z0 = 10 um) the linear
value is below the log law by 1.9 % (reduced grid) to 2.9 % (smoke grid; the paper's 2.4 %). w is
linear between the z-faces, to 0 at the bed, which takes the share of a reaction on face 0.
Scalar numba code, inlined into the parcel kernels.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from ..._jit import device
from ..grid import Grid
from ..numerics.elementary import log_small
from ..numerics.simd import fma2, fma4, load2

#: the parcel kernels' helpers, inlined by LLVM (``_jit.device``: out-of-line calls passing the
#: arrays as structs on the stack cost ~25 ns each, most of the parcel step)
ijit = device

#: Where a point sits (``locate``): index and fraction of the x-faces (u) and x-centres (v, w), the
#: same in y, the lower centre level ``kc`` and fraction ``fzc`` (u, v), the lower face ``kf`` and
#: ``fzf`` (w), the log-law region (``islog``: ``lfac`` the log-law factor, ``kc`` = LOG_LEVEL,
#: ``fzc`` = 0) and the level of the cell holding it (``kcell``); ``ix + 1`` etc. wrap at the users
Stencil = namedtuple("Stencil", "ixf fxf ixc fxc jyf fyf jyc fyc kc fzc kf fzf lfac islog kcell")
#: the level the first cell's log law extrapolates, where a parcel there deposits (module doc)
LOG_LEVEL = 1
#: index in ``GridGeometry.geo`` of the log region's top, z_f[1]
GEO_LOG_TOP = 8
#: indices in ``GridGeometry.geo`` of 1 / dx, 1 / dy, 1 / z0 and 1 / lut_dz (locate multiplies:
#: a division is a long dependency for the parcel's stencil)
GEO_RDX, GEO_RDY, GEO_RZ0, GEO_RLUT = 9, 10, 11, 12
#: The grid as the parcel kernels take it (``GridGeometry.record``); ``rdz_f``, ``rdz_c``: 1 /
#: the spacings of the faces and of the centres
Geometry = namedtuple("Geometry", "geo z_f z_c dz_c lut rdz_f rdz_c")


class GridGeometry:
    """The parcel kernels' grid: ``geo`` = [dx, dy, Lx, Ly, z0, lut_dz, Lz, 1 / ln(z_c[1] / z0),
    z_f[1], 1 / dx, 1 / dy, 1 / z0, 1 / lut_dz], ``lut[m]`` the face under m lut_dz."""

    def __init__(self, grid: Grid, z0: float):
        self.nx, self.ny, self.nz = grid.shape
        self.z_f = np.ascontiguousarray(grid.z_f, dtype=np.float64)
        self.z_c = np.ascontiguousarray(grid.z_c, dtype=np.float64)
        self.dz_c = np.ascontiguousarray(grid.dz_c, dtype=np.float64)
        self.dz_f = np.ascontiguousarray(grid.dz_f, dtype=np.float64)
        lut_dz = 0.5 * float(np.min(self.dz_c))
        n_lut = int(math.ceil(grid.Lz / lut_dz)) + 2
        zs = np.arange(n_lut) * lut_dz
        self.lut = np.clip(np.searchsorted(self.z_f, zs, side="right") - 1, 0, self.nz - 1).astype(np.int64)
        if self.nz < 2:
            raise ValueError("the log-law extrapolation needs at least two levels")
        self.geo = np.array([grid.dx, grid.dy, grid.Lx, grid.Ly, z0, lut_dz, grid.Lz,
                             1.0 / math.log(self.z_c[LOG_LEVEL] / z0), self.z_f[1], 1.0 / grid.dx,
                             1.0 / grid.dy, 1.0 / z0, 1.0 / lut_dz], dtype=np.float64)
        if not z0 < self.z_c[0]:
            raise ValueError(f"z0 ({z0}) must lie below the first level ({self.z_c[0]})")
        self.rdz_f = np.ascontiguousarray(1.0 / np.diff(self.z_f))
        self.rdz_c = np.ascontiguousarray(1.0 / np.diff(self.z_c))
        self.record = Geometry(self.geo, self.z_f, self.z_c, self.dz_c, self.lut, self.rdz_f,
                               self.rdz_c)


@ijit
def wrap_periodic(x: float, L: float) -> float:
    """x mod L in [0, L), correct for any number of domain lengths (Oceananigans#3320)."""
    r = x - L * math.floor(x / L)
    if r >= L:  # x slightly negative: x - L*(-1) rounds to L
        r -= L
    if r < 0.0:
        r = 0.0
    return r


@ijit
def wrap_index(i, n):
    """i mod n; positions are kept in [0, L), so i is almost always in [-1, n]: no division."""
    if i < 0:
        i += n
        if i < 0:
            i %= n
    elif i >= n:
        i -= n
        if i >= n:
            i %= n
    return i


@ijit
def level_of(z: float, z_f: np.ndarray, lut: np.ndarray, lut_dz: float, nz: int) -> int:
    """Face index k (0..nz-1) with z_f[k] <= z < z_f[k+1] (clamped): the cell holding height z."""
    if z <= 0.0:
        return 0
    m = int(z / lut_dz)
    if m >= lut.shape[0]:
        return nz - 1
    k = lut[m]
    while k < nz - 1 and z_f[k + 1] <= z:
        k += 1
    return k


@ijit
def _cell_level(z, G, nz):
    """level_of with 1 / lut_dz (stepping back a z whose product rounded up)."""
    if z <= 0.0:
        return 0
    m = int(z * G.geo[GEO_RLUT])
    if m >= G.lut.shape[0]:
        return nz - 1
    k = G.lut[m]
    if k > 0 and z < G.z_f[k]:
        k -= 1
    while k < nz - 1 and G.z_f[k + 1] <= z:
        k += 1
    return k


@ijit
def _faces_and_centres(s):
    """(face index, fraction, centre index, fraction) of a coordinate s in cell widths."""
    i = int(math.floor(s))
    f = s - i
    if f >= 0.5:
        return i, f, i, f - 0.5
    return i, f, i - 1, f + 0.5


@ijit
def locate(x, y, z, G, nx, ny, nz):
    """The :data:`Stencil` of a point for the three staggered components (G: :data:`Geometry`)."""
    geo = G.geo
    ixf, fxf, ixc, fxc = _faces_and_centres(x * geo[GEO_RDX])
    jyf, fyf, jyc, fyc = _faces_and_centres(y * geo[GEO_RDY])
    ixf = wrap_index(ixf, nx)
    ixc = wrap_index(ixc, nx)
    jyf = wrap_index(jyf, ny)
    jyc = wrap_index(jyc, ny)
    kcell = _cell_level(z, G, nz)
    # faces: w between z_f[kf] and z_f[kf+1]
    kf = kcell
    fzf = (z - G.z_f[kf]) * G.rdz_f[kf]
    if fzf < 0.0:
        fzf = 0.0
    elif fzf > 1.0:
        fzf = 1.0
    # centres: u, v between z_c[kc] and z_c[kc+1]
    islog = False
    lfac = 1.0
    if z < geo[GEO_LOG_TOP]:  # the log region
        islog = True
        kc = LOG_LEVEL  # the level it reads and deposits on
        fzc = 0.0
        z0 = geo[4]
        zz = z if z > 1.0001 * z0 else 1.0001 * z0
        lfac = log_small(zz * geo[GEO_RZ0]) * geo[7]
    else:
        kc = kcell if z >= G.z_c[kcell] else kcell - 1
        if kc >= nz - 1:
            kc = nz - 2
            fzc = 1.0
        else:
            fzc = (z - G.z_c[kc]) * G.rdz_c[kc]
            if fzc > 1.0:
                fzc = 1.0
    return Stencil(ixf, fxf, ixc, fxc, jyf, fyf, jyc, fyc, kc, fzc, kf, fzf, lfac, islog, kcell)


@ijit
def _upper_corner(i0, fx, j0, fy, nx, ny):
    """(i0 + 1, j0 + 1) wrapped (i0, j0 are in range) and the lower corner's weights 1 - fx, 1 - fy."""
    i1 = i0 + 1
    if i1 == nx:
        i1 = 0
    j1 = j0 + 1
    if j1 == ny:
        j1 = 0
    return i1, j1, 1.0 - fx, 1.0 - fy


@ijit
def _tri(f, i0, fx, j0, fy, k0, fz, nx, ny):
    """Trilinear value of f around (i0+fx, j0+fy, k0+fz) with periodic i, j."""
    i1, j1, gx, gy = _upper_corner(i0, fx, j0, fy, nx, ny)
    gz = 1.0 - fz
    # each column's two levels in one load (simd.load2; k0 + 1 < nz by the callers)
    f000, f001 = load2(f, i0, j0, k0)
    f010, f011 = load2(f, i0, j1, k0)
    f100, f101 = load2(f, i1, j0, k0)
    f110, f111 = load2(f, i1, j1, k0)
    a = (gx * (gy * (gz * f000 + fz * f001) + fy * (gz * f010 + fz * f011))
         + fx * (gy * (gz * f100 + fz * f101) + fy * (gz * f110 + fz * f111)))
    return a


@ijit
def _bil(f, i0, fx, j0, fy, k, nx, ny):
    i1, j1, gx, gy = _upper_corner(i0, fx, j0, fy, nx, ny)
    return (gx * (gy * f[i0, j0, k] + fy * f[i0, j1, k])
            + fx * (gy * f[i1, j0, k] + fy * f[i1, j1, k]))


@ijit
def interp_fluid(u, v, w, st, nx, ny):
    """Resolved air velocity at a located point (trilinear; the log law in the log region)."""
    if st.islog:
        uf = st.lfac * _bil(u, st.ixf, st.fxf, st.jyc, st.fyc, LOG_LEVEL, nx, ny)
        vf = st.lfac * _bil(v, st.ixc, st.fxc, st.jyf, st.fyf, LOG_LEVEL, nx, ny)
    else:
        uf = _tri(u, st.ixf, st.fxf, st.jyc, st.fyc, st.kc, st.fzc, nx, ny)
        vf = _tri(v, st.ixc, st.fxc, st.jyf, st.fyf, st.kc, st.fzc, nx, ny)
    wf = _tri(w, st.ixc, st.fxc, st.jyc, st.fyc, st.kf, st.fzf, nx, ny)
    return uf, vf, wf


# ---- chunk-private deposit buffers (coupling.py): slabs s ... s+L-1 (mod nx) of the face fields
# flat in a pool from ``off``, index ``off + ((comp * L + (i - s) mod nx) * ny + j) * nk + k``
# (times 2, plus 0 or 1, for the paired buffers); every slab written lies in the range


@ijit
def slab_of(i, s, nx):
    """Chunk-local slab index of global slab i for a range starting at s."""
    ii = i - s
    if ii < 0:
        ii += nx
    return ii


@ijit
def pool_add_tri(pool, base, s, nx, ny, nk, val, i0, fx, j0, fy, k0, fz):
    """pool[base + slab-local trilinear stencil] += w val (levels >= nk fold onto nk - 1)."""
    i1, j1, gx, gy = _upper_corner(i0, fx, j0, fy, nx, ny)
    gz = 1.0 - fz
    r0 = base + slab_of(i0, s, nx) * ny * nk
    r1 = base + slab_of(i1, s, nx) * ny * nk
    a00 = r0 + j0 * nk
    a01 = r0 + j1 * nk
    a10 = r1 + j0 * nk
    a11 = r1 + j1 * nk
    v00 = gx * gy * val
    v01 = gx * fy * val
    v10 = fx * gy * val
    v11 = fx * fy * val
    if k0 + 1 < nk:
        fma2(pool, a00 + k0, gz, fz, v00)
        fma2(pool, a01 + k0, gz, fz, v01)
        fma2(pool, a10 + k0, gz, fz, v10)
        fma2(pool, a11 + k0, gz, fz, v11)
    else:  # both levels fold onto nk - 1
        k = nk - 1
        pool[a00 + k] += v00 * gz
        pool[a00 + k] += v00 * fz
        pool[a01 + k] += v01 * gz
        pool[a01 + k] += v01 * fz
        pool[a10 + k] += v10 * gz
        pool[a10 + k] += v10 * fz
        pool[a11 + k] += v11 * gz
        pool[a11 + k] += v11 * fz


@ijit
def pool_add_tri2(pool, base, s, nx, ny, nk, va, vb, i0, fx, j0, fy, k0, fz):
    """As pool_add_tri for a pair of interleaved buffers: (+ w va, + w vb), simd.fma4."""
    i1, j1, gx, gy = _upper_corner(i0, fx, j0, fy, nx, ny)
    gz = 1.0 - fz
    r0 = base + 2 * slab_of(i0, s, nx) * ny * nk
    r1 = base + 2 * slab_of(i1, s, nx) * ny * nk
    a00 = r0 + 2 * j0 * nk
    a01 = r0 + 2 * j1 * nk
    a10 = r1 + 2 * j0 * nk
    a11 = r1 + 2 * j1 * nk
    if k0 + 1 < nk:
        k = 2 * k0
        fma4(pool, a00 + k, gx * gy * gz, gx * gy * fz, va, vb)
        fma4(pool, a01 + k, gx * fy * gz, gx * fy * fz, va, vb)
        fma4(pool, a10 + k, fx * gy * gz, fx * gy * fz, va, vb)
        fma4(pool, a11 + k, fx * fy * gz, fx * fy * fz, va, vb)
    else:  # both levels fold onto nk - 1
        k = 2 * (nk - 1)
        for a, wxy in ((a00, gx * gy), (a01, gx * fy), (a10, fx * gy), (a11, fx * fy)):
            w = wxy * gz
            pool[a + k] += w * va
            pool[a + k + 1] += w * vb
            w = wxy * fz
            pool[a + k] += w * va
            pool[a + k + 1] += w * vb
