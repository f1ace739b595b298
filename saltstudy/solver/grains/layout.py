"""The grain kernels' shared layout: the parameter vector's indices, the drag iteration's tolerances
and series constants, the lane scratch's rows (a block of up to _LANES parcels advanced
together), and the records a step passes between its passes.
"""
from __future__ import annotations

import math
from collections import namedtuple

from ..numerics.elementary import CLIFT_EXPONENT, binomial_coefficients


#: stop of the end-of-step drag-rate iteration: |F(k) - k| <= DRAG_TOL k before a Newton update
#: (its error is then ~DRAG_TOL^2: bench steps agree with a 1e-12 tolerance to 1e-13 m/s), or
#: <= DRAG_TOL^2 k before a plain fixed-point update
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

#: The drag-rate iteration evaluates exp(-k h) and Re_p^0.687 at arguments close to those of its
#: previous evaluation; there they are updated from the previous values by short series, exact to
#: round-off (truncation < 1e-19 relative), instead of new evaluations:
#: expm1(-k h) = em_q + E_q expm1((k_q - k) h) and Re^a = Re_q^a (1 + eps)^a (binomial series).
#: New evaluations are inlined too (elementary.py: no libm calls, which spill the registers).
_NEAR = 0.02

_X2, _X3, _X4, _X5, _X6, _X7, _X8, _X9 = (1.0 / math.factorial(i) for i in range(2, 10))

_B1, _B2, _B3, _B4, _B5, _B6, _B7, _B8, _B9, _B10 = binomial_coefficients(CLIFT_EXPONENT, 10)

# ---- the advance of one parcel, process by process (inlined into _advance_chunk) ----------------
# A block of up to _LANES parcels takes its first sub-step in passes over all its lanes. Where a
# parcel's work branches or reads the grid (locating it and reading the wind there; the
# deposits) the passes are scalar; between them, the step's coefficients, the drag rate's fixed
# point and the relaxation and move are loops without branches or calls, which LLVM vectorizes
# (8 lanes per instruction with AVX-512; the helpers' ``exact=False``). The few lanes whose
# arithmetic there needs libm (an argument beyond the inlined expm1's or Re^0.687's range) or a
# bed crossing are redone one at a time by the same helpers with ``exact=True`` (branches and
# libm allowed; the same formulas wherever both apply, equal to round-off: LLVM may contract the
# two differently, tests/test_particles_lanes.py), and a parcel that needs more sub-steps
# takes them alone (_rest_of_step). Between the passes a lane's values wait in the chunk's lane
# scratch, one row of _LANES values per quantity, flat: row r of lane l at r * _LANES + l (a
# constant offset from one base pointer).
(_X, _Y, _Z, _U, _V, _W, _D, _KD, _T, _US, _VS, _WS, _DZK, _EC, _TLC,
 _FXF, _FXC, _FYF, _FYC, _FZC, _FZF,
 _TP, _ITP, _DNU, _QM, _H, _IH, _DU, _DV, _DW, _MU, _MV, _MW,
 _K, _KQ, _EMQ, _IRELQ, _RPQ,
 _XN, _YN, _ZN, _UN, _VN, _WN, _RU, _RV, _RW, _RT) = (r * _LANES for r in range(48))

# _X ... _W the parcel at the start, _D its diameter, _KD its stored drag rate, _T its step (dt plus
# its time credit); _US, _VS, _WS the resolved wind it sees; _DZK the height of the cell holding it;
# _EC the SGS TKE of the cell its TKE sink goes to and _TLC that level's T_L coefficient; _FXF ...
# _FZF the stencil's fractions; _TP T_p, _ITP 1 / T_p, _DNU d / nu, _QM Q m_p; _H the sub-step, _IH
# 1 / h; _DU, _DV, _DW the slip at its start; _MU, _MV, _MW the modelled impulse of the implicit
# estimate; _K the drag rate (the iteration's current value), _KQ, _EMQ, _IRELQ, _RPQ the
# iteration's last evaluation (_EMQ: the estimate's expm1 before the first); _XN ... _WN the parcel
# at the end of the sub-step (_H then the sub-step as taken); _RU, _RV, _RW the air's impulse and
# _RT the TKE-sink rate the sub-step deposits
_LANE_ROWS_F = 48

(_ACTIVE, _ITER, _FIX, _E0, _HIT, _XF, _XC, _YF, _YC, _KC, _KF, _LOG, _KCELL) = (
    r * _LANES for r in range(13))

# _ACTIVE 1 if the lane takes its sub-step (0: the parcel was inside the impact layer already);
# _ITER 1 while its drag rate iterates; _FIX 1 if a vectorized pass left it to the exact one;
# _E0 1 if the first drag evaluation's expm1 is the implicit estimate's (same k and h: the same
# number); _HIT 1 if the sub-step ended at the bed; _XF ... _KF the stencil's indices, _LOG 1 in
# the log region, _KCELL the level of the cell holding the parcel
_LANE_ROWS_I = 13

#: the scalars of a step, as _advance_chunk reads them once from prm and geo
_Step = namedtuple("_Step", "dt g h_imp tol tol_fp Lx Ly Lz rho nu rho_p Q twoway tke nkb")

#: the chunks' work: their parcels (idx[cstart[c]:cstart[c+1]], coupling.chunk_assign), pool
#: ranges (coupling.chunk_ranges) and pool, results (vmax, nhit per chunk) and lane scratch
#: (lane_f (chunks, _LANE_ROWS_F * _LANES), lane_i (chunks, _LANE_ROWS_I * _LANES))
Work = namedtuple("Work", "cstart idx ranges pool vmax nhit lane_f lane_i")

#: where a chunk deposits: its pool range (slab s, L slabs, offset off; csz entries per
#: component), nk levels, comp ct the TKE sink's
_Out = namedtuple("_Out", "pool s L off csz nk ct")
