"""The grain kernels' shared layout: the parameter vector's indices, the drag iteration's
tolerances and series constants, the lane scratch's rows and the records between the passes."""
from __future__ import annotations

import math
from collections import namedtuple

from ..numerics.elementary import CLIFT_EXPONENT, binomial_coefficients


#: stop of the drag-rate iteration: |F(k) - k| <= DRAG_TOL k before a Newton update (its error is
#: then ~DRAG_TOL^2: bench steps agree with a 1e-12 tolerance to 1e-13 m/s), DRAG_TOL^2 k before
#: a plain fixed-point update
DRAG_TOL = 1e-3
DRAG_MAXIT = 40

#: Newton updates of the drag-rate iteration at most (then plain fixed-point updates)
NEWTON_MAXIT = 12

#: sub-steps per step at most (a parcel then moves more than a cell height in a sub-step)
MAX_SUBSTEPS = 16

#: parcels advanced together (in lockstep passes) by _advance_chunk (its lane rows: below)
_LANES = 64

# indices of the kernels' parameter vector
_RHO, _NU, _G, _RHOP, _Q, _HIMP, _TOL, _LZ, _DT, _TWOWAY, _TKE = range(11)

#: Within _NEAR of its last evaluation the drag iteration updates exp(-k h) and Re_p^0.687 by
#: short series (truncation < 1e-19 relative): expm1(-k h) = em_q + E_q expm1((k_q - k) h) and
#: Re^a = Re_q^a (1 + eps)^a
_NEAR = 0.02

_X2, _X3, _X4, _X5, _X6, _X7, _X8, _X9 = (1.0 / math.factorial(i) for i in range(2, 10))

_B1, _B2, _B3, _B4, _B5, _B6, _B7, _B8, _B9, _B10 = binomial_coefficients(CLIFT_EXPONENT, 10)

# ---- the lanes: a block of up to _LANES parcels takes its first sub-step in passes over its lanes.
# Locating, reading the wind and depositing are scalar passes; the coefficients, the drag rate's
# fixed point, the relaxation and move are loops without branches or calls that LLVM vectorizes
# (``exact=False``). Lanes needing libm or a bed crossing are redone one at a time with
# ``exact=True`` (the same formulas, equal to round-off: tests/test_particles_lanes.py); further
# sub-steps go one parcel at a time (_rest_of_step). Row r of lane l sits at r * _LANES + l of
# the chunk's lane scratch.
(_X, _Y, _Z, _U, _V, _W, _D, _KD, _T, _US, _VS, _WS, _DZK, _EC, _TLC,
 _FXF, _FXC, _FYF, _FYC, _FZC, _FZF,
 _TP, _ITP, _DNU, _QM, _H, _IH, _DU, _DV, _DW, _MU, _MV, _MW,
 _K, _KQ, _EMQ, _IRELQ, _RPQ,
 _XN, _YN, _ZN, _UN, _VN, _WN, _RU, _RV, _RW, _RT) = (r * _LANES for r in range(48))

# _X ... _W the parcel, _D, _KD its diameter and drag rate, _T its step (dt + credit); _US ... _WS
# the wind seen; _DZK its cell's height; _EC, _TLC its TKE-sink cell's e and T_L coefficient; _FXF
# ... _FZF the stencil; _TP T_p, _ITP 1 / T_p, _DNU d / nu, _QM Q m_p; _H, _IH the sub-step and
# 1 / h; _DU ... _DW the start slip; _MU ... _MW the modelled impulse; _K the drag rate, _KQ ...
# _RPQ the iteration's last evaluation; _XN ... _WN the end state; _RU ... _RT the deposits
_LANE_ROWS_F = 48

(_ACTIVE, _ITER, _FIX, _E0, _HIT, _XF, _XC, _YF, _YC, _KC, _KF, _LOG, _KCELL) = (
    r * _LANES for r in range(13))

# _ACTIVE the lane takes its sub-step; _ITER its drag rate iterates; _FIX left to the exact pass;
# _E0 the first evaluation's expm1 is the estimate's; _HIT it ended at the bed; _XF ... _KF, _LOG,
# _KCELL the stencil
_LANE_ROWS_I = 13

#: the scalars of a step, as _advance_chunk reads them once from prm and geo
_Step = namedtuple("_Step", "dt g h_imp tol tol_fp Lx Ly Lz rho nu rho_p Q twoway tke nkb")

#: the chunks' work: parcels (coupling.chunk_assign), pool ranges and pool, results (vmax, nhit
#: per chunk) and lane scratch (chunks, rows * _LANES)
Work = namedtuple("Work", "cstart idx ranges pool vmax nhit lane_f lane_i")

#: where a chunk deposits: slab s, L slabs, offset off, csz entries per comp, nk levels, TKE comp ct
_Out = namedtuple("_Out", "pool s L off csz nk ct")
