"""A periodic velocity field with a k^-5/3 inertial range and the energy transfer of real
turbulence, for a-priori tests of SGS closures (not a test module).

A Gaussian random field with a Kolmogorov spectrum has the right spectrum but no energy cascade:
its velocity-gradient skewness is zero, and so is the mean transfer <L_ij S^_ij> that a dynamic
procedure measures (its plane mean of L_ij M_ij comes out <= 0). Here such a field is evolved for
about half a large-eddy turnover by the Navier-Stokes equations (pseudo-spectral, 2/3 dealiased,
the Chollet & Lesieur 1981 spectral eddy viscosity at the truncation, SSP-RK3): the small scales
reach the cascade's quasi-equilibrium (derivative skewness ~ -0.4, measured) while the spectrum
keeps its k^-5/3 shape. Then it is truncated to the test's grid and sampled on the staggered
(Arakawa-C) points of the LES.
"""
from __future__ import annotations

import numpy as np

KOLMOGOROV_C = 1.6        #: Kolmogorov constant of the spectrum E(k) = C eps^(2/3) k^(-5/3)


def _wavenumbers(n: int):
    k = np.fft.fftfreq(n, 1.0 / n)
    kr = np.fft.rfftfreq(n, 1.0 / n)
    return np.meshgrid(k, k, kr, indexing="ij")


def _project(uh, kv, k2):
    with np.errstate(invalid="ignore", divide="ignore"):
        dv = (kv[0] * uh[0] + kv[1] * uh[1] + kv[2] * uh[2]) / np.where(k2 > 0, k2, 1.0)
    return np.stack([uh[i] - kv[i] * dv for i in range(3)])


def _spectrum(uh, kmag, n):
    e = 0.5 * np.sum(np.abs(uh) ** 2, axis=0)
    e[..., 1:-1] *= 2.0
    return np.bincount(np.rint(kmag).astype(int).ravel(), (e / n ** 6).ravel())


def evolved_field(n: int = 64, turnovers: float = 0.5, seed: int = 3):
    """Fourier coefficients (3, n, n, n//2+1) of a 2 pi-periodic field with u_rms ~ 1 (module doc),
    and the velocity-gradient skewness <(du/dx)^3>/<(du/dx)^2>^1.5 at the end."""
    rng = np.random.default_rng(seed)
    kx, ky, kz = kv = _wavenumbers(n)
    k2 = kx ** 2 + ky ** 2 + kz ** 2
    kmag = np.sqrt(k2)
    kd = n // 3
    keep = (np.abs(kx) <= kd) & (np.abs(ky) <= kd) & (kz <= kd)
    amp = np.where((kmag >= 0.5) & keep, np.maximum(kmag, 1.0) ** (-11.0 / 6.0), 0.0)
    uh = _project(np.fft.rfftn(rng.normal(size=(3, n, n, n)), axes=(1, 2, 3)) * amp, kv, k2)
    uh *= np.sqrt(1.5 / _spectrum(uh, kmag, n).sum())

    def rhs(a):
        u = np.fft.irfftn(a, s=(n, n, n), axes=(1, 2, 3))
        wh = np.stack([1j * (ky * a[2] - kz * a[1]), 1j * (kz * a[0] - kx * a[2]),
                       1j * (kx * a[1] - ky * a[0])])
        w = np.fft.irfftn(wh, s=(n, n, n), axes=(1, 2, 3))
        c = np.stack([u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]])
        e_kd = _spectrum(a, kmag, n)[kd]
        nu = (0.441 * KOLMOGOROV_C ** -1.5 * (1.0 + 34.5 * np.exp(-3.03 * kd / np.maximum(kmag, 1e-9)))
              * np.sqrt(e_kd / kd))
        return _project(np.fft.rfftn(c, axes=(1, 2, 3)) * keep, kv, k2) - nu * k2 * a

    t, t_end, umax = 0.0, turnovers * 2.0 * np.pi / 2.0, 4.5   # turnover ~ L/u_rms, L ~ pi
    while t < t_end:
        dt = min(0.8 / (kd * umax), t_end - t)
        u1 = uh + dt * rhs(uh)
        u2 = 0.75 * uh + 0.25 * (u1 + dt * rhs(u1))
        uh = uh / 3.0 + 2.0 / 3.0 * (u2 + dt * rhs(u2))
        t += dt
        umax = np.abs(np.fft.irfftn(uh, s=(n, n, n), axes=(1, 2, 3))).max()
    dudx = np.fft.irfftn(1j * kx * uh[0], s=(n, n, n), axes=(0, 1, 2))
    return uh, float(np.mean(dudx ** 3) / np.mean(dudx ** 2) ** 1.5)


def staggered_sample(uh, m: int):
    """(u, v, w) of the field truncated to |k_i| < m/2 and sampled on an m^3 Arakawa-C grid of
    spacing 2 pi/m: u at (x_f, y_c, z_c), v at (x_c, y_f, z_c), w at (x_c, y_c, z_f) with
    x_f = i dx, x_c = (i + 1/2) dx; shapes (m, m, m), (m, m, m), (m, m, m+1) (w periodic in z)."""
    n = uh.shape[1]
    idx = np.r_[0:m // 2, n - m // 2:n]
    sub = uh[:, idx][:, :, idx][:, :, :, :m // 2 + 1].copy()
    sub[:, m // 2] = 0.0
    sub[:, :, m // 2] = 0.0
    sub[:, :, :, m // 2] = 0.0
    k = np.fft.fftfreq(m, 1.0 / m)
    kr = np.fft.rfftfreq(m, 1.0 / m)
    kx, ky, kz = np.meshgrid(k, k, kr, indexing="ij")
    h = np.pi / m                                  # half a cell: dx/2 for dx = 2 pi/m
    scale = (m / n) ** 3
    out = []
    for comp, (sx, sy, sz) in enumerate(((0.0, h, h), (h, 0.0, h), (h, h, 0.0))):
        shift = np.exp(1j * (kx * sx + ky * sy + kz * sz))
        out.append(np.fft.irfftn(sub[comp] * shift, s=(m, m, m), axes=(0, 1, 2)) * scale)
    u, v, w = out
    return u, v, np.concatenate([w, w[:, :, :1]], axis=2)
