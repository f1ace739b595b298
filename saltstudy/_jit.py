"""One shared set of numba flags for every kernel of the package.

``fastmath`` keeps NaN/Inf semantics (no ``nnan``/``ninf``): with those flags ``np.isnan`` is
folded to False and the blow-up check silently stops working. The cache lives in a directory keyed
by a hash of the package's numerical sources (set in ``saltstudy/__init__.py``), because numba's
``cache=True`` does not notice edits to *other* modules a kernel calls.
"""
from __future__ import annotations

import numba
import numba.core.cpu

FASTMATH = {"nsz", "arcp", "contract", "afn", "reassoc"}

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
