"""Deardorff 1.5-order subgrid TKE closure (Deardorff 1980, Boundary-Layer Meteorol. 18, 495; Moeng
1984, J. Atmos. Sci. 41, 2052), the paper's (its Appendix A, eq. A1, after Dupont et al. 2010):

    nu_t = c_m l sqrt(e)                                  eddy viscosity [m^2 s^-1], c_m = 0.1
    tau_ij = -2 nu_t S_ij                                 SGS stress (kinematic) [m^2 s^-2]
    de/dt + u_j de/dx_j = -tau_ij S_ij                    shear production P
                        + d/dx_j (2 nu_t de/dx_j)         turbulent transport
                        - eps,  eps = c_eps e^{3/2} / l   dissipation, c_eps = 0.19 + 0.74 l / Delta
                        - (grain sink: tke_sink e, implicit once per step)

(neutral: no buoyancy term). Delta = (dx dy dz)^{1/3}, by default times the anisotropy factor of
Scotti, Meneveau & Lilly (1993, Phys. Fluids A 5, 2306), f = cosh(sqrt(4/27 [(ln a1)^2 - ln a1
ln a2 + (ln a2)^2])), a1, a2 the two smaller spacings over the largest (docs/ARCHITECTURE.md).

Near the bed, where Delta >> z, l = Delta leaves the SGS model too weak (the log law overshoots),
so l = [Delta^-n + (c_l kappa z)^-n]^(-1/n) (Mason & Thomson 1992 blending), c_l such that a
purely-SGS log layer is an equilibrium: P = eps gives nu_t = c_m^{3/2} c_eps^{-1/2} l^2 S, and
nu_t S = u*^2 with S = u*/(kappa z) gives l = (c_eps / c_m^3)^{1/4} kappa z = 3.7 kappa z.

``case.closure.viscosity`` "anisotropic": eq. A1's pair, nu_h = c_m l_h sqrt(e) for tau_11,
tau_12, tau_22 and the horizontal transport, nu_v = c_m l_v sqrt(e) for the vertical ones, l_h =
sqrt(dx dy), l_v = dz, each blended as l; the kernels take nu_h and rv = l_v / l_h per level.
T_ij = -tau_ij = 2 nu_t S_ij is the diffusive momentum flux; at the bed T_i3 = -tau_s,i (wall.py).
"""
from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..._jit import device, like, pjit

#: Lagrangian structure-function constant C0 of the subgrid Lagrangian time T_L of the grains' TKE
#: sink (eq. A1); not given in the paper
C0_LAGRANGIAN = 2.1

C_M = 0.1            #: Deardorff (1980) / Moeng (1984) eddy-viscosity constant
C_EPS_0 = 0.19       #: c_eps = C_EPS_0 + C_EPS_1 l / Delta (Deardorff 1980; Moeng 1984)
C_EPS_1 = 0.74
C_L = 3.7            #: near-wall length l -> C_L kappa z (equilibrium log layer, see module doc)
BLEND_N = 2.0        #: exponent of the Mason & Thomson (1992) blending of Delta and C_L kappa z
E_MIN = 1.0e-10      #: floor of e [m^2 s^-2]: keeps sqrt(e) and e^{3/2} defined


DELTA_KINDS = ("scotti", "geometric")


def scotti_factor(dx: float, dy: float, dz: np.ndarray) -> np.ndarray:
    """Scotti et al. (1993) factor f >= 1 per level (nz,): Delta = f (dx dy dz)^{1/3}."""
    h = np.stack(np.broadcast_arrays(np.float64(dx), np.float64(dy), np.asarray(dz, dtype=np.float64)))
    h = np.sort(h, axis=0)                      # smallest, middle, largest spacing per level
    la1, la2 = np.log(h[0] / h[2]), np.log(h[1] / h[2])
    return np.cosh(np.sqrt(4.0 / 27.0 * (la1 * la1 - la1 * la2 + la2 * la2)))


def delta_profile(grid, delta: str = "scotti") -> np.ndarray:
    """Filter width Delta(z) (nz,) [m]: (dx dy dz_c)^{1/3}, times the Scotti factor by default."""
    if delta not in DELTA_KINDS:
        raise ValueError(f"delta must be one of {DELTA_KINDS} (got {delta!r})")
    d = (grid.dx * grid.dy * grid.dz_c) ** (1.0 / 3.0)
    return d * scotti_factor(grid.dx, grid.dy, grid.dz_c) if delta == "scotti" else d


def wall_blend(length, grid, kappa: float = 0.4, c_l: float = C_L, n: float = BLEND_N) -> np.ndarray:
    """[length^-n + (c_l kappa z)^-n]^(-1/n) at the cell centres (nz,) [m] (module doc)."""
    lw = c_l * kappa * grid.z_c
    return (np.asarray(length, dtype=np.float64) ** -n + lw ** -n) ** (-1.0 / n)


def length_scale(grid, kappa: float = 0.4, c_l: float = C_L, n: float = BLEND_N,
                 delta: str = "scotti") -> np.ndarray:
    """Mixing length l(z) at the cell centres (nz,) [m] (see module docstring)."""
    return wall_blend(delta_profile(grid, delta), grid, kappa, c_l, n)


VISCOSITY_KINDS = ("isotropic", "anisotropic")


def viscosity_lengths(grid, kappa: float = 0.4, viscosity: str = "isotropic",
                      delta: str = "scotti") -> tuple[np.ndarray, np.ndarray]:
    """(l_h, l_v) (nz,) [m] of the horizontal and vertical eddy viscosities (module doc)."""
    if viscosity not in VISCOSITY_KINDS:
        raise ValueError(f"viscosity must be one of {VISCOSITY_KINDS} (got {viscosity!r})")
    if viscosity == "isotropic":
        ell = length_scale(grid, kappa, delta=delta)
        return ell, ell.copy()
    return (wall_blend(math.sqrt(grid.dx * grid.dy), grid, kappa),
            wall_blend(grid.dz_c, grid, kappa))


def c_eps_profile(grid, l: np.ndarray, delta: str = "scotti") -> np.ndarray:
    """c_eps = 0.19 + 0.74 l/Delta per level (Deardorff 1980)."""
    return C_EPS_0 + C_EPS_1 * l / delta_profile(grid, delta)


@pjit
def compute_nu(e, cml, nu_mol, nu):
    """nu = c_m l sqrt(e) + nu_mol in place; cml = c_m l per level."""
    zero = like(e, 0.0)
    nx, ny, nz = e.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                ek = e[i, j, k]
                if ek < zero:
                    ek = zero
                nu[i, j, k] = cml[k] * math.sqrt(ek) + nu_mol


@device
def diff_u_split_at(u, v, w, nu, rv, taux, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, dzc, dzf):
    """d T_1j / dx_j at the u point [m s^-2] as (explicit, a, c [s^-1]): explicit + c (u_k+1 - u_k)
    - a (u_k - u_k-1); explicit: T_11, T_12, T_13's dw/dx part and the bed flux -taux."""
    zero = like(u, 0.0)
    quarter = like(u, 0.25)
    one = like(u, 1.0)
    two = like(u, 2.0)
    uc = u[i, j, k]
    t11e = two * nu[i, j, k] * (u[ip, j, k] - uc) * rdx
    t11w = two * nu[im, j, k] * (uc - u[im, j, k]) * rdx
    nun = quarter * (nu[im, j, k] + nu[i, j, k] + nu[im, jp, k] + nu[i, jp, k])
    t12n = nun * ((u[i, jp, k] - uc) * rdy + (v[i, jp, k] - v[im, jp, k]) * rdx)
    nus = quarter * (nu[im, jm, k] + nu[i, jm, k] + nu[im, j, k] + nu[i, j, k])
    t12s = nus * ((uc - u[i, jm, k]) * rdy + (v[i, j, k] - v[im, j, k]) * rdx)
    rdz = one / dzc[k]
    xt = zero
    c = zero
    if top:
        nut = quarter * ((nu[im, j, k] + nu[i, j, k]) * rv[k]
                         + (nu[im, j, k + 1] + nu[i, j, k + 1]) * rv[k + 1])
        xt = nut * (w[i, j, k + 1] - w[im, j, k + 1]) * rdx
        c = nut / dzf[k + 1] * rdz
    a = zero
    if bot:
        nub = quarter * ((nu[im, j, k - 1] + nu[i, j, k - 1]) * rv[k - 1]
                         + (nu[im, j, k] + nu[i, j, k]) * rv[k])
        xb = nub * (w[i, j, k] - w[im, j, k]) * rdx
        a = nub / dzf[k] * rdz
    else:
        xb = -taux[i, j]
    return (t11e - t11w) * rdx + (t12n - t12s) * rdy + (xt - xb) * rdz, a, c


@device
def diff_v_split_at(u, v, w, nu, rv, tauy, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, dzc, dzf):
    """d T_2j / dx_j at the v point split as ``diff_u_split_at`` (bed flux T_23 = -tauy)."""
    zero = like(v, 0.0)
    quarter = like(v, 0.25)
    one = like(v, 1.0)
    two = like(v, 2.0)
    vc = v[i, j, k]
    nue = quarter * (nu[i, jm, k] + nu[ip, jm, k] + nu[i, j, k] + nu[ip, j, k])
    t12e = nue * ((u[ip, j, k] - u[ip, jm, k]) * rdy + (v[ip, j, k] - vc) * rdx)
    nuw = quarter * (nu[im, jm, k] + nu[i, jm, k] + nu[im, j, k] + nu[i, j, k])
    t12w = nuw * ((u[i, j, k] - u[i, jm, k]) * rdy + (vc - v[im, j, k]) * rdx)
    t22n = two * nu[i, j, k] * (v[i, jp, k] - vc) * rdy
    t22s = two * nu[i, jm, k] * (vc - v[i, jm, k]) * rdy
    rdz = one / dzc[k]
    xt = zero
    c = zero
    if top:
        nut = quarter * ((nu[i, jm, k] + nu[i, j, k]) * rv[k]
                         + (nu[i, jm, k + 1] + nu[i, j, k + 1]) * rv[k + 1])
        xt = nut * (w[i, j, k + 1] - w[i, jm, k + 1]) * rdy
        c = nut / dzf[k + 1] * rdz
    a = zero
    if bot:
        nub = quarter * ((nu[i, jm, k - 1] + nu[i, j, k - 1]) * rv[k - 1]
                         + (nu[i, jm, k] + nu[i, j, k]) * rv[k])
        xb = nub * (w[i, j, k] - w[i, jm, k]) * rdy
        a = nub / dzf[k] * rdz
    else:
        xb = -tauy[i, j]
    return (t12e - t12w) * rdx + (t22n - t22s) * rdy + (xt - xb) * rdz, a, c


@device
def vertical_coupling(f, i, j, k, a, c, top, bot):
    """c (f_k+1 - f_k) - a (f_k - f_k-1) on column (i, j): a split diffusion's vertical part."""
    zero = like(f, 0.0)
    fc = f[i, j, k]
    r = zero
    if top:
        r += c * (f[i, j, k + 1] - fc)
    if bot:
        r -= a * (fc - f[i, j, k - 1])
    return r


@device
def diff_w_split_at(u, v, w, nu, rv, i, j, k, im, ip, jm, jp, rdx, rdy, dzc, dzf):
    """d T_3j / dx_j at the interior w point, split as diff_u_split_at (all with nu rv)."""
    quarter = like(w, 0.25)
    one = like(w, 1.0)
    two = like(w, 2.0)
    wc = w[i, j, k]
    rdzf = one / dzf[k]
    r0 = quarter * rv[k - 1]
    r1 = quarter * rv[k]
    nue = r0 * (nu[i, j, k - 1] + nu[ip, j, k - 1]) + r1 * (nu[i, j, k] + nu[ip, j, k])
    t13e = nue * ((u[ip, j, k] - u[ip, j, k - 1]) * rdzf + (w[ip, j, k] - wc) * rdx)
    nuw = r0 * (nu[im, j, k - 1] + nu[i, j, k - 1]) + r1 * (nu[im, j, k] + nu[i, j, k])
    t13w = nuw * ((u[i, j, k] - u[i, j, k - 1]) * rdzf + (wc - w[im, j, k]) * rdx)
    nun = r0 * (nu[i, j, k - 1] + nu[i, jp, k - 1]) + r1 * (nu[i, j, k] + nu[i, jp, k])
    t23n = nun * ((v[i, jp, k] - v[i, jp, k - 1]) * rdzf + (w[i, jp, k] - wc) * rdy)
    nus = r0 * (nu[i, jm, k - 1] + nu[i, j, k - 1]) + r1 * (nu[i, jm, k] + nu[i, j, k])
    t23s = nus * ((v[i, j, k] - v[i, j, k - 1]) * rdzf + (wc - w[i, jm, k]) * rdy)
    c = two * nu[i, j, k] * rv[k] / dzc[k] * rdzf
    a = two * nu[i, j, k - 1] * rv[k - 1] / dzc[k - 1] * rdzf
    return (t13e - t13w) * rdx + (t23n - t23s) * rdy, a, c


@device
def strain_edges(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc, rdzf, rlog):
    """The strain's terms around cell (i, j, k) [s^-1]: S_11, S_22, S_33, 2 S_12 on the vertical
    edges, 2 S_13, 2 S_23 on the edges below (a, b) and above (c, d). The bed face's shear is
    the log law's, u_1 rlog (bot False), the lid's 0; i, j signed (a modulo made it 4x slower)."""
    zero = like(u, 0.0)
    s11 = (u[ip, j, k] - u[i, j, k]) * rdx
    s22 = (v[i, jp, k] - v[i, j, k]) * rdy
    s33 = (w[i, j, k + 1] - w[i, j, k]) * rdzc[k]
    e00 = (u[i, j, k] - u[i, jm, k]) * rdy + (v[i, j, k] - v[im, j, k]) * rdx
    e10 = (u[ip, j, k] - u[ip, jm, k]) * rdy + (v[ip, j, k] - v[i, j, k]) * rdx
    e01 = (u[i, jp, k] - u[i, j, k]) * rdy + (v[i, jp, k] - v[im, jp, k]) * rdx
    e11 = (u[ip, jp, k] - u[ip, j, k]) * rdy + (v[ip, jp, k] - v[i, jp, k]) * rdx
    if bot:
        rdz = rdzf[k]
        a0 = (u[i, j, k] - u[i, j, k - 1]) * rdz + (w[i, j, k] - w[im, j, k]) * rdx
        a1 = (u[ip, j, k] - u[ip, j, k - 1]) * rdz + (w[ip, j, k] - w[i, j, k]) * rdx
        b0 = (v[i, j, k] - v[i, j, k - 1]) * rdz + (w[i, j, k] - w[i, jm, k]) * rdy
        b1 = (v[i, jp, k] - v[i, jp, k - 1]) * rdz + (w[i, jp, k] - w[i, j, k]) * rdy
    else:
        a0 = u[i, j, k] * rlog
        a1 = u[ip, j, k] * rlog
        b0 = v[i, j, k] * rlog
        b1 = v[i, jp, k] * rlog
    c0 = zero
    c1 = zero
    d0 = zero
    d1 = zero
    if top:
        kt = k + 1
        rdz = rdzf[kt]
        c0 = (u[i, j, kt] - u[i, j, k]) * rdz + (w[i, j, kt] - w[im, j, kt]) * rdx
        c1 = (u[ip, j, kt] - u[ip, j, k]) * rdz + (w[ip, j, kt] - w[i, j, kt]) * rdx
        d0 = (v[i, j, kt] - v[i, j, k]) * rdz + (w[i, j, kt] - w[i, jm, kt]) * rdy
        d1 = (v[i, jp, kt] - v[i, jp, k]) * rdz + (w[i, jp, kt] - w[i, j, kt]) * rdy
    return s11, s22, s33, e00, e10, e01, e11, a0, a1, b0, b1, c0, c1, d0, d1


@device
def strain_sq_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc, rdzf, rlog):
    """2 S_ij S_ij at the cell centre [s^-2] as (2 S_11^2 + 2 S_22^2 + 4 S_12^2, the rest), the
    parts against the horizontal and the vertical viscosity (strain_edges)."""
    zero = like(u, 0.0)
    quarter = like(u, 0.25)
    two = like(u, 2.0)
    s11, s22, s33, e00, e10, e01, e11, a0, a1, b0, b1, c0, c1, d0, d1 = strain_edges(
        u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc, rdzf, rlog)
    acc = two * (s11 * s11 + s22 * s22)
    acc += quarter * (e00 * e00 + e10 * e10 + e01 * e01 + e11 * e11)
    q = zero
    q += a0 * a0 + a1 * a1 + b0 * b0 + b1 * b1
    if top:
        q += c0 * c0 + c1 * c1 + d0 * d0 + d1 * d1
    return acc, two * s33 * s33 + quarter * q


@device
def tke_split_at(e, u, v, w, nu, rv, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc, rdzf,
                 rlog, ceps_over_l_k):
    """de/dt without advection (eq. A1) as (P + horizontal transport [m^2 s^-3], a, c, r [s^-1]):
    de/dt = that + c (e_k+1 - e_k) - a (e_k - e_k-1) - r e_k, r = c_eps e^{1/2} / l."""
    zero = like(e, 0.0)
    ec = e[i, j, k]
    nuc = nu[i, j, k]
    sh, sv = strain_sq_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc, rdzf, rlog)
    nvc = nuc * rv[k]
    prod = nuc * sh + nvc * sv
    fe = (nuc + nu[ip, j, k]) * (e[ip, j, k] - ec) * rdx
    fw = (nu[im, j, k] + nuc) * (ec - e[im, j, k]) * rdx
    fn = (nuc + nu[i, jp, k]) * (e[i, jp, k] - ec) * rdy
    fs = (nu[i, jm, k] + nuc) * (ec - e[i, jm, k]) * rdy
    c = zero
    a = zero
    if top:
        c = (nvc + nu[i, j, k + 1] * rv[k + 1]) * rdzf[k + 1] * rdzc[k]
    if bot:
        a = (nu[i, j, k - 1] * rv[k - 1] + nvc) * rdzf[k] * rdzc[k]
    ep = ec if ec > zero else zero
    return prod + (fe - fw) * rdx + (fn - fs) * rdy, a, c, ceps_over_l_k * math.sqrt(ep)


@pjit
def sgs_stress_uw_profile(u, w, nu, rv, taux, dzf, rdx):
    """Horizontal means of the SGS flux tau_13 on the faces z_w (nz+1,) [m^2 s^-2] (bed: taux)."""
    nx, ny, nz = u.shape
    part = np.zeros((nx, nz + 1))
    for i in prange(nx):
        im = (i - 1) % nx
        for j in range(ny):
            part[i, 0] += taux[i, j]
            for k in range(1, nz):
                nub = 0.25 * ((nu[im, j, k - 1] + nu[i, j, k - 1]) * rv[k - 1]
                              + (nu[im, j, k] + nu[i, j, k]) * rv[k])
                part[i, k] -= nub * ((u[i, j, k] - u[i, j, k - 1]) / dzf[k]
                                     + (w[i, j, k] - w[im, j, k]) * rdx)
    out = np.zeros(nz + 1)
    for i in range(nx):
        for k in range(nz + 1):
            out[k] += part[i, k]
    return out / (nx * ny)
