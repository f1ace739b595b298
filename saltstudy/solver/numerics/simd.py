"""Short-vector read-modify-writes and loads for the parcel kernels' deposits and trilinear reads.

A trilinear deposit adds to levels k and k + 1 of four columns, contiguous in the buffers (four
values with the implicit estimate's interleaved (A, B) sums). Numba keeps LLVM's SLP vectorizer
off (a miscompilation, numba#8705), so these intrinsics emit one vector load, fused multiply-add
and store of 2 or 4 doubles, each element bit for bit the scalar code's. No bounds check.
"""
from __future__ import annotations

from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic


def _vector_fma(context, builder, ary_ty, ary, i, mul, add_scalars):
    """pool[i:i + n] = fma(mul, add, pool[i:i + n]) for n = len(mul) (vectors built from scalars)."""
    n = len(mul)
    dbl = ir.DoubleType()
    vty = ir.VectorType(dbl, n)
    arr = context.make_array(ary_ty)(context, builder, value=ary)
    ptr = builder.gep(arr.data, [i])
    vptr = builder.bitcast(ptr, vty.as_pointer())
    old = builder.load(vptr, align=8)
    a = cgutils.get_null_value(vty)
    b = cgutils.get_null_value(vty)
    for m in range(n):
        idx = ir.Constant(ir.IntType(32), m)
        a = builder.insert_element(a, mul[m], idx)
        b = builder.insert_element(b, add_scalars[m], idx)
    fma = cgutils.get_or_insert_function(builder.module, ir.FunctionType(vty, [vty, vty, vty]),
                                         f"llvm.fma.v{n}f64")
    builder.store(builder.call(fma, [a, b, old]), vptr, align=8)


def _check(ary, i):
    return (isinstance(ary, types.Array) and ary.ndim == 1 and ary.dtype == types.float64
            and ary.layout == "C" and isinstance(i, types.Integer))


@intrinsic
def fma2(typingctx, ary, i, w0, w1, v):
    """ary[i] += w0 * v; ary[i + 1] += w1 * v (one 2-wide fused multiply-add)."""
    if not _check(ary, i):
        return None
    sig = types.void(ary, types.intp, types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        a, idx, x0, x1, val = args
        _vector_fma(context, builder, signature.args[0], a, idx, [x0, x1], [val, val])
        return context.get_dummy_value()
    return sig, codegen


@intrinsic
def fma4(typingctx, ary, i, w0, w1, va, vb):
    """ary[i:i + 4] += (w0 va, w0 vb, w1 va, w1 vb): two interleaved (A, B) pairs at once."""
    if not _check(ary, i):
        return None
    sig = types.void(ary, types.intp, types.float64, types.float64, types.float64,
                     types.float64)

    def codegen(context, builder, signature, args):
        a, idx, x0, x1, pa, pb = args
        _vector_fma(context, builder, signature.args[0], a, idx, [x0, x0, x1, x1],
                    [pa, pb, pa, pb])
        return context.get_dummy_value()
    return sig, codegen


@intrinsic
def load2(typingctx, ary, i, j, k):
    """(ary[i, j, k], ary[i, j, k + 1]) of a C-contiguous 3-D float64 or float32 array in one
    2-wide load; indices in range (k + 1 < shape[2]), no check."""
    if not (isinstance(ary, types.Array) and ary.ndim == 3
            and ary.dtype in (types.float64, types.float32)
            and ary.layout == "C" and all(isinstance(t, types.Integer) for t in (i, j, k))):
        return None
    ret = types.UniTuple(ary.dtype, 2)
    sig = ret(ary, types.intp, types.intp, types.intp)
    lane = ir.DoubleType() if ary.dtype == types.float64 else ir.FloatType()
    align = 8 if ary.dtype == types.float64 else 4

    def codegen(context, builder, signature, args):
        aty = signature.args[0]
        arr = context.make_array(aty)(context, builder, value=args[0])
        shape = cgutils.unpack_tuple(builder, arr.shape, 3)
        strides = cgutils.unpack_tuple(builder, arr.strides, 3)
        ptr = cgutils.get_item_pointer2(context, builder, arr.data, shape, strides, "C",
                                        list(args[1:]), wraparound=False)
        vty = ir.VectorType(lane, 2)
        v = builder.load(builder.bitcast(ptr, vty.as_pointer()), align=align)
        elems = [builder.extract_element(v, ir.Constant(ir.IntType(32), m)) for m in range(2)]
        return context.make_tuple(builder, ret, elems)
    return sig, codegen
