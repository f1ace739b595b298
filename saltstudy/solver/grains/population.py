"""The grain population between steps: release from the bed, the dead removed (compaction), the
parcels reordered by cell, the SGS velocity's update, aerodynamic entrainment, and the wind read
at the parcels.
"""
from __future__ import annotations

import math
from numba import prange

from ..._jit import jit, jit_borrow, pjit
from .interp import interp_fluid, level_of, locate, wrap_index
from .splash_kernels import draw_diameter


@jit_borrow
def _collect_events(n, flag, ev):
    """ev[:m] = indices of the parcels with flag 1, in increasing order; returns m."""
    m = 0
    for p in range(n):
        if flag[p] == 1:
            ev[m] = p
            m += 1
    return m


@jit_borrow
def _compact(dead, n_dead, n, x, y, z, u, v, w, d, kd, flag, trem, su, sv, sw, tl, xl, yl):
    """Swap-remove the dead parcels; ``dead`` sorted in decreasing order. Returns the new count."""
    has_sgs = su.shape[0] > 0
    for i in range(n_dead):
        q = dead[i]
        last = n - 1
        if q != last:
            x[q] = x[last]
            y[q] = y[last]
            z[q] = z[last]
            u[q] = u[last]
            v[q] = v[last]
            w[q] = w[last]
            d[q] = d[last]
            kd[q] = kd[last]
            flag[q] = flag[last]
            trem[q] = trem[last]
            tl[q] = tl[last]
            xl[q] = xl[last]
            yl[q] = yl[last]
            if has_sgs:
                su[q] = su[last]
                sv[q] = sv[last]
                sw[q] = sw[last]
        n -= 1
    return n


@jit_borrow
def _cell_order(n, x, y, z, geo, z_f, lut, nx, ny, nz, key, perm, count):
    """Stable counting sort of parcels by cell (x-slab, then y, then level): perm[new] = old.
    Serial and deterministic. Keeps the grid gathers/scatters of neighbouring parcels in cache."""
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
def _gather(n, perm, a, out):
    """out[q] = a[perm[q]] for q < n (the parcels reordered, one field)."""
    for q in prange(n):
        out[q] = a[perm[q]]


@jit
def _release(rng, n0, n_new, x, y, z, u, v, w, d, kd, flag, trem, Lx, Ly, z_lo, z_hi, cum, mu, lnsig):
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
def _sgs_update(rng, n, dt, x, y, z, su, sv, sw, ef, tlc, geo, z_f, lut, nx, ny, nz):
    """Ornstein-Uhlenbeck SGS velocity per parcel (serial: random draws). See module doc."""
    for p in range(n):
        i = wrap_index(int(x[p] / geo[0]), nx)
        j = wrap_index(int(y[p] / geo[1]), ny)
        k = level_of(z[p], z_f, lut, geo[5], nz)
        e = ef[i, j, k]
        if e <= 0.0:
            su[p] = 0.0
            sv[p] = 0.0
            sw[p] = 0.0
            continue
        tl = tlc[k] / math.sqrt(e)
        R = math.exp(-dt / tl)
        s = math.sqrt(max(0.0, 1.0 - R * R)) * math.sqrt(2.0 * e / 3.0)
        su[p] = R * su[p] + s * rng.normal(0.0, 1.0)
        sv[p] = R * sv[p] + s * rng.normal(0.0, 1.0)
        sw[p] = R * sw[p] + s * rng.normal(0.0, 1.0)


@jit
def _entrain(rng, n, dt, uf, vf, geo, z_c, prm_e, x, y, z, u, v, w, d, kd, flag, trem, cum, mu,
             lnsig):
    """Aerodynamic entrainment (module doc). prm_e: [rho, kappa, z0, tau_t, zeta, Q, h_imp].
    Returns the new parcel count, or -1 - (first cell not done) if capacity ran out (no draws
    are made for that cell)."""
    nx = uf.shape[0]
    ny = uf.shape[1]
    rho = prm_e[0]
    kappa = prm_e[1]
    z0 = prm_e[2]
    tau_t = prm_e[3]
    zeta = prm_e[4]
    Q = prm_e[5]
    h_imp = prm_e[6]
    dx = geo[0]
    dy = geo[1]
    lnz = math.log(z_c[0] / z0)
    cap = x.shape[0]
    for i in range(nx):
        ip = (i + 1) % nx
        for j in range(ny):
            jp = (j + 1) % ny
            uc = 0.5 * (uf[i, j, 0] + uf[ip, j, 0])
            vc = 0.5 * (vf[i, j, 0] + vf[i, jp, 0])
            ustar = kappa * math.sqrt(uc * uc + vc * vc) / lnz
            tau = rho * ustar * ustar
            if tau <= tau_t:
                continue
            mean = zeta * (tau - tau_t) * dx * dy * dt / Q
            nn = int(math.floor(mean))
            if n + nn + 1 > cap:
                return -1
            if rng.random() < mean - nn:
                nn += 1
            for _ in range(nn):
                x[n] = (i + rng.random()) * dx
                y[n] = (j + rng.random()) * dy
                z[n] = h_imp
                u[n] = 0.0
                v[n] = 0.0
                w[n] = ustar
                d[n] = draw_diameter(rng, cum, mu, lnsig)
                kd[n] = 0.0
                flag[n] = 0
                trem[n] = 0.0
                n += 1
    return n


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
def _fluid_at(n, x, y, z, uf, vf, wf, G, out):
    nb = 64
    for b in prange(nb):
        _fluid_at_range((b * n) // nb, ((b + 1) * n) // nb, x, y, z, uf, vf, wf, G, out)
