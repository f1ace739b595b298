"""Energy-conserving centred advection on the staggered grid stretched in z: second order, or
fourth order in x and y.

Flux form on each control volume (Harlow & Welch 1965; Morinishi et al. 1998, J. Comput. Phys.
143, 90; Verstappen & Veldman 2003 for non-uniform grids): the advecting volume flux through a
face is the mean of the two neighbouring mass-conserving fluxes, the advected quantity the
arithmetic mean of its two neighbours (even in z). The operator is then skew-symmetric, so with
a zero discrete divergence advection conserves the kinetic energy to round-off and adds no
numerical dissipation. A w volume (interior face k, dx dy dz_f[k]) takes the thickness-weighted
sums of the two u (v) half faces as its side fluxes.

Fourth order in x and y (``*4_at``): Morinishi et al.'s fully conservative scheme (the paper's
ARPS advects momentum at fourth order in the horizontal). In x_j = x or y, delta_n the difference
over n h, f^{n x_j} the two-point mean at +-n h/2:

    -A_i = 9/8 delta_1(F_j u_i^{1 x_j}) - 1/8 delta_3(F_j u_i^{3 x_j}) + delta_z(F_z u_i^z) / dz,
    F_j = 9/8 u_j^{1 x_i} - 1/8 u_j^{3 x_i}   (x_i horizontal; for w the z mean of second order).

It conserves kinetic energy when the fourth-order divergence vanishes, as the fourth-order
projection makes it (pressure.py); with the second-order one the energy rate is 2.5e-4 of
sum|V u_i A_i| in a random solenoidal field (tests/test_solver_advection4.py). Its scalar form
(the SGS TKE) then conserves sum(V e^2) and keeps a uniform e uniform.

The ``*_at`` functions are per-point kernels inlined into the stage kernels (stepper.py); units
m s^-2 (momentum), m^2 s^-3 (SGS TKE).
"""
from __future__ import annotations

from ..._jit import device, like


#: the horizontal orders of the advection (config.TimeStepping.advection_order)
ADVECTION_ORDERS = (2, 4)

#: Morinishi et al.'s weights: 9/8 on the narrow difference (or interpolation), 1/8 on the wide
#: one; C3 = 1/8 * 1/3 folds the wide difference's 1/(3 h) in
C1 = 9.0 / 8.0
C3 = 1.0 / 24.0


@device
def adv_u_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc_k):
    """-div(u u) at the u point (i, j, k) [m s^-2]. top/bot: whether the cell has an interior face
    above/below (False at the lid/bed, where w = 0); literal in the peeled levels of the callers."""
    half = like(u, 0.5)
    zero = like(u, 0.0)
    uc = u[i, j, k]
    ue = half * (uc + u[ip, j, k])
    uw = half * (u[im, j, k] + uc)
    vn = half * (v[im, jp, k] + v[i, jp, k])
    vs = half * (v[im, j, k] + v[i, j, k])
    un = half * (uc + u[i, jp, k])
    us = half * (u[i, jm, k] + uc)
    ft = zero
    fb = zero
    if top:
        ft = half * (w[im, j, k + 1] + w[i, j, k + 1]) * half * (uc + u[i, j, k + 1])
    if bot:
        fb = half * (w[im, j, k] + w[i, j, k]) * half * (u[i, j, k - 1] + uc)
    return -((ue * ue - uw * uw) * rdx + (vn * un - vs * us) * rdy + (ft - fb) * rdzc_k)


@device
def adv_v_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc_k):
    """-div(u v) at the v point (i, j, k) [m s^-2]."""
    half = like(v, 0.5)
    zero = like(v, 0.0)
    vc = v[i, j, k]
    ue = half * (u[ip, jm, k] + u[ip, j, k])
    uw = half * (u[i, jm, k] + u[i, j, k])
    ve = half * (vc + v[ip, j, k])
    vw = half * (v[im, j, k] + vc)
    vn = half * (vc + v[i, jp, k])
    vs = half * (v[i, jm, k] + vc)
    ft = zero
    fb = zero
    if top:
        ft = half * (w[i, jm, k + 1] + w[i, j, k + 1]) * half * (vc + v[i, j, k + 1])
    if bot:
        fb = half * (w[i, jm, k] + w[i, j, k]) * half * (v[i, j, k - 1] + vc)
    return -((ue * ve - uw * vw) * rdx + (vn * vn - vs * vs) * rdy + (ft - fb) * rdzc_k)


@device
def adv_w_at(u, v, w, i, j, k, im, ip, jm, jp, rdx, rdy, hzm, hzp, rdzf_k):
    """-div(u w) at the interior w point [m s^-2]; hzm, hzp = dz_c[k-1], dz_c[k] over 2 dz_f[k]."""
    half = like(w, 0.5)
    wc = w[i, j, k]
    ue = hzm * u[ip, j, k - 1] + hzp * u[ip, j, k]
    uw = hzm * u[i, j, k - 1] + hzp * u[i, j, k]
    vn = hzm * v[i, jp, k - 1] + hzp * v[i, jp, k]
    vs = hzm * v[i, j, k - 1] + hzp * v[i, j, k]
    we = half * (wc + w[ip, j, k])
    ww = half * (w[im, j, k] + wc)
    wn = half * (wc + w[i, jp, k])
    ws = half * (w[i, jm, k] + wc)
    wt = half * (wc + w[i, j, k + 1])
    wb = half * (w[i, j, k - 1] + wc)
    return -((ue * we - uw * ww) * rdx + (vn * wn - vs * ws) * rdy + (wt * wt - wb * wb) * rdzf_k)


@device
def adv_scalar_at(s, u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc_k):
    """-div(u s) for a cell-centred scalar (the SGS TKE e) [units of s per s]."""
    half = like(s, 0.5)
    zero = like(s, 0.0)
    sc = s[i, j, k]
    fe = u[ip, j, k] * half * (sc + s[ip, j, k])
    fw = u[i, j, k] * half * (s[im, j, k] + sc)
    fn = v[i, jp, k] * half * (sc + s[i, jp, k])
    fs = v[i, j, k] * half * (s[i, jm, k] + sc)
    ft = zero
    fb = zero
    if top:
        ft = w[i, j, k + 1] * half * (sc + s[i, j, k + 1])
    if bot:
        fb = w[i, j, k] * half * (s[i, j, k - 1] + sc)
    return -((fe - fw) * rdx + (fn - fs) * rdy + (ft - fb) * rdzc_k)


@device
def wrap_down(im, n):
    """(im - 1) mod n for 0 <= im < n, without an integer division in the inner loops."""
    return im - 1 if im > 0 else n - 1


@device
def wrap_up(ip, n):
    """(ip + 1) mod n for 0 <= ip < n."""
    return ip + 1 if ip + 1 < n else 0


@device
def _outer(im, ip, n):
    """(im2, im3, ip2, ip3): the second and third neighbours of a point whose first are im, ip."""
    im2 = wrap_down(im, n)
    ip2 = wrap_up(ip, n)
    return im2, wrap_down(im2, n), ip2, wrap_up(ip2, n)


@device
def _mid4(a, b, c, d):
    """Fourth-order midpoint of b and c: 9/8 (b + c)/2 - 1/8 (a + d)/2."""
    half = like(a, 0.5)
    eighth = like(a, 0.125)
    c1 = like(a, C1)
    return half * (c1 * (b + c) - eighth * (a + d))


@device
def _div4(fm3, fm1, fp1, fp3, qm3, qm1, qc, qp1, qp3):
    """(9/8 delta_1(F q^1) - 1/8 delta_3(F q^3)) h: F at +-h/2, +-3h/2, q at 0, +-h, +-3h."""
    half = like(fm3, 0.5)
    c1 = like(fm3, C1)
    c3 = like(fm3, C3)
    return (c1 * (fp1 * (qc + qp1) - fm1 * (qm1 + qc))
            - c3 * (fp3 * (qc + qp3) - fm3 * (qm3 + qc))) * half


@device
def adv_u4_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc_k):
    """-div(u u) at the u point [m s^-2], fourth order in x and y; finds the further neighbours
    itself (the stage kernels' calls are at numba's 30-argument limit for inlining)."""
    half = like(u, 0.5)
    zero = like(u, 0.0)
    im2, im3, ip2, ip3 = _outer(im, ip, u.shape[0])
    jm2, jm3, jp2, jp3 = _outer(jm, jp, u.shape[1])
    uc = u[i, j, k]
    # x: u advects u; centres i-2, i-1, i, i+1 lie at -3/2, -1/2, +1/2, +3/2 dx
    um3 = u[im3, j, k]
    um2 = u[im2, j, k]
    um1 = u[im, j, k]
    up1 = u[ip, j, k]
    up2 = u[ip2, j, k]
    up3 = u[ip3, j, k]
    ax = _div4(_mid4(um3, um2, um1, uc), _mid4(um2, um1, uc, up1), _mid4(um1, uc, up1, up2),
               _mid4(uc, up1, up2, up3), um3, um1, uc, up1, up3)
    # y: v at the faces y_f[j-1], y_f[j], y_f[j+1], y_f[j+2] interpolated to x_f[i]
    ay = _div4(_mid4(v[im2, jm, k], v[im, jm, k], v[i, jm, k], v[ip, jm, k]),
               _mid4(v[im2, j, k], v[im, j, k], v[i, j, k], v[ip, j, k]),
               _mid4(v[im2, jp, k], v[im, jp, k], v[i, jp, k], v[ip, jp, k]),
               _mid4(v[im2, jp2, k], v[im, jp2, k], v[i, jp2, k], v[ip, jp2, k]),
               u[i, jm3, k], u[i, jm, k], uc, u[i, jp, k], u[i, jp3, k])
    ft = zero
    fb = zero
    if top:
        ft = _mid4(w[im2, j, k + 1], w[im, j, k + 1], w[i, j, k + 1], w[ip, j, k + 1]) * half * (
            uc + u[i, j, k + 1])
    if bot:
        fb = _mid4(w[im2, j, k], w[im, j, k], w[i, j, k], w[ip, j, k]) * half * (u[i, j, k - 1] + uc)
    return -(ax * rdx + ay * rdy + (ft - fb) * rdzc_k)


@device
def adv_v4_at(u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc_k):
    """-div(u v) at the v point [m s^-2], fourth order in x and y (as adv_u4_at)."""
    half = like(v, 0.5)
    zero = like(v, 0.0)
    im2, im3, ip2, ip3 = _outer(im, ip, v.shape[0])
    jm2, jm3, jp2, jp3 = _outer(jm, jp, v.shape[1])
    vc = v[i, j, k]
    # x: u at the faces x_f[i-1], x_f[i], x_f[i+1], x_f[i+2] interpolated to y_f[j]
    ax = _div4(_mid4(u[im, jm2, k], u[im, jm, k], u[im, j, k], u[im, jp, k]),
               _mid4(u[i, jm2, k], u[i, jm, k], u[i, j, k], u[i, jp, k]),
               _mid4(u[ip, jm2, k], u[ip, jm, k], u[ip, j, k], u[ip, jp, k]),
               _mid4(u[ip2, jm2, k], u[ip2, jm, k], u[ip2, j, k], u[ip2, jp, k]),
               v[im3, j, k], v[im, j, k], vc, v[ip, j, k], v[ip3, j, k])
    # y: v advects v; centres j-2, j-1, j, j+1 lie at -3/2, -1/2, +1/2, +3/2 dy
    vm3 = v[i, jm3, k]
    vm2 = v[i, jm2, k]
    vm1 = v[i, jm, k]
    vp1 = v[i, jp, k]
    vp2 = v[i, jp2, k]
    vp3 = v[i, jp3, k]
    ay = _div4(_mid4(vm3, vm2, vm1, vc), _mid4(vm2, vm1, vc, vp1), _mid4(vm1, vc, vp1, vp2),
               _mid4(vc, vp1, vp2, vp3), vm3, vm1, vc, vp1, vp3)
    ft = zero
    fb = zero
    if top:
        ft = _mid4(w[i, jm2, k + 1], w[i, jm, k + 1], w[i, j, k + 1], w[i, jp, k + 1]) * half * (
            vc + v[i, j, k + 1])
    if bot:
        fb = _mid4(w[i, jm2, k], w[i, jm, k], w[i, j, k], w[i, jp, k]) * half * (v[i, j, k - 1] + vc)
    return -(ax * rdx + ay * rdy + (ft - fb) * rdzc_k)


@device
def adv_w4_at(u, v, w, i, j, k, im, ip, jm, jp, rdx, rdy, hzm, hzp, rdzf_k):
    """-div(u w) at the interior w point [m s^-2], fourth order in x and y."""
    half = like(w, 0.5)
    im2, im3, ip2, ip3 = _outer(im, ip, w.shape[0])
    jm2, jm3, jp2, jp3 = _outer(jm, jp, w.shape[1])
    wc = w[i, j, k]
    ax = _div4(hzm * u[im, j, k - 1] + hzp * u[im, j, k],
               hzm * u[i, j, k - 1] + hzp * u[i, j, k],
               hzm * u[ip, j, k - 1] + hzp * u[ip, j, k],
               hzm * u[ip2, j, k - 1] + hzp * u[ip2, j, k],
               w[im3, j, k], w[im, j, k], wc, w[ip, j, k], w[ip3, j, k])
    ay = _div4(hzm * v[i, jm, k - 1] + hzp * v[i, jm, k],
               hzm * v[i, j, k - 1] + hzp * v[i, j, k],
               hzm * v[i, jp, k - 1] + hzp * v[i, jp, k],
               hzm * v[i, jp2, k - 1] + hzp * v[i, jp2, k],
               w[i, jm3, k], w[i, jm, k], wc, w[i, jp, k], w[i, jp3, k])
    wt = half * (wc + w[i, j, k + 1])
    wb = half * (w[i, j, k - 1] + wc)
    return -(ax * rdx + ay * rdy + (wt * wt - wb * wb) * rdzf_k)


@device
def adv_scalar4_at(s, u, v, w, i, j, k, im, ip, jm, jp, top, bot, rdx, rdy, rdzc_k):
    """-div(u s) for a cell-centred scalar, fourth order in x and y; z as adv_scalar_at."""
    half = like(s, 0.5)
    zero = like(s, 0.0)
    _, im3, ip2, ip3 = _outer(im, ip, s.shape[0])
    _, jm3, jp2, jp3 = _outer(jm, jp, s.shape[1])
    sc = s[i, j, k]
    ax = _div4(u[im, j, k], u[i, j, k], u[ip, j, k], u[ip2, j, k],
               s[im3, j, k], s[im, j, k], sc, s[ip, j, k], s[ip3, j, k])
    ay = _div4(v[i, jm, k], v[i, j, k], v[i, jp, k], v[i, jp2, k],
               s[i, jm3, k], s[i, jm, k], sc, s[i, jp, k], s[i, jp3, k])
    ft = zero
    fb = zero
    if top:
        ft = w[i, j, k + 1] * half * (sc + s[i, j, k + 1])
    if bot:
        fb = w[i, j, k] * half * (s[i, j, k - 1] + sc)
    return -(ax * rdx + ay * rdy + (ft - fb) * rdzc_k)
