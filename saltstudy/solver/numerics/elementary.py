"""Inlined elementary functions for the parcel kernels: Re^0.687, expm1 and log without libm calls.

As libm calls, a parcel-step's Re_p^0.687 (eq. 4) and expm1(-k T) were 14 % of the grain step
(``perf record -e cpu-clock``, bench, 10^6 parcels), plus the spills (a call clobbers every
vector register). Here, with x = 2^e m and c_j the centre of m's 1/256-wide bin:

* ``pow_0687``: 2^(0.687 e) c_j^0.687 (1 + t)^0.687, t = m / c_j - 1: two tables and a five-term
  binomial series; within 3 ulp of ``x ** 0.687`` (tested), which takes the x beyond the tables.
* ``expm1_small``: Taylor to degree 14 for |x| <= 0.35 (truncation < 2e-17 relative), libm beyond
  (the drag update's k T is 0.01-0.2; the 20 um soils go to libm).
* ``log_small`` (x >= 1: the first cell's log law): e ln 2 + ln(c_j) + log1p(t) (ln 2 in two
  parts), seven- or, below 1 + 2^-8, nine-term series; within 2 ulp (tested).

The tables are module-level arrays, frozen into the kernels as constants.
"""
from __future__ import annotations

import math
from decimal import Decimal, getcontext

import numpy as np
from llvmlite import ir
from numba.core import types
from numba.extending import intrinsic

from ..._jit import device as ijit  # (interp.ijit; interp imports this module)

#: the exponent of the Clift et al. (1978) correction f(Re) = 1 + 0.15 Re^0.687 (paper eq. 4)
CLIFT_EXPONENT = 0.687
#: |x| up to which expm1_small uses its Taylor polynomial
EXPM1_TAYLOR_MAX = 0.35
#: binary exponents e of x = 2^e m covered by the table (others: x ** 0.687)
_E_MIN, _E_MAX = -128, 127
_BIN_BITS = 8


@intrinsic
def _bits(typingctx, x):
    """The IEEE-754 bits of a float64, as an int64 (a register move, no memory)."""
    if isinstance(x, types.Float) and x.bitwidth == 64:
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], ir.IntType(64))
        return types.int64(types.float64), codegen
    return None


@intrinsic
def _float(typingctx, b):
    """The float64 with IEEE-754 bits b (int64)."""
    if isinstance(b, types.Integer) and b.bitwidth == 64:
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], ir.DoubleType())
        return types.float64(b), codegen
    return None


def _tables(a: float):
    """2^(a e) per exponent, (c_j^a, 1 / c_j) per mantissa bin j; correctly rounded."""
    getcontext().prec = 40
    da = Decimal(a)
    ln2 = Decimal(2).ln()
    p2 = np.array([float((da * e * ln2).exp()) for e in range(_E_MIN, _E_MAX + 1)])
    nb = 1 << _BIN_BITS
    cs = [Decimal(1) + (Decimal(j) + Decimal("0.5")) / nb for j in range(nb)]
    pm = np.array([[float((da * c.ln()).exp()), float(1 / c)] for c in cs])
    return p2, pm


_P2, _PM = _tables(CLIFT_EXPONENT)


def _log_tables():
    """ln(c_j) per mantissa bin (c_j as in _tables), correctly rounded; ln 2 as a head with 32
    trailing zero bits (e ln2_hi is exact for |e| < 2^21) and the rounded rest."""
    getcontext().prec = 40
    nb = 1 << _BIN_BITS
    lc = np.array([float((Decimal(1) + (Decimal(j) + Decimal("0.5")) / nb).ln())
                   for j in range(nb)])
    ln2 = Decimal(2).ln()
    hi = float(ln2)
    hi = float(np.frombuffer((np.frombuffer(np.float64(hi).tobytes(), dtype=np.int64)
                              & ~np.int64((1 << 32) - 1)).tobytes(), dtype=np.float64)[0])
    return lc, hi, float(ln2 - Decimal(hi))


_LC, _LN2_HI, _LN2_LO = _log_tables()


def binomial_coefficients(a: float, m: int) -> list[float]:
    """C(a, 1), ..., C(a, m): the coefficients of (1 + t)^a = 1 + sum_i C(a, i) t^i."""
    c = [1.0]
    for i in range(m):
        c.append(c[-1] * (a - i) / (i + 1))
    return c[1:]


_B1, _B2, _B3, _B4, _B5 = binomial_coefficients(CLIFT_EXPONENT, 5)
_MANT = (1 << 52) - 1
_ONE = 1023 << 52
_SHIFT = 52 - _BIN_BITS
_HALF_BIN = 1 << (_SHIFT - 1)


@ijit
def pow_0687_table(x):
    """(x^0.687 from the tables, whether x is in their range): branch-free, for vector loops."""
    b = _bits(x)
    eb = (b >> 52) - 1023  # x < 0 has the sign bit: a negative b, out of range
    ok = _E_MIN <= eb <= _E_MAX and b > 0
    e = min(max(eb, _E_MIN), _E_MAX)
    j = (b & _MANT) >> _SHIFT
    m = _float((b & _MANT) | _ONE)
    c = _float(_ONE | (j << _SHIFT) | _HALF_BIN)
    t = (m - c) * _PM[j, 1]  # m - c is exact (same binade)
    s = t * (_B1 + t * (_B2 + t * (_B3 + t * (_B4 + t * _B5))))
    pm = _PM[j, 0]
    return _P2[e - _E_MIN] * (pm + pm * s), ok


@ijit
def pow_0687(x):
    """x^0.687 [same units^0.687] (the Clift exponent), inlined; see the module doc."""
    v, ok = pow_0687_table(x)
    if ok:
        return v
    return x ** 0.687


@ijit
def log_small(x):
    """ln(x), inlined for x >= 1 (libm below); see the module doc."""
    b = _bits(x)
    eb = (b >> 52) - 1023
    if 0 <= eb <= 1023:
        t = x - 1.0
        if t < 1.0 / 256.0:  # near 1: log1p(t) itself (t exact), no cancellation
            return t * (1.0 + t * (-0.5 + t * (1.0 / 3.0 + t * (-0.25 + t * (0.2 + t * (
                -1.0 / 6.0 + t * (1.0 / 7.0 + t * (-0.125 + t * (1.0 / 9.0)))))))))
        j = (b & _MANT) >> _SHIFT
        m = _float((b & _MANT) | _ONE)
        c = _float(_ONE | (j << _SHIFT) | _HALF_BIN)
        t = (m - c) * _PM[j, 1]  # m - c is exact (same binade)
        s = t * (1.0 + t * (-0.5 + t * (1.0 / 3.0 + t * (-0.25 + t * (0.2 + t * (
            -1.0 / 6.0 + t * (1.0 / 7.0)))))))
        e = float(eb)
        return (e * _LN2_HI + _LC[j]) + (e * _LN2_LO + s)
    return math.log(x)


_T = [1.0 / math.factorial(i) for i in range(15)]
_T2, _T3, _T4, _T5, _T6, _T7, _T8, _T9, _T10, _T11, _T12, _T13, _T14 = _T[2:]


@ijit
def expm1_taylor(x):
    """The Taylor polynomial of expm1_small, branch-free (for loops LLVM vectorizes)."""
    return x * (1.0 + x * (_T2 + x * (_T3 + x * (_T4 + x * (_T5 + x * (_T6 + x * (
        _T7 + x * (_T8 + x * (_T9 + x * (_T10 + x * (_T11 + x * (_T12 + x * (
            _T13 + x * _T14)))))))))))))


@ijit
def expm1_small(x):
    """expm1(x) = e^x - 1, inlined for |x| <= EXPM1_TAYLOR_MAX (libm beyond); see the module doc."""
    if abs(x) <= EXPM1_TAYLOR_MAX:
        return expm1_taylor(x)
    return math.expm1(x)
