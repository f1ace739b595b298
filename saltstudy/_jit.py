"""One shared set of numba flags for every kernel of the package.

``fastmath`` keeps NaN/Inf semantics (no ``nnan``/``ninf``): with those flags ``np.isnan`` is
folded to False and the blow-up check silently stops working. The cache lives in a directory keyed
by a hash of the package's numerical sources (set in ``saltstudy/__init__.py``), because numba's
``cache=True`` does not notice edits to *other* modules a kernel calls.
"""
from __future__ import annotations

import os

import numba
import numba.core.cpu
from llvmlite import binding as _llvm

#: ``SALTSTUDY_STRICT_IEEE=1`` compiles every kernel without fast-math: a check, not a mode to run
#: studies in. With ``reassoc`` and ``contract`` LLVM chooses the order of sums and products from
#: the code around them, so an edit that only removes a dead branch can move the last bit of a
#: result (and a turbulent run amplifies it); under strict IEEE two versions that do the same
#: arithmetic give the same bits. The source key (``saltstudy.SOURCE_KEY``) names the mode, so its
#: kernels and archives are cached apart.
STRICT_IEEE = os.environ.get("SALTSTUDY_STRICT_IEEE", "") not in ("", "0")
FASTMATH = set() if STRICT_IEEE else {"nsz", "arcp", "contract", "afn", "reassoc"}

#: serial kernels (particles per parcel, small loops)
jit = numba.njit(cache=True, nogil=True, error_model="numpy", fastmath=FASTMATH)
#: parallel stencils: ``prange`` over x-slabs
pjit = numba.njit(cache=True, nogil=True, error_model="numpy", fastmath=FASTMATH, parallel=True)


def jit_with(**overrides):
    """The shared flags with some overridden (e.g. ``parallel=True`` for a kernel with prange)."""
    flags = dict(cache=True, nogil=True, error_model="numpy", fastmath=FASTMATH)
    flags.update(overrides)
    return numba.njit(**flags)


#: serial per-parcel kernels that allocate nothing (scratch arrays come from the caller): compiled
#: without numba's reference counting. With it, every call of an inlined helper that takes an array
#: and branches inside (``interp.locate``, the trilinear deposits, ...) incremented and decremented
#: that array's reference count -- an atomic on a cache line both threads share -- about 18 pairs
#: per parcel-step, which the reference-count pruning pass cannot remove across the branches
#: (measured by callgrind on the bench; a micro-benchmark of one such helper: 11 ns -> 3 ns per
#: call). Falls back to the plain flags if numba no longer has the (private) option.
jit_borrow = jit_with(_nrt=False) if hasattr(numba.core.cpu.CPUTargetOptions, "_nrt") else jit


#: LLVM's inliner threshold for every kernel compiled in this process. The per-point functions of
#: the stencils (advection, SGS fluxes, the peeled levels of a column) and of the parcel step are
#: small but take many arrays, which numba passes as structs: above LLVM's default threshold (275)
#: they stay out-of-line calls. Numba's own IR inlining (``inline="always"``) inlines them but
#: re-types each copy, and each stage kernel took 3-9 minutes to compile. Measured on a 2-core
#: VM, IR inlining against LLVM inlining at this threshold: `saltstudy bench flow --steps 10
#: --no-big` from an empty cache 236 s against 59 s, 226 against 205 ns per cell-step; Stepper.step
#: on the reduced grid (median of 10 steps, the first step for the compile), all four stages
#: (explicit/implicit x advection order 2/4) compiled in 860 s against 81 s and ran at
#: 177/195/277/346 against 117/142/187/248 ns per cell-step; the grain step (`saltstudy bench
#: particles`, three alternating runs each) the same within the runs' +-15 % scatter.
LLVM_INLINE_THRESHOLD = 20000
_llvm.set_option("saltstudy", f"-inline-threshold={LLVM_INLINE_THRESHOLD}")

#: small per-point helpers called from the kernels (inlined by LLVM, see above); compiled without
#: reference counting, so that the inlined copies carry no reference-count traffic either
device = jit_borrow
