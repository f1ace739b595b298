"""Deardorff 1.5-order subgrid TKE closure (Deardorff 1980, Boundary-Layer Meteorol. 18, 495;
Moeng 1984, J. Atmos. Sci. 41, 2052), the closure of the paper (its Appendix A, eq. A1, after Dupont et
al. 2010).

    nu_t = c_m l sqrt(e)                                  eddy viscosity [m^2 s^-1], c_m = 0.1
    tau_ij = -2 nu_t S_ij                                 SGS stress (kinematic) [m^2 s^-2]
    de/dt + u_j de/dx_j = -tau_ij S_ij                    shear production P
                        + d/dx_j (2 nu_t de/dx_j)         turbulent transport
                        - eps,  eps = c_eps e^{3/2} / l   dissipation, c_eps = 0.19 + 0.74 l / Delta
                        - (particle sink: tke_sink e, applied implicitly once per step by the stepper)

Delta = (dx dy dz)^{1/3} (Deardorff 1980) times, by default, the anisotropy correction of Scotti,
Meneveau & Lilly (1993, Phys. Fluids A 5, 2306) for cells flatter than wide:
f = cosh(sqrt(4/27 [(ln a1)^2 - ln a1 ln a2 + (ln a2)^2])), a1, a2 the two smaller spacings over the
largest (1.09 for dz/dx = 1/3, 1.33 for 1/8). Flat cells of the stretched grid otherwise get too
short a filter width, too little SGS dissipation, and resolved eddies that mix too well: in an early
short run on the reduced grid the log law's phi fell to 0.84 at 0.5 m with the geometric mean and not
with the correction. At equilibrium (600 s spin-up, tests/test_solver_loglaw.py) phi still dips to
~0.7 at about 6 Delta whatever the filter width: the dip rides on Delta, see
reports/loglaw/README.md. ``case.closure.delta`` selects the correction.
The buoyancy term of A1 vanishes (neutral scenes).

Length scale near the bed. With l = Delta everywhere the SGS model is far too diffusive-free near a
wall where Delta >> z (the first Delta is 6 cm at z = 5 mm on the reduced grid) and the classic LES
overshoot of the log law results. We limit l by the distance to the bed,

    l = [Delta^-n + (c_l kappa z)^-n]^(-1/n),                    (Mason & Thomson 1992 blending)

with c_l chosen so that a purely-SGS log layer is an equilibrium solution of the closure: in local
equilibrium P = eps gives e = (c_m / c_eps) l^2 S^2 and nu_t = c_m^{3/2} c_eps^{-1/2} l^2 S; requiring
nu_t S = u*^2 with S = u*/(kappa z) gives l = kappa z (c_eps / c_m^3)^{1/4} = 3.7 kappa z for
c_eps -> 0.19 (l << Delta). The constants ``C_L`` and ``BLEND_N`` below record the values used.

Horizontal and vertical viscosities (``case.closure.viscosity``). The paper's eq. A1 carries a
horizontal and a vertical eddy viscosity, nu_th and nu_tv (its model, ARPS, has both for grids
much flatter than wide). "isotropic" (the default) uses one, nu_t = c_m l sqrt(e), for every stress;
"anisotropic" uses nu_h = c_m l_h sqrt(e) for tau_11, tau_12, tau_22 and the horizontal TKE
transport, and nu_v = c_m l_v sqrt(e) for tau_13, tau_23, tau_33 and the vertical transport, with
l_h = sqrt(dx dy) and l_v = dz, each blended with C_L kappa z as l is; the dissipation keeps l and
c_eps. The kernels take the horizontal nu field and the per-level ratio rv = l_v / l_h (all ones
when isotropic); the molecular part of nu is scaled by rv with it, a relative 1e-5 to 1e-3.

The ``*_at`` functions are per-point kernels inlined into the fused stage kernels of stepper.py.
Stress sign convention: T_ij = -tau_ij = 2 nu_t S_ij is the diffusive momentum flux with which
du_i/dt += dT_ij/dx_j; at the bed T_i3 = -tau_s,i with tau_s from wall.py (kinematic, m^2 s^-2).
"""
from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..._jit import device, pjit

#: Lagrangian structure-function constant C0 of the subgrid Lagrangian time T_L (eq. A1), read
#: by the grains' subgrid velocity and TKE sink and by the dynamic closure; not given in the
#: paper.
C0_LAGRANGIAN = 2.1

#: per-point kernels (``device``): inlined by LLVM into the fused stage kernels (an out-of-line call
#: with a dozen array arguments per grid point costs more than the stencil itself)

__all__ = ["C_M", "C_L", "BLEND_N", "E_MIN", "wall_blend", "length_scale", "viscosity_lengths",
           "VISCOSITY_KINDS", "c_eps_profile", "delta_profile", "scotti_factor", "DELTA_KINDS",
           "eddy_viscosity", "diff_u_at", "diff_v_at", "diff_w_at", "tke_tendency_at",
           "diff_u_split_at", "diff_v_split_at", "diff_w_split_at", "tke_split_at",
           "vertical_coupling",
           "strain_sq_at",
           "compute_nu", "sgs_stress_uw_profile"]

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
    """Filter width Delta(z) per level (nz,) [m]: (dx dy dz_c)^{1/3}, times the Scotti factor
    unless ``delta == "geometric"``."""
    if delta not in DELTA_KINDS:
        raise ValueError(f"delta must be one of {DELTA_KINDS} (got {delta!r})")
    d = (grid.dx * grid.dy * grid.dz_c) ** (1.0 / 3.0)
    return d * scotti_factor(grid.dx, grid.dy, grid.dz_c) if delta == "scotti" else d


def wall_blend(length, grid, kappa: float = 0.4, c_l: float = C_L, n: float = BLEND_N) -> np.ndarray:
    """[length^-n + (c_l kappa z)^-n]^(-1/n) at the cell centres (nz,) [m]: a grid length limited
    by the distance to the bed (Mason & Thomson 1992 blending, module doc)."""
    lw = c_l * kappa * grid.z_c
    return (np.asarray(length, dtype=np.float64) ** -n + lw ** -n) ** (-1.0 / n)


def length_scale(grid, kappa: float = 0.4, c_l: float = C_L, n: float = BLEND_N,
                 delta: str = "scotti") -> np.ndarray:
    """Mixing length l(z) at the cell centres (nz,) [m] (see module docstring)."""
    return wall_blend(delta_profile(grid, delta), grid, kappa, c_l, n)


VISCOSITY_KINDS = ("isotropic", "anisotropic")


def viscosity_lengths(grid, kappa: float = 0.4, viscosity: str = "isotropic",
                      delta: str = "scotti") -> tuple[np.ndarray, np.ndarray]:
    """(l_h, l_v) per level (nz,) [m]: the lengths of the horizontal and vertical eddy
    viscosities. "isotropic": both the filter length l (``length_scale``); "anisotropic": the
    horizontal spacing sqrt(dx dy) and the level's dz, each blended with C_L kappa z as l is
    (module doc)."""
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


def eddy_viscosity(e: np.ndarray, l: np.ndarray, nu_mol: float = 0.0) -> np.ndarray:
    """nu_t = c_m l sqrt(e) (+ molecular nu) [m^2 s^-1]."""
    return C_M * l[None, None, :] * np.sqrt(np.maximum(e, 0.0)) + nu_mol


@pjit
def compute_nu(e, cml, nu_mol, nu):
    """nu = c_m l sqrt(e) + nu_mol in place; cml = c_m l per level."""
    nx, ny, nz = e.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                ek = e[i, j, k]
                if ek < 0.0:
                    ek = 0.0
                nu[i, j, k] = cml[k] * math.sqrt(ek) + nu_mol


@device
def diff_u_split_at(u, v, w, nu, rv, taux, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, dzc, dzf):
    """d T_1j / dx_j at the u point split for a vertically implicit scheme: (the part that stays
    explicit [m s^-2], a, c [s^-1]) with d T_1j / dx_j = explicit + c (u_k+1 - u_k) - a (u_k - u_k-1).

    Explicit: T_11, T_12 and the dw/dx part of T_13, and the bed flux T_13 = -taux (wall.py) below
    the first level; a, c: the du/dz part of T_13 on the faces below and above, nu_face / (dz_f dz_c)
    (zero at the bed and under the free-slip lid). ``nu`` is the horizontal viscosity, ``rv[k]`` the
    vertical over the horizontal one per level (module doc)."""
    uc = u[i, j, k]
    t11e = 2.0 * nu[i, j, k] * (u[ip, j, k] - uc) * rdx
    t11w = 2.0 * nu[im, j, k] * (uc - u[im, j, k]) * rdx
    nun = 0.25 * (nu[im, j, k] + nu[i, j, k] + nu[im, jp, k] + nu[i, jp, k])
    t12n = nun * ((u[i, jp, k] - uc) * rdy + (v[i, jp, k] - v[im, jp, k]) * rdx)
    nus = 0.25 * (nu[im, jm, k] + nu[i, jm, k] + nu[im, j, k] + nu[i, j, k])
    t12s = nus * ((uc - u[i, jm, k]) * rdy + (v[i, j, k] - v[im, j, k]) * rdx)
    rdz = 1.0 / dzc[k]
    xt = 0.0
    c = 0.0
    if top:
        nut = 0.25 * ((nu[im, j, k] + nu[i, j, k]) * rv[k]
                      + (nu[im, j, k + 1] + nu[i, j, k + 1]) * rv[k + 1])
        xt = nut * (w[i, j, k + 1] - w[im, j, k + 1]) * rdx
        c = nut / dzf[k + 1] * rdz
    a = 0.0
    if bot:
        nub = 0.25 * ((nu[im, j, k - 1] + nu[i, j, k - 1]) * rv[k - 1]
                      + (nu[im, j, k] + nu[i, j, k]) * rv[k])
        xb = nub * (w[i, j, k] - w[im, j, k]) * rdx
        a = nub / dzf[k] * rdz
    else:
        xb = -taux[i, j]
    return (t11e - t11w) * rdx + (t12n - t12s) * rdy + (xt - xb) * rdz, a, c


@device
def diff_v_split_at(u, v, w, nu, rv, tauy, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, dzc, dzf):
    """d T_2j / dx_j at the v point split as ``diff_u_split_at`` (bed flux T_23 = -tauy)."""
    vc = v[i, j, k]
    nue = 0.25 * (nu[i, jm, k] + nu[ip, jm, k] + nu[i, j, k] + nu[ip, j, k])
    t12e = nue * ((u[ip, j, k] - u[ip, jm, k]) * rdy + (v[ip, j, k] - vc) * rdx)
    nuw = 0.25 * (nu[im, jm, k] + nu[i, jm, k] + nu[im, j, k] + nu[i, j, k])
    t12w = nuw * ((u[i, j, k] - u[i, jm, k]) * rdy + (vc - v[im, j, k]) * rdx)
    t22n = 2.0 * nu[i, j, k] * (v[i, jp, k] - vc) * rdy
    t22s = 2.0 * nu[i, jm, k] * (vc - v[i, jm, k]) * rdy
    rdz = 1.0 / dzc[k]
    xt = 0.0
    c = 0.0
    if top:
        nut = 0.25 * ((nu[i, jm, k] + nu[i, j, k]) * rv[k]
                      + (nu[i, jm, k + 1] + nu[i, j, k + 1]) * rv[k + 1])
        xt = nut * (w[i, j, k + 1] - w[i, jm, k + 1]) * rdy
        c = nut / dzf[k + 1] * rdz
    a = 0.0
    if bot:
        nub = 0.25 * ((nu[i, jm, k - 1] + nu[i, j, k - 1]) * rv[k - 1]
                      + (nu[i, jm, k] + nu[i, j, k]) * rv[k])
        xb = nub * (w[i, j, k] - w[i, jm, k]) * rdy
        a = nub / dzf[k] * rdz
    else:
        xb = -tauy[i, j]
    return (t12e - t12w) * rdx + (t22n - t22s) * rdy + (xt - xb) * rdz, a, c


@device
def vertical_coupling(f, i, j, k, a, c, top, bot):
    """c (f_k+1 - f_k) - a (f_k - f_k-1) on the column (i, j) [units of f s^-1]: the vertical part
    of a split diffusion (``*_split_at``), for the explicit scheme or the explicit share of the
    Crank-Nicolson one."""
    fc = f[i, j, k]
    r = 0.0
    if top:
        r += c * (f[i, j, k + 1] - fc)
    if bot:
        r -= a * (fc - f[i, j, k - 1])
    return r


@device
def diff_u_at(u, v, w, nu, rv, taux, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, dzc, dzf):
    """d T_1j / dx_j at the u point [m s^-2]; bed flux T_13 = -taux (wall.py). ``nu`` is the
    horizontal viscosity, ``rv[k]`` the vertical over the horizontal one per level (module doc)."""
    x, a, c = diff_u_split_at(u, v, w, nu, rv, taux, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy,
                              dzc, dzf)
    return x + vertical_coupling(u, i, j, k, a, c, top, bot)


@device
def diff_v_at(u, v, w, nu, rv, tauy, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, dzc, dzf):
    """d T_2j / dx_j at the v point [m s^-2]; bed flux T_23 = -tauy."""
    x, a, c = diff_v_split_at(u, v, w, nu, rv, tauy, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy,
                              dzc, dzf)
    return x + vertical_coupling(v, i, j, k, a, c, top, bot)


@device
def diff_w_split_at(u, v, w, nu, rv, i, j, k, im, ip, jm, jp, rdx, rdy, dzc, dzf):
    """d T_3j / dx_j at the interior w point (1 <= k <= nz-1) split as ``diff_u_split_at``:
    explicit T_13, T_23 (x and y derivatives), and a, c of T_33 = 2 nu_v dw/dz on the centres below
    and above. Every T_3j is a vertical flux: all carry the vertical viscosity nu rv."""
    wc = w[i, j, k]
    rdzf = 1.0 / dzf[k]
    r0 = 0.25 * rv[k - 1]
    r1 = 0.25 * rv[k]
    nue = r0 * (nu[i, j, k - 1] + nu[ip, j, k - 1]) + r1 * (nu[i, j, k] + nu[ip, j, k])
    t13e = nue * ((u[ip, j, k] - u[ip, j, k - 1]) * rdzf + (w[ip, j, k] - wc) * rdx)
    nuw = r0 * (nu[im, j, k - 1] + nu[i, j, k - 1]) + r1 * (nu[im, j, k] + nu[i, j, k])
    t13w = nuw * ((u[i, j, k] - u[i, j, k - 1]) * rdzf + (wc - w[im, j, k]) * rdx)
    nun = r0 * (nu[i, j, k - 1] + nu[i, jp, k - 1]) + r1 * (nu[i, j, k] + nu[i, jp, k])
    t23n = nun * ((v[i, jp, k] - v[i, jp, k - 1]) * rdzf + (w[i, jp, k] - wc) * rdy)
    nus = r0 * (nu[i, jm, k - 1] + nu[i, j, k - 1]) + r1 * (nu[i, jm, k] + nu[i, j, k])
    t23s = nus * ((v[i, j, k] - v[i, j, k - 1]) * rdzf + (wc - w[i, jm, k]) * rdy)
    c = 2.0 * nu[i, j, k] * rv[k] / dzc[k] * rdzf
    a = 2.0 * nu[i, j, k - 1] * rv[k - 1] / dzc[k - 1] * rdzf
    return (t13e - t13w) * rdx + (t23n - t23s) * rdy, a, c


@device
def diff_w_at(u, v, w, nu, rv, i, j, k, im, ip, jm, jp, rdx, rdy, dzc, dzf):
    """d T_3j / dx_j at the interior w point (1 <= k <= nz-1) [m s^-2] (w = 0 on the bed and the
    lid, faces 0 and nz)."""
    x, a, c = diff_w_split_at(u, v, w, nu, rv, i, j, k, im, ip, jm, jp, rdx, rdy, dzc, dzf)
    return x + vertical_coupling(w, i, j, k, a, c, True, True)


@device
def strain_sq_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc, rdzf, rlog):
    """2 S_ij S_ij at the cell centre (i, j, k) [s^-2], split as (horizontal part, vertical part):
    (2 S_11^2 + 2 S_22^2 + 4 S_12^2, 2 S_33^2 + 4 S_13^2 + 4 S_23^2), the parts that work against
    the horizontal and the vertical viscosity (module doc).

    Diagonal terms at the centre; the squares of the off-diagonal terms averaged over the four
    surrounding edges. On the bed face (bot = False) the vertical shear is the log-law gradient at
    the first level, du/dz = u_1 / (z_1 ln(z_1/z0)) (rlog = 1/(z_1 ln(z_1/z0))), since the resolved
    difference does not exist there; on the lid (top = False, free slip) it is zero. ``rdzc``,
    ``rdzf``: 1/dz_c, 1/dz_f. i, j must be signed integers (the callers cast numba's prange index):
    index arithmetic here is plain, with no modulo in the inner loop (which made the TKE stage 4x
    slower).
    """
    s11 = (u[ip, j, k] - u[i, j, k]) * rdx
    s22 = (v[i, jp, k] - v[i, j, k]) * rdy
    s33 = (w[i, j, k + 1] - w[i, j, k]) * rdzc[k]
    acc = 2.0 * (s11 * s11 + s22 * s22)
    # 2 S_12 on the four vertical edges (x_f[i|ip], y_f[j|jp])
    e00 = (u[i, j, k] - u[i, jm, k]) * rdy + (v[i, j, k] - v[im, j, k]) * rdx
    e10 = (u[ip, j, k] - u[ip, jm, k]) * rdy + (v[ip, j, k] - v[i, j, k]) * rdx
    e01 = (u[i, jp, k] - u[i, j, k]) * rdy + (v[i, jp, k] - v[im, jp, k]) * rdx
    e11 = (u[ip, jp, k] - u[ip, j, k]) * rdy + (v[ip, jp, k] - v[i, jp, k]) * rdx
    acc += 0.25 * (e00 * e00 + e10 * e10 + e01 * e01 + e11 * e11)
    # 2 S_13 on the edges (x_f, z_f) and 2 S_23 on (y_f, z_f), faces k (below) and k+1 (above)
    q = 0.0
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
    q += a0 * a0 + a1 * a1 + b0 * b0 + b1 * b1
    if top:
        kt = k + 1
        rdz = rdzf[kt]
        a0 = (u[i, j, kt] - u[i, j, k]) * rdz + (w[i, j, kt] - w[im, j, kt]) * rdx
        a1 = (u[ip, j, kt] - u[ip, j, k]) * rdz + (w[ip, j, kt] - w[i, j, kt]) * rdx
        b0 = (v[i, j, kt] - v[i, j, k]) * rdz + (w[i, j, kt] - w[i, jm, kt]) * rdy
        b1 = (v[i, jp, kt] - v[i, jp, k]) * rdz + (w[i, jp, kt] - w[i, j, kt]) * rdy
        q += a0 * a0 + a1 * a1 + b0 * b0 + b1 * b1
    return acc, 2.0 * s33 * s33 + 0.25 * q


@device
def tke_split_at(e, u, v, w, nu, rv, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc, rdzf,
                 rlog, ceps_over_l_k):
    """de/dt at the centre without advection (eq. A1) split for a vertically implicit scheme:
    (P + horizontal transport [m^2 s^-3], a, c [s^-1] of the vertical transport, r [s^-1] of the
    dissipation) with de/dt = P + transport_h + c (e_k+1 - e_k) - a (e_k - e_k-1) - r e_k and
    r = c_eps e^{1/2} / l, so that r e = eps = c_eps e^{3/2} / l.

    Horizontal fluxes with nu, vertical ones with nu rv (as in A1's nu_th, nu_tv); the transport
    is 2 nu_t grad e with the face viscosities as two-point means."""
    ec = e[i, j, k]
    nuc = nu[i, j, k]
    sh, sv = strain_sq_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc, rdzf, rlog)
    nvc = nuc * rv[k]
    prod = nuc * sh + nvc * sv
    fe = (nuc + nu[ip, j, k]) * (e[ip, j, k] - ec) * rdx
    fw = (nu[im, j, k] + nuc) * (ec - e[im, j, k]) * rdx
    fn = (nuc + nu[i, jp, k]) * (e[i, jp, k] - ec) * rdy
    fs = (nu[i, jm, k] + nuc) * (ec - e[i, jm, k]) * rdy
    c = 0.0
    a = 0.0
    if top:
        c = (nvc + nu[i, j, k + 1] * rv[k + 1]) * rdzf[k + 1] * rdzc[k]
    if bot:
        a = (nu[i, j, k - 1] * rv[k - 1] + nvc) * rdzf[k] * rdzc[k]
    ep = ec if ec > 0.0 else 0.0
    return prod + (fe - fw) * rdx + (fn - fs) * rdy, a, c, ceps_over_l_k * math.sqrt(ep)


@device
def tke_tendency_at(e, u, v, w, nu, rv, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc, rdzf,
                    rlog, ceps_over_l_k):
    """de/dt at the centre without advection: P + transport - eps [m^2 s^-3] (eq. A1, all
    explicit; ``tke_split_at``)."""
    x, a, c, r = tke_split_at(e, u, v, w, nu, rv, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc,
                              rdzf, rlog, ceps_over_l_k)
    ec = e[i, j, k]
    ep = ec if ec > 0.0 else 0.0
    return x + vertical_coupling(e, i, j, k, a, c, top, bot) - r * ep


@pjit
def sgs_stress_uw_profile(u, w, nu, rv, taux, dzf, rdx):
    """Horizontal means of the SGS flux tau_13 on the faces z_w (nz+1,) [m^2 s^-2] (bed: taux);
    nu the horizontal viscosity, rv the vertical/horizontal ratio per level."""
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
