"""One shared set of numba flags for every kernel of the package.

``fastmath`` keeps NaN/Inf semantics (no ``nnan``/``ninf``: they fold ``np.isnan`` to False and
break the blow-up check). The cache directory is keyed by a hash of the numerical sources
(_identity.py): numba's ``cache=True`` misses edits to other modules a kernel calls.
"""
from __future__ import annotations

import os

import numba
import numba.core.cpu
from llvmlite import binding as _llvm
from numba.core import types as _types
from numba.extending import overload as _overload

#: ``SALTSTUDY_STRICT_IEEE=1`` compiles without fast-math, a check: with ``reassoc``/``contract``
#: LLVM orders sums from the surrounding code, so removing a dead branch can move a result's last
#: bit; under strict IEEE the same arithmetic gives the same bits. SOURCE_KEY names the mode.
STRICT_IEEE = os.environ.get("SALTSTUDY_STRICT_IEEE", "") not in ("", "0")
FASTMATH = set() if STRICT_IEEE else {"nsz", "arcp", "contract", "afn", "reassoc"}

#: serial kernels (particles per parcel, small loops)
jit = numba.njit(cache=True, nogil=True, error_model="numpy", fastmath=FASTMATH)
#: parallel stencils: ``prange`` over x-slabs
pjit = numba.njit(cache=True, nogil=True, error_model="numpy", fastmath=FASTMATH, parallel=True)


def jit_with(**overrides):
    """The shared flags with some overridden."""
    return numba.njit(**{**dict(cache=True, nogil=True, error_model="numpy", fastmath=FASTMATH),
                         **overrides})


#: serial per-parcel kernels that allocate nothing, compiled without numba's reference counting:
#: its atomic increments in inlined helpers that take arrays cost ~18 pairs per parcel-step (one
#: helper 11 -> 3 ns per call, callgrind on ``saltstudy bench particles``). Falls back to the
#: plain flags where numba lacks the private option.
jit_borrow = jit_with(_nrt=False) if hasattr(numba.core.cpu.CPUTargetOptions, "_nrt") else jit


#: LLVM's inliner threshold: the per-point helpers take many arrays (structs), which the default
#: threshold (275) leaves out of line; numba's IR inlining re-types each copy (minutes per kernel).
#: ``saltstudy bench flow --steps 10 --no-big`` from an empty cache: 236 s with IR inlining, 59 s
#: with this, and 226 against 205 ns per cell-step.
LLVM_INLINE_THRESHOLD = 20000
_llvm.set_option("saltstudy", f"-inline-threshold={LLVM_INLINE_THRESHOLD}")

#: small per-point helpers called from the kernels (inlined by LLVM, see above); compiled without
#: reference counting, so that the inlined copies carry no reference-count traffic either
device = jit_borrow


def like(ref, value):
    """``value`` in the floating type of ``ref`` (an array's dtype or a scalar's type): a float
    literal in a kernel is float64 and would promote single-precision stencils (``time.precision``);
    for float64 fields the constant equals the literal: those kernels compile to the same code."""
    t = ref.dtype.type if hasattr(ref, "dtype") else type(ref)
    return t(value)


@_overload(like, inline="always", jit_options={"cache": True})
def _like(ref, value):
    t = ref.dtype if isinstance(ref, _types.Array) else ref

    def impl(ref, value):
        return t(value)
    return impl
