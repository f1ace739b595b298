"""Pressure projection: FFT in x and y, tridiagonal (Thomas) solve in z per wavenumber pair.

Discrete operators (staggered grid, see grid.py), with D the divergence at cell centres and G the
gradient at the faces:

    D(u)[i,j,k] = (u[i+1]-u[i])/dx + (v[j+1]-v[j])/dy + (w[k+1]-w[k])/dz_c[k]
    G(phi)_u = (phi[i]-phi[i-1])/dx,  G(phi)_w[k] = (phi[k]-phi[k-1])/dz_f[k]  (1 <= k <= nz-1)

G is minus the volume-weighted adjoint of D, so the projection does no work on the flow. The
projection solves L phi = D(u*) with L = D G (Neumann at the bed and the lid since w = 0 there) and
sets u = u* - G phi: D(u) = 0 to round-off. In x and y, L is diagonalised by the discrete Fourier
transform with the modified wavenumbers of the 3-point Laplacian, -4 sin^2(pi m/n)/dx^2 (e.g.
Schumann & Sweet 1988, J. Comput. Phys. 75, 123); in z each wavenumber pair leaves a tridiagonal
system solved by the Thomas algorithm (factors precomputed once). The (0, 0) mode is singular (phi
defined up to a constant): its first row is replaced by phi[0] = 0, which is exact because the rows
sum to zero with weights dz_c and so does the right-hand side.

Fourth order in x and y (``order=4``, with the fourth-order advection, advection.py): D and G take
Morinishi et al.'s (1998) fourth-order staggered differences in x and y,

    D4(u)[i] = (9/8 (u[i+1]-u[i]) - 1/24 (u[i+2]-u[i-1]))/dx + (the same in y)
               + (w[k+1]-w[k])/dz_c[k]
    G4(phi)_u[i] = (9/8 (phi[i]-phi[i-1]) - 1/24 (phi[i+1]-phi[i-2]))/dx,   G_w as above,

G4 is again minus the adjoint of D4 (the projection does no work), and only the modified wavenumbers
change: -(2 s + s^3/3)^2/dx^2 with s = sin(pi m/n) (the symbol of D4 G4; 2 s + s^3/3 > 0 for
0 < m < n, so no spurious null mode), against -4 s^2/dx^2. After the projection D4(u) = 0 to round-off, the
condition under which the fourth-order advection conserves kinetic energy exactly; the second-order
divergence D2(u) is then not zero but O(dx^2): D2 - D4 is, per direction, s^2/(6 + s^2) times that
direction's part of D4 (1/7 on the 2 dx wave, 1.6 % on the 10 dx wave). The (0, 0) mode and the z
solve are as above.

The FFTs (numpy's pocketfft) release the GIL; they run on ``workers`` threads over slabs of z
levels. The right-hand side is held as (nz, nx, ny) so that each level's 2-D transform is
contiguous. Pressure p is the kinematic pressure [m^2 s^-2]: phi / (stage time step).
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np
from numba import prange

from ..._jit import device, jit, pjit

__all__ = ["PressureSolver", "divergence", "gradient", "laplacian", "max_relative_divergence",
           "modified_wavenumber_sq", "PROJECTION_ORDERS"]

#: horizontal orders of the divergence and gradient (advection.ADVECTION_ORDERS)
PROJECTION_ORDERS = (2, 4)
#: Morinishi et al.'s staggered fourth-order difference: 9/8 on the narrow one, 1/8 x 1/3 on the
#: wide one (over 3 h)
C1 = 9.0 / 8.0
C3 = 1.0 / 24.0


#: columns per block of the transposing kernels: one 64-byte line of the (nz, nx, ny) layout per
#: level and block
JB = 8


@pjit
def _divergence_kzxy(u, v, w, rdx, rdy, dzc, rdzc, out):
    nx, ny, nz = u.shape
    # per block of JB columns: the columns' divergence along k (contiguous reads, vectorized) into
    # a scratch tile, then written level by level as whole lines of the (nz, nx, ny) layout
    for i in prange(nx):
        ip = (i + 1) % nx
        tile = np.empty((JB, nz))
        for j0 in range(0, ny, JB):
            nb = min(JB, ny - j0)
            for jj in range(nb):
                j = j0 + jj
                jp = j + 1 if j + 1 < ny else 0
                for k in range(nz):
                    tile[jj, k] = ((u[ip, j, k] - u[i, j, k]) * rdx
                                   + (v[i, jp, k] - v[i, j, k]) * rdy
                                   + (w[i, j, k + 1] - w[i, j, k]) * rdzc[k])
            for k in range(nz):
                for jj in range(nb):
                    out[k, i, j0 + jj] = tile[jj, k]


@pjit
def _divergence4_kzxy(u, v, w, rdx, rdy, dzc, rdzc, out):
    """D4 (module doc) in the (nz, nx, ny) layout, as _divergence_kzxy."""
    nx, ny, nz = u.shape
    for i in prange(nx):
        im = (i - 1) % nx
        ip = (i + 1) % nx
        ip2 = (i + 2) % nx
        tile = np.empty((JB, nz))
        for j0 in range(0, ny, JB):
            nb = min(JB, ny - j0)
            for jj in range(nb):
                j = j0 + jj
                jm = j - 1 if j > 0 else ny - 1
                jp = j + 1 if j + 1 < ny else 0
                jp2 = jp + 1 if jp + 1 < ny else 0
                if j == 0:
                    for k in range(nz):
                        ddx = C1 * (u[ip, j, k] - u[i, j, k]) - C3 * (u[ip2, j, k] - u[im, j, k])
                        ddy = C1 * (v[i, jp, k] - v[i, j, k]) - C3 * (v[i, jp2, k] - v[i, jm, k])
                        tile[jj, k] = (w[i, j, k + 1] - w[i, j, k]) / dzc[k] + ddx * rdx + ddy * rdy
                else:
                    for k in range(nz):
                        ddx = C1 * (u[ip, j, k] - u[i, j, k]) - C3 * (u[ip2, j, k] - u[im, j, k])
                        ddy = C1 * (v[i, jp, k] - v[i, j, k]) - C3 * (v[i, jp2, k] - v[i, jm, k])
                        tile[jj, k] = (ddx * rdx + ddy * rdy
                                       + (w[i, j, k + 1] - w[i, j, k]) * rdzc[k])
            for k in range(nz):
                for jj in range(nb):
                    out[k, i, j0 + jj] = tile[jj, k]


@pjit
def _thomas(hat, a, inv_den, cprime):
    """Solve in place, per (m, n): a_k x[k-1] + b x[k] + c x[k+1] = hat[k] (factors precomputed)."""
    nz, nx, nyh = hat.shape
    for m in prange(nx):
        if m == 0:
            hat[0, 0, 0] = 0.0  # pinned mean mode: phi[0] = 0
        for n in range(nyh):
            hat[0, m, n] = hat[0, m, n] * inv_den[0, m, n]
        for k in range(1, nz):
            ak = a[k]
            for n in range(nyh):
                hat[k, m, n] = (hat[k, m, n] - ak * hat[k - 1, m, n]) * inv_den[k, m, n]
        for k in range(nz - 2, -1, -1):
            for n in range(nyh):
                hat[k, m, n] = hat[k, m, n] - cprime[k, m, n] * hat[k + 1, m, n]


@jit
def _phi_tile(phi, i, j0, lo, n, ny, tile):
    """tile[q, k] = phi[k, i, (j0 + lo + q) mod ny] for q < n: columns of the (nz, nx, ny)
    layout read a level at a time (whole lines) and laid out along k."""
    nz = phi.shape[0]
    for k in range(nz):
        for q in range(n):
            jw = j0 + lo + q
            if jw < 0:
                jw += ny
            elif jw >= ny:
                jw -= ny
            tile[q, k] = phi[k, i, jw]


@device
def _correct_w_p(w, p, tc, c, i, j, dzf, rdzf, rdt, keep, dp):
    """The column (i, j) of _correct and _correct4 past u and v: w -= Gz phi, and p set or
    incremented by phi / dt_stage (rdt = 1 / dt_stage; skipped when rdt == 0); phi is the tile
    row tc[c] (_phi_tile)."""
    nz = tc.shape[1]
    if rdt != 0.0 and keep != 0.0:
        # the increment rounded before it is added (no fused multiply-add): the rounding of the
        # pressure the double-precision results are pinned to
        for k in range(nz):
            dp[k] = tc[c, k] * rdt
        for k in range(nz):
            p[i, j, k] += dp[k]
    elif rdt != 0.0:
        for k in range(nz):
            p[i, j, k] = tc[c, k] * rdt
    if j < 2:
        for k in range(1, nz):
            w[i, j, k] -= (tc[c, k] - tc[c, k - 1]) / dzf[k]
    else:
        for k in range(1, nz):
            w[i, j, k] -= (tc[c, k] - tc[c, k - 1]) * rdzf[k]


@pjit
def _correct(u, v, w, phi, rdx, rdy, dzf, rdzf, p, rdt, keep):
    """u -= G phi; p = keep p + phi / dt_stage (skipped when rdt == 0; keep = 1: the pressure
    increment of an incremental projection). Per block of JB columns, phi of the column and its
    x and y neighbours is first laid out along k in scratch tiles (_phi_tile), so that the
    corrections run along k with contiguous reads and writes."""
    nx, ny, nz = u.shape
    for i in prange(nx):
        im = (i - 1) % nx
        tc = np.empty((JB + 1, nz))     # phi[., i, j0 - 1 .. j0 + JB - 1]
        tw = np.empty((JB, nz))         # phi[., im, j0 .. j0 + JB - 1]
        dp = np.empty(nz)
        for j0 in range(0, ny, JB):
            nb = min(JB, ny - j0)
            _phi_tile(phi, i, j0, -1, nb + 1, ny, tc)
            _phi_tile(phi, im, j0, 0, nb, ny, tw)
            for jj in range(nb):
                j = j0 + jj
                # one array per loop: each vectorizes along k
                for k in range(nz):
                    u[i, j, k] -= (tc[jj + 1, k] - tw[jj, k]) * rdx
                for k in range(nz):
                    v[i, j, k] -= (tc[jj + 1, k] - tc[jj, k]) * rdy
                _correct_w_p(w, p, tc, jj + 1, i, j, dzf, rdzf, rdt, keep, dp)


@pjit
def _correct4(u, v, w, phi, rdx, rdy, dzf, rdzf, p, rdt, keep):
    """_correct with G4 in x and y (module doc)."""
    nx, ny, nz = u.shape
    for i in prange(nx):
        im = (i - 1) % nx
        im2 = (i - 2) % nx
        ip = (i + 1) % nx
        tc = np.empty((JB + 3, nz))     # phi[., i, j0 - 2 .. j0 + JB]
        tw = np.empty((JB, nz))         # phi[., im, j0 .. j0 + JB - 1]
        tw2 = np.empty((JB, nz))        # phi[., im2, ...]
        te = np.empty((JB, nz))         # phi[., ip, ...]
        dp = np.empty(nz)
        for j0 in range(0, ny, JB):
            nb = min(JB, ny - j0)
            _phi_tile(phi, i, j0, -2, nb + 3, ny, tc)
            _phi_tile(phi, im, j0, 0, nb, ny, tw)
            _phi_tile(phi, im2, j0, 0, nb, ny, tw2)
            _phi_tile(phi, ip, j0, 0, nb, ny, te)
            for jj in range(nb):
                j = j0 + jj
                # one array per loop: each vectorizes along k
                for k in range(nz):
                    u[i, j, k] -= (C1 * (tc[jj + 2, k] - tw[jj, k])
                                   - C3 * (te[jj, k] - tw2[jj, k])) * rdx
                for k in range(nz):
                    v[i, j, k] -= (C1 * (tc[jj + 2, k] - tc[jj + 1, k])
                                   - C3 * (tc[jj + 3, k] - tc[jj, k])) * rdy
                _correct_w_p(w, p, tc, jj + 2, i, j, dzf, rdzf, rdt, keep, dp)


def _check_order(order: int) -> int:
    if order not in PROJECTION_ORDERS:
        raise ValueError(f"projection order must be one of {PROJECTION_ORDERS} (got {order!r})")
    return int(order)


def modified_wavenumber_sq(n: int, h: float, order: int = 2) -> np.ndarray:
    """-k'^2 [m^-2] of the modes m = 0 .. n-1: the symbol of D G in one periodic direction of n
    points spaced h [m], -4 s^2/h^2 (order 2) or -(2 s + s^3/3)^2/h^2 (order 4), s = sin(pi m/n)."""
    _check_order(order)
    s = np.sin(np.pi * np.arange(n) / n)
    if order == 2:
        return -4.0 * s**2 / h**2
    return -(2.0 * s + s**3 / 3.0) ** 2 / h**2


class PressureSolver:
    """Projection onto the discretely divergence-free fields for one grid (work arrays
    preallocated); ``order``: the horizontal order of D and G, 2 or 4 (module doc)."""

    def __init__(self, grid, workers: int | None = None, order: int = 2):
        self.order = _check_order(order)
        self.grid = grid
        nx, ny, nz = grid.shape
        self.nyh = ny // 2 + 1
        dzc, dzf = grid.dz_c, grid.dz_f
        a = np.zeros(nz)
        c = np.zeros(nz)
        a[1:] = 1.0 / (dzc[1:] * dzf[1:nz])
        c[:-1] = 1.0 / (dzc[:-1] * dzf[1:nz])
        kx = modified_wavenumber_sq(nx, grid.dx, order)
        ky = modified_wavenumber_sq(ny, grid.dy, order)[:self.nyh]
        lam = kx[:, None] + ky[None, :]
        inv_den = np.empty((nz, nx, self.nyh))
        cprime = np.empty((nz, nx, self.nyh))
        b0 = -(a[0] + c[0]) + lam
        c0 = np.full_like(lam, c[0])
        b0[0, 0], c0[0, 0] = 1.0, 0.0  # pinned mean mode
        inv_den[0] = 1.0 / b0
        cprime[0] = c0 * inv_den[0]
        for k in range(1, nz):
            den = -(a[k] + c[k]) + lam - a[k] * cprime[k - 1]
            inv_den[k] = 1.0 / den
            cprime[k] = c[k] * inv_den[k]
        self._a = a
        self._inv_den = inv_den
        self._cprime = cprime
        self.rhs = np.empty((nz, nx, ny))
        self.hat = np.empty((nz, nx, self.nyh), dtype=np.complex128)
        # the half-transformed slabs: each 1-D pass writes another array than it reads (numpy
        # copies the input of an in-place transform first)
        self._half = np.empty_like(self.hat)
        self.workers = max(1, int(workers if workers is not None else numba.get_num_threads()))
        self.workers = min(self.workers, nz)
        bounds = np.linspace(0, nz, self.workers + 1).astype(int)
        self._slabs = [slice(int(bounds[q]), int(bounds[q + 1])) for q in range(self.workers)]
        # the calling thread transforms the first slab itself, the pool the others
        self._pool = ThreadPoolExecutor(self.workers - 1) if self.workers > 1 else None

    # ---- pieces ---------------------------------------------------------------------------
    def _fft_forward(self) -> None:
        def f(sl):
            # rfft2 over (x, y) as its two 1-D passes (numpy's rfftn: y, then x)
            np.fft.rfft(self.rhs[sl], axis=2, out=self._half[sl])
            np.fft.fft(self._half[sl], axis=1, out=self.hat[sl])
        self._map(f)

    def _fft_inverse(self) -> None:
        ny = self.grid.ny

        def f(sl):
            # Two 1-D passes: numpy 2.x's irfft2(..., out=) returns wrong values (seen with 2.4).
            np.fft.ifft(self.hat[sl], axis=1, out=self._half[sl])
            np.fft.irfft(self._half[sl], n=ny, axis=2, out=self.rhs[sl])
        self._map(f)

    def _map(self, f) -> None:
        if self._pool is None:
            f(self._slabs[0])
            return
        pending = [self._pool.submit(f, sl) for sl in self._slabs[1:]]
        f(self._slabs[0])
        for fut in pending:
            fut.result()

    def solve_rhs_inplace(self) -> None:
        """phi = L^-1 rhs, with ``self.rhs`` ((nz, nx, ny) layout) overwritten by phi."""
        self._fft_forward()
        _thomas(self.hat, self._a, self._inv_den, self._cprime)
        self._fft_inverse()

    # ---- public ---------------------------------------------------------------------------
    def project(self, u, v, w, p=None, dt_stage: float = 0.0, increment: bool = False) -> None:
        """Make (u, v, w) discretely divergence-free in place; p = phi/dt_stage if given
        [m^2 s^-2], or p += phi/dt_stage with ``increment`` (the stage already carried the
        gradient of p)."""
        g = self.grid
        div, corr = ((_divergence_kzxy, _correct) if self.order == 2
                     else (_divergence4_kzxy, _correct4))
        div(u, v, w, 1.0 / g.dx, 1.0 / g.dy, g.dz_c, g.rdz_c, self.rhs)
        self.solve_rhs_inplace()
        if p is None or dt_stage <= 0.0:
            corr(u, v, w, self.rhs, 1.0 / g.dx, 1.0 / g.dy, g.dz_f, g.rdz_f, u, 0.0, 0.0)
        else:
            corr(u, v, w, self.rhs, 1.0 / g.dx, 1.0 / g.dy, g.dz_f, g.rdz_f, p, 1.0 / dt_stage,
                 1.0 if increment else 0.0)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """phi (nx, ny, nz) with L phi = rhs (rhs at cell centres, zero volume-weighted mean)."""
        self.rhs[...] = np.transpose(rhs, (2, 0, 1))
        self.solve_rhs_inplace()
        return np.ascontiguousarray(np.transpose(self.rhs, (1, 2, 0)))

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=False)
            self._pool = None


def divergence(grid, u, v, w, order: int = 2) -> np.ndarray:
    """D(u) at cell centres (nx, ny, nz) [s^-1]; ``order`` 4: D4 (module doc)."""
    out = np.empty((grid.nz, grid.nx, grid.ny))
    kernel = _divergence_kzxy if _check_order(order) == 2 else _divergence4_kzxy
    kernel(u, v, w, 1.0 / grid.dx, 1.0 / grid.dy, grid.dz_c, grid.rdz_c, out)
    return np.ascontiguousarray(np.transpose(out, (1, 2, 0)))


def gradient(grid, phi, order: int = 2):
    """G(phi) on the u, v, w points (w zero at the bed and lid); ``order`` 4: G4 in x and y."""
    def d(axis, h):
        narrow = phi - np.roll(phi, 1, axis=axis)
        if _check_order(order) == 2:
            return narrow / h
        return (C1 * narrow - C3 * (np.roll(phi, -1, axis=axis) - np.roll(phi, 2, axis=axis))) / h
    gx = d(0, grid.dx)
    gy = d(1, grid.dy)
    gz = np.zeros(phi.shape[:2] + (grid.nz + 1,))
    gz[..., 1:-1] = np.diff(phi, axis=2) / grid.dz_f[1:-1]
    return gx, gy, gz


def laplacian(grid, phi, order: int = 2) -> np.ndarray:
    """L phi = D G phi (the operator the projection inverts) [units of phi m^-2]."""
    gx, gy, gz = gradient(grid, phi, order)
    return divergence(grid, np.ascontiguousarray(gx), np.ascontiguousarray(gy), gz, order)


def max_relative_divergence(grid, u, v, w, order: int = 2) -> float:
    """max |D(u)| min(dx, dy, dz) / max|u|: the projection's residual relative to the flow [-]."""
    d = divergence(grid, u, v, w, order)
    umax = max(np.abs(u).max(), np.abs(v).max(), np.abs(w).max(), 1e-300)
    return float(np.abs(d).max() * min(grid.dx, grid.dy, grid.dz_c.min()) / umax)
