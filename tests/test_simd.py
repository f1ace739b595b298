"""The short-vector intrinsics (solver/numerics/simd.py) and the deposit / interpolation helpers built on
them (interp.pool_add_tri, pool_add_tri2, _tri) against plain references."""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from saltstudy._jit import jit
from saltstudy.solver.grains.interp import _tri, pool_add_tri, pool_add_tri2
from saltstudy.solver.numerics.simd import fma2, fma4, load2


@jit
def _fma2_at(a, i, w0, w1, v):
    fma2(a, i, w0, w1, v)


@jit
def _fma4_at(a, i, w0, w1, va, vb):
    fma4(a, i, w0, w1, va, vb)


@jit
def _load2_at(f, i, j, k):
    return load2(f, i, j, k)


def _fused(w, v, old):
    """w v + old rounded once (what a fused multiply-add returns)."""
    return float(Fraction(w) * Fraction(v) + Fraction(old))


def test_vector_fused_multiply_adds_round_once_per_element_and_touch_nothing_else():
    rng = np.random.default_rng(5)
    for _ in range(200):
        a = rng.normal(size=12)
        before = a.copy()
        i = int(rng.integers(0, 8))
        w0, w1, va, vb = rng.normal(size=4) * 10.0 ** rng.uniform(-8, 8, 4)
        _fma4_at(a, i, w0, w1, va, vb)
        want = before.copy()
        want[i:i + 4] = [_fused(w0, va, before[i]), _fused(w0, vb, before[i + 1]),
                         _fused(w1, va, before[i + 2]), _fused(w1, vb, before[i + 3])]
        np.testing.assert_array_equal(a, want)
        j = int(rng.integers(0, 10))
        before = a.copy()
        _fma2_at(a, j, w0, w1, va)
        want = before.copy()
        want[j:j + 2] = [_fused(w0, va, before[j]), _fused(w1, va, before[j + 1])]
        np.testing.assert_array_equal(a, want)


def test_load2_reads_a_columns_two_levels():
    f = np.random.default_rng(2).normal(size=(5, 4, 6))
    for i, j, k in [(0, 0, 0), (4, 3, 4), (2, 1, 3)]:
        assert _load2_at(f, i, j, k) == (f[i, j, k], f[i, j, k + 1])


@jit
def _tri_at(f, i0, fx, j0, fy, k0, fz):
    return _tri(f, i0, fx, j0, fy, k0, fz, f.shape[0], f.shape[1])


def test_trilinear_value_is_the_weighted_sum_of_its_corners_with_periodic_wrap():
    rng = np.random.default_rng(8)
    f = rng.normal(size=(6, 5, 7))
    for i0, j0, k0 in [(0, 0, 0), (5, 4, 5), (3, 2, 1)]:  # (5, 4): both wrap to 0
        fx, fy, fz = rng.uniform(size=3)
        i1, j1 = (i0 + 1) % 6, (j0 + 1) % 5
        want = sum(wx * wy * wz * f[i, j, k]
                   for i, wx in ((i0, 1 - fx), (i1, fx)) for j, wy in ((j0, 1 - fy), (j1, fy))
                   for k, wz in ((k0, 1 - fz), (k0 + 1, fz)))
        assert _tri_at(f, i0, fx, j0, fy, k0, fz) == pytest.approx(want, rel=1e-14, abs=1e-15)


@jit
def _add_tri_at(pool, base, s, nx, ny, nk, val, i0, fx, j0, fy, k0, fz):
    pool_add_tri(pool, base, s, nx, ny, nk, val, i0, fx, j0, fy, k0, fz)


@jit
def _add_tri2_at(pool, base, s, nx, ny, nk, va, vb, i0, fx, j0, fy, k0, fz):
    pool_add_tri2(pool, base, s, nx, ny, nk, va, vb, i0, fx, j0, fy, k0, fz)


def _stencil(nx, ny, nk, s, i0, fx, j0, fy, k0, fz):
    """(slab-local i, j, k, weight) of a deposit; levels >= nk fold onto nk - 1."""
    out = []
    for i, wx in ((i0, 1 - fx), ((i0 + 1) % nx, fx)):
        for j, wy in ((j0, 1 - fy), ((j0 + 1) % ny, fy)):
            for k, wz in ((k0, 1 - fz), (k0 + 1, fz)):
                out.append(((i - s) % nx, j, min(k, nk - 1), wx * wy * wz))
    return out


@pytest.mark.parametrize("k0", [0, 2, 3, 5])  # 3: the upper level folds; 5: both do (nk = 4)
def test_pool_deposits_put_the_trilinear_weights_on_the_slab_local_buffers(k0):
    nx, ny, nk, L, s, base = 8, 5, 4, 3, 7, 6  # slabs 7, 0, 1 (the range wraps)
    rng = np.random.default_rng(k0)
    for i0, j0 in [(7, 4), (0, 2)]:
        fx, fy, fz = rng.uniform(size=3)
        val, va, vb = rng.normal(size=3)
        pool = np.zeros(base + L * ny * nk + 3)
        _add_tri_at(pool, base, s, nx, ny, nk, val, i0, fx, j0, fy, k0, fz)
        want = np.zeros_like(pool)
        for i, j, k, w in _stencil(nx, ny, nk, s, i0, fx, j0, fy, k0, fz):
            want[base + (i * ny + j) * nk + k] += w * val
        np.testing.assert_allclose(pool, want, rtol=1e-14, atol=1e-16)
        assert pool.sum() == pytest.approx(val, rel=1e-14)
        pool2 = np.zeros(base + 2 * L * ny * nk + 3)
        _add_tri2_at(pool2, base, s, nx, ny, nk, va, vb, i0, fx, j0, fy, k0, fz)
        want2 = np.zeros_like(pool2)
        for i, j, k, w in _stencil(nx, ny, nk, s, i0, fx, j0, fy, k0, fz):
            q = base + 2 * ((i * ny + j) * nk + k)
            want2[q] += w * va
            want2[q + 1] += w * vb
        np.testing.assert_allclose(pool2, want2, rtol=1e-14, atol=1e-16)
