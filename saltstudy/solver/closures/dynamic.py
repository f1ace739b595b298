"""Plane-averaged, scale-dependent dynamic Smagorinsky closure, with the SGS TKE of the paper's eq. A1
diagnosed in local equilibrium (grain sink included).

Why: with the paper's Deardorff model phi = kappa z/u* dU/dz dips to ~0.7 at z/Delta ~ 3-10
(`saltstudy probe loglaw`); a fixed coefficient cannot follow the SGS share as eddies shrink.

Model (Smagorinsky 1963; Germano et al. 1991; Lilly 1992): tau_ij - delta_ij tau_kk/3 = -2 nu_t
S_ij, nu_t = (C_s Delta)^2 |S|, |S| = sqrt(2 S_ij S_ij), (C_s Delta)^2 a function of height
computed every ``interval`` steps by the Germano identity on horizontal planes (Porte-Agel,
Meneveau & Parlange 2000, J. Fluid Mech. 415, 261):

    L_ij = <u_i u_j>^ - u^_i u^_j,      M_ij = 2 [ (|S| S_ij)^ - a^2 |S^| S^_ij ],
    (C_s Delta)^2 (at the test scale) = <L_ij M_ij> / <M_ij M_ij>    (<> a plane mean)

^ a test filter in x and y: Simpson weights (1, 4, 1)/6 and (1, 4, 2, 4, 1)/12 (the second
moments of box filters of 2 and 4 cells) give the coefficient at 2 Delta and 4 Delta; with the
scale dependence of Bou-Zeid, Meneveau & Parlange (2005, Phys. Fluids 17, 025105),
beta = C^2(4 Delta) / C^2(2 Delta) (>= BETA_MIN) and (C_s Delta)^2 = C^2(2 Delta) / beta. Delta =
(dx dy dz)^(1/3), and a filter of alpha dx in x and y widens it by alpha^(2/3), so a^2 =
alpha^(4/3) (an a-priori test on a k^-5/3 field, tests/test_dynamic_sgs.py, gives C_s ~ 0.17 and
beta ~ 1; with a^2 = alpha^2 C_s came out ~25 % low). Negative plane means are clipped to zero
(no backscatter), C_s is bounded by CS_MAX.

The SGS TKE e is the local-equilibrium solution of A1 (production = dissipation + grain sink
r e, r = ``state.tke_sink``) for nu_t = C_K l sqrt(e), the paper's C_K = 0.1 and the Deardorff
length l (sgs.length_scale), with c_eps such that without grains it is the Smagorinsky model:

    c_eps / l = (C_K l)^3 / (C_s Delta)^4,        C_K l sqrt(e) |S|^2 = (c_eps/l) e^(3/2) + r e,

a quadratic in sqrt(e): nu_t = (C_s Delta)^2 |S| / (sqrt(1 + rho^2) + rho), rho = r (C_s
Delta)^2 / (2 (C_K l)^2 |S|): the grains lower the viscosity where they load the air, and every
reader of e sees a field consistent with it. (A prognostic dynamic TKE model would need the
test-level SGS energy, Ghosal et al. 1995.) The coefficient is checkpointed.
"""
from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..._jit import device, pjit
from .sgs import C0_LAGRANGIAN, C_M, E_MIN, length_scale, strain_edges


#: upper bound of C_s (about twice the Smagorinsky-Lilly value 0.17)
CS_MAX = 0.35
#: lower bound of beta (Bou-Zeid et al. 2005)
BETA_MIN = 0.125
#: a^2 for the test filters of 2 dx and 4 dx in x and y (module doc): alpha^(4/3)
TEST_ALPHA_SQ = (2.0 ** (4.0 / 3.0), 4.0 ** (4.0 / 3.0))
#: number of plane fields filtered per level: u_i (3), u_i u_j (6), S_ij (6), |S| S_ij (6)
_NQ = 21


@device
def strain_at_centre(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc, rdzf, rlog):
    """(S11, S22, S33, S12, S13, S23) at the centre of cell (i, j, k) [s^-1], each off-diagonal
    term the mean of its four edges (sgs.strain_edges; the upper edges summed in float64)."""
    s11, s22, s33, e00, e10, e01, e11, a0, a1, b0, b1, c0, c1, d0, d1 = strain_edges(
        u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc, rdzf, rlog)
    return (s11, s22, s33, 0.125 * (e00 + e10 + e01 + e11),
            0.125 * (a0 + a1 + float(c0) + float(c1)), 0.125 * (b0 + b1 + float(d0) + float(d1)))


@device
def _strain_norm(s11, s22, s33, s12, s13, s23):
    """|S| = sqrt(2 S_ij S_ij) [s^-1]."""
    return math.sqrt(2.0 * (s11 * s11 + s22 * s22 + s33 * s33)
                     + 4.0 * (s12 * s12 + s13 * s13 + s23 * s23))


@device
def filter_plane_2(src, dst, tmp):
    """dst = the (1, 4, 1)/6 filter of the periodic plane src in x, then in y (width 2 cells);
    the y pass peels its end points so that the interior loop vectorises (twice as fast)."""
    nx, ny = src.shape
    for i in range(nx):
        im = i - 1 if i > 0 else nx - 1
        ip = i + 1 if i < nx - 1 else 0
        for j in range(ny):
            tmp[i, j] = (src[im, j] + 4.0 * src[i, j] + src[ip, j]) * (1.0 / 6.0)
    for i in range(nx):
        dst[i, 0] = (tmp[i, ny - 1] + 4.0 * tmp[i, 0] + tmp[i, 1]) * (1.0 / 6.0)
        for j in range(1, ny - 1):
            dst[i, j] = (tmp[i, j - 1] + 4.0 * tmp[i, j] + tmp[i, j + 1]) * (1.0 / 6.0)
        dst[i, ny - 1] = (tmp[i, ny - 2] + 4.0 * tmp[i, ny - 1] + tmp[i, 0]) * (1.0 / 6.0)


@device
def _y5(tmp, i, j1, j2, j, j4, j5):
    return (tmp[i, j1] + 4.0 * tmp[i, j2] + 2.0 * tmp[i, j] + 4.0 * tmp[i, j4]
            + tmp[i, j5]) * (1.0 / 12.0)


@device
def filter_plane_4(src, dst, tmp):
    """dst = the (1, 4, 2, 4, 1)/12 filter of src in x, then y (as filter_plane_2)."""
    nx, ny = src.shape
    for i in range(nx):
        i1 = (i - 2) % nx
        i2 = (i - 1) % nx
        i4 = (i + 1) % nx
        i5 = (i + 2) % nx
        for j in range(ny):
            tmp[i, j] = (src[i1, j] + 4.0 * src[i2, j] + 2.0 * src[i, j] + 4.0 * src[i4, j]
                         + src[i5, j]) * (1.0 / 12.0)
    for i in range(nx):
        dst[i, 0] = _y5(tmp, i, ny - 2, ny - 1, 0, 1, 2)
        dst[i, 1] = _y5(tmp, i, ny - 1, 0, 1, 2, 3)
        for j in range(2, ny - 2):
            dst[i, j] = (tmp[i, j - 2] + 4.0 * tmp[i, j - 1] + 2.0 * tmp[i, j] + 4.0 * tmp[i, j + 1]
                         + tmp[i, j + 2]) * (1.0 / 12.0)
        dst[i, ny - 2] = _y5(tmp, i, ny - 4, ny - 3, ny - 2, ny - 1, 0)
        dst[i, ny - 1] = _y5(tmp, i, ny - 3, ny - 2, ny - 1, 0, 1)


@device
def _contract(f, a2, i, j):
    """(L_ij M_ij, M_ij M_ij) at one point from the filtered fields f (module doc)."""
    u1 = f[0, i, j]
    u2 = f[1, i, j]
    u3 = f[2, i, j]
    l11 = f[3, i, j] - u1 * u1
    l12 = f[4, i, j] - u1 * u2
    l13 = f[5, i, j] - u1 * u3
    l22 = f[6, i, j] - u2 * u2
    l23 = f[7, i, j] - u2 * u3
    l33 = f[8, i, j] - u3 * u3
    s11 = f[9, i, j]
    s22 = f[10, i, j]
    s33 = f[11, i, j]
    s12 = f[12, i, j]
    s13 = f[13, i, j]
    s23 = f[14, i, j]
    c = a2 * _strain_norm(s11, s22, s33, s12, s13, s23)
    m11 = 2.0 * (f[15, i, j] - c * s11)
    m22 = 2.0 * (f[16, i, j] - c * s22)
    m33 = 2.0 * (f[17, i, j] - c * s33)
    m12 = 2.0 * (f[18, i, j] - c * s12)
    m13 = 2.0 * (f[19, i, j] - c * s13)
    m23 = 2.0 * (f[20, i, j] - c * s23)
    lm = l11 * m11 + l22 * m22 + l33 * m33 + 2.0 * (l12 * m12 + l13 * m13 + l23 * m23)
    mm = m11 * m11 + m22 * m22 + m33 * m33 + 2.0 * (m12 * m12 + m13 * m13 + m23 * m23)
    return lm, mm


@pjit
def germano_sums(u, v, w, rdx, rdy, rdzc, rdzf, rlog, a2_2, a2_4, out):
    """Per level, plane means of L_ij M_ij and M_ij M_ij for the 2 dx (out[:, :2]) and 4 dx
    test filters, M without Delta^2 (the ratio is (C_s Delta)^2 [m^2]); parallel over levels."""
    nx, ny, nz = u.shape
    inv = 1.0 / (nx * ny)
    for kk in prange(nz):
        k = np.int64(kk)
        q = np.empty((_NQ, nx, ny))
        f = np.empty((_NQ, nx, ny))
        tmp = np.empty((nx, ny))
        top = k < nz - 1
        bot = k > 0
        for i in range(nx):
            im = i - 1 if i > 0 else nx - 1
            ip = i + 1 if i < nx - 1 else 0
            for j in range(ny):
                jm = j - 1 if j > 0 else ny - 1
                jp = j + 1 if j < ny - 1 else 0
                uc = 0.5 * (u[i, j, k] + u[ip, j, k])
                vc = 0.5 * (v[i, j, k] + v[i, jp, k])
                wc = 0.5 * (w[i, j, k] + w[i, j, k + 1])
                s11, s22, s33, s12, s13, s23 = strain_at_centre(u, v, w, i, j, k, im, ip, jm, jp,
                                                                top, bot, rdx, rdy, rdzc, rdzf, rlog)
                sn = _strain_norm(s11, s22, s33, s12, s13, s23)
                # q: u_i, u_i u_j (i <= j), S_ij, |S| S_ij; one element type for a single-precision
                # flow (whose S_11, S_22, S_33 are float32)
                vel = (uc, vc, wc)
                sij = (float(s11), float(s22), float(s33), s12, s13, s23)
                m = 3
                for p in range(3):
                    q[p, i, j] = vel[p]
                    for r in range(p, 3):
                        q[m, i, j] = vel[p] * vel[r]
                        m += 1
                for n in range(6):
                    q[9 + n, i, j] = sij[n]
                    q[15 + n, i, j] = sn * sij[n]
        for c in range(2):  # the 2 dx test filter, then the 4 dx one
            for n in range(_NQ):
                if c == 0:
                    filter_plane_2(q[n], f[n], tmp)
                else:
                    filter_plane_4(q[n], f[n], tmp)
            a2 = a2_2 if c == 0 else a2_4
            lm = 0.0
            mm = 0.0
            for i in range(nx):
                for j in range(ny):
                    a, b = _contract(f, a2, i, j)
                    lm += a
                    mm += b
            out[k, 2 * c] = lm * inv
            out[k, 2 * c + 1] = mm * inv


def coefficient_profile(sums: np.ndarray, delta: np.ndarray, cs_max: float = CS_MAX,
                        beta_min: float = BETA_MIN) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """((C_s Delta)^2 [m^2], beta, C_s) per level (0 and NaN where C^2(2 Delta) <= 0)."""
    sums = np.asarray(sums, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        c2 = np.where(sums[:, 1] > 0, sums[:, 0] / sums[:, 1], 0.0)
        c4 = np.where(sums[:, 3] > 0, sums[:, 2] / sums[:, 3], 0.0)
        beta = np.where(c2 > 0, np.maximum(c4 / np.where(c2 > 0, c2, 1.0), beta_min), np.nan)
        cs2d2 = np.where(c2 > 0, c2 / np.where(np.isfinite(beta), beta, 1.0), 0.0)
    cs2d2 = np.minimum(np.maximum(cs2d2, 0.0), (cs_max * delta) ** 2)
    return cs2d2, beta, np.sqrt(cs2d2) / delta


@pjit
def smagorinsky_viscosity(u, v, w, cs2d2, ckl, sink, with_sink, nu_mol, rdx, rdy, rdzc, rdzf, rlog,
                          e_min, nu, e):
    """nu = (C_s Delta)^2 |S| g + nu_mol and the diagnosed e in place (module doc)."""
    nx, ny, nz = u.shape
    for ii in prange(nx):
        i = np.int64(ii)
        im = (i - 1) % nx
        ip = (i + 1) % nx
        for j in range(ny):
            jm = (j - 1) % ny
            jp = (j + 1) % ny
            for k in range(nz):
                c = cs2d2[k]
                if c <= 0.0:
                    nu[i, j, k] = nu_mol
                    e[i, j, k] = e_min
                    continue
                s11, s22, s33, s12, s13, s23 = strain_at_centre(u, v, w, i, j, k, im, ip, jm, jp,
                                                                k < nz - 1, k > 0, rdx, rdy, rdzc,
                                                                rdzf, rlog)
                sn = _strain_norm(s11, s22, s33, s12, s13, s23)
                nt = c * sn
                if with_sink:
                    r = sink[i, j, k]
                    if r > 0.0 and sn > 0.0:
                        kl = ckl[k]
                        rho = r * c / (2.0 * kl * kl * sn)
                        nt = nt / (math.sqrt(1.0 + rho * rho) + rho)
                nu[i, j, k] = nt + nu_mol
                ek = (nt / ckl[k]) ** 2
                e[i, j, k] = ek if ek > e_min else e_min


class DynamicSmagorinsky:
    """(C_s Delta)^2 per level, updated every ``interval`` steps, and ``ceps_l`` [m^-1], ``tlc``
    [m s^-1] updated in place (the stepper and the grains hold references to them)."""

    def __init__(self, grid, kappa: float, rlog: float, delta: str = "scotti", interval: int = 5):
        if interval < 1:
            raise ValueError(f"dynamic interval must be >= 1 step (got {interval})")
        if min(grid.nx, grid.ny) < 5:
            raise ValueError(f"the dynamic closure's 4 dx test filter spans 5 cells: the grid has "
                             f"nx = {grid.nx}, ny = {grid.ny}")
        self.grid = grid
        self.interval = int(interval)
        self.rlog = float(rlog)
        nz = grid.nz
        #: the filter width Delta = (dx dy dz)^(1/3) of the coefficient [m]
        self.delta = (grid.dx * grid.dy * grid.dz_c) ** (1.0 / 3.0)
        #: C_K l: the paper's nu_t = C_K l sqrt(e) that defines the diagnosed e [m]
        self.ckl = np.ascontiguousarray(C_M * length_scale(grid, kappa, delta=delta))
        #: the coefficient scale (C_s Delta)^2 per level [m^2]
        self.cs2d2 = np.zeros(nz)
        self.beta = np.full(nz, np.nan)
        self.sums = np.zeros((nz, 4))
        self.ceps_l = np.zeros(nz)
        self.tlc = np.zeros(nz)
        self.c0 = C0_LAGRANGIAN   # the grain sink's own C0
        self.ready = False
        self.n_updates = 0

    @property
    def c_s(self) -> np.ndarray:
        """C_s per level [-]."""
        return np.sqrt(self.cs2d2) / self.delta

    def _derived(self) -> None:
        c = self.cs2d2
        pos = c > 0
        ceps = np.zeros_like(c)
        ceps[pos] = self.ckl[pos] ** 3 / c[pos] ** 2
        self.ceps_l[...] = ceps
        tl = np.full_like(c, np.inf)
        tl[pos] = 4.0 / (3.0 * self.c0 * ceps[pos])
        self.tlc[...] = tl

    def update(self, u, v, w) -> None:
        """Recompute (C_s Delta)^2 from the resolved field (u, v, w)."""
        g = self.grid
        a2, a4 = TEST_ALPHA_SQ
        germano_sums(u, v, w, 1.0 / g.dx, 1.0 / g.dy, g.rdz_c, g.rdz_f, self.rlog, a2, a4, self.sums)
        cs2d2, beta, _ = coefficient_profile(self.sums, self.delta)
        self.cs2d2[...] = cs2d2
        self.beta[...] = beta
        self._derived()
        self.ready = True
        self.n_updates += 1

    def maybe_update(self, state) -> None:
        """Update at steps that are multiples of ``interval`` (and whenever no coefficient is held)."""
        if not self.ready or state.step % self.interval == 0:
            self.update(state.u, state.v, state.w)

    def viscosity(self, u, v, w, sink, nu_mol: float, nu, e) -> None:
        """nu and the diagnosed e in place from (u, v, w) and the grain sink rate (or None)."""
        g = self.grid
        with_sink = sink is not None
        smagorinsky_viscosity(u, v, w, self.cs2d2, self.ckl, sink if with_sink else nu, with_sink,
                              nu_mol, 1.0 / g.dx, 1.0 / g.dy, g.rdz_c, g.rdz_f, self.rlog, E_MIN, nu, e)

    def checkpoint(self) -> dict:
        return {"cs2d2": self.cs2d2.copy(), "beta": self.beta.copy()}

    def restore(self, data: dict) -> None:
        c = np.asarray(data["cs2d2"], dtype=np.float64)
        if c.shape != self.cs2d2.shape:
            raise ValueError(f"restart: closure coefficient has shape {c.shape}, the grid needs "
                             f"{self.cs2d2.shape}")
        self.cs2d2[...] = c
        if "beta" in data:
            self.beta[...] = np.asarray(data["beta"], dtype=np.float64)
        self._derived()
        self.ready = True
