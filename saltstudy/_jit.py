"""One shared set of numba flags for every kernel of the package.

``fastmath`` keeps NaN/Inf semantics (no ``nnan``/``ninf``): with those flags ``np.isnan`` is
folded to False and the blow-up check silently stops working. The cache lives in a directory keyed
by a hash of the package's numerical sources (set in ``saltstudy/__init__.py``), because numba's
``cache=True`` does not notice edits to *other* modules a kernel calls.
"""
from __future__ import annotations

import numba

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
