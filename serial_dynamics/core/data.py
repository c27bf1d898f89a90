"""``Data``: the named scratch arrays of one evaluation, separate from the model.

Each compiled entry point makes the arrays its algorithm needs at the start of the call,
on the stack of that call (``stack_empty``; an array of more than 64 KiB on the heap), so
no scratch memory is ever shared between calls or threads: a ``Robot`` is thread-safe by
construction and the batch kernels run on several cores without locks. Making them costs
a few nanoseconds (a heap allocation costs ~20 ns each; docs/speed.md). Shapes, for n
joints (spatial vectors angular first, as everywhere in the core):

    Kin   sc  (2, n)      sin q_i, cos q_i
          R   (n, 3, 3)   rotation of body i in body i-1       } the joint transforms at q
          p   (n, 3)      origin of body i in body i-1         } (Xup_i = X(R, p)^-1)
          f   (n, 6)      body wrench (n_O; f) about the body origin (Newton-Euler)
    Chol  M   (n, n)      mass matrix, then its Cholesky factor
          b   (n,)        tau - bias
    Art   IA  (n, 6, 6)   articulated-body inertias            pA (n, 6)  bias forces
          U   (n, 6)      IA S                                 c  (n, 6)  v x S qd
          Du  (n, 2)      D = S^T U (+ damping), u = tau - S^T pA
          Y   (3, 3)      one 3x3 block of IA rotated into the parent's axes
    Poses sc, R, p        as Kin's                             } core/kinematics.py
          R0  (n, 3, 3)   body i's joint frame in the world    o  (n, 3)  its origin
          Rb  (3, 3)      the base's orientation               pb (3,)    its origin

The ``new_*`` functions must be inlined into the entry point that owns the call (they
are ``inline="always"``) and must not be called inside a loop: stack memory lives until
that entry point returns.
"""
from collections import namedtuple

import numpy as np
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic

from .signatures import internal

Kin = namedtuple("Kin", "sc R p f")                  # kinematics + Newton-Euler (+ CRBA)
Chol = namedtuple("Chol", "M b")                     # Cholesky route of forward dynamics
Art = namedtuple("Art", "IA pA U c Du Y")            # articulated-body algorithm
Poses = namedtuple("Poses", "sc R p R0 o Rb pb")     # kinematics: bodies (and base) in the world
STACK_DOUBLES = 8192    # an array larger than this (64 KiB) goes on the heap: the mass matrix
# from n = 91 joints on, the articulated inertias from n = 228; Kin, 20 n doubles, always
# fits a thread's stack (8 MB).


@intrinsic
def stack_empty(typingctx, shape):
    """An uninitialized C-contiguous float64 array of ``shape`` (a tuple of ints) in the
    calling function's stack frame: no allocation, no reference count."""
    if not (isinstance(shape, types.UniTuple) and isinstance(shape.dtype, types.Integer)):
        return None
    ndim = shape.count
    arrty = types.Array(types.float64, ndim, "C")

    def codegen(context, builder, sig, args):
        intp = context.get_value_type(types.intp)
        dims = [builder.sext(d, intp) if d.type.width < intp.width else d
                for d in cgutils.unpack_tuple(builder, args[0], ndim)]
        total = context.get_constant(types.intp, 1)
        for d in dims:
            total = builder.mul(total, d)
        data = builder.alloca(context.get_value_type(types.float64), size=total)
        strides, step = [], context.get_constant(types.intp, 8)
        for d in reversed(dims):
            strides.insert(0, step)
            step = builder.mul(step, d)
        ary = context.make_array(arrty)(context, builder)
        context.populate_array(ary, data=data, shape=dims, strides=strides,
                               itemsize=context.get_constant(types.intp, 8), meminfo=None)
        return ary._getvalue()

    return arrty(shape), codegen


@internal
def heap_empty(shape):
    """``np.empty(shape)``, compiled once per number of dimensions and called (lowering
    np.empty in every entry point would cost ~0.3 s of compile time each)."""
    return np.empty(shape)


@njit(cache=True, inline="always")
def scratch(shape, size):
    """``stack_empty(shape)``, or a heap array when ``size`` doubles exceed the limit."""
    return stack_empty(shape) if size <= STACK_DOUBLES else heap_empty(shape)


# A lane block's scratch that grows as n^2 (the mass matrix's n^2 rows of B samples) is on
# the block's stack, where LLVM sees it cannot overlap the model or the inputs (on the heap,
# or chosen between the two at run time, it cannot, and the Cholesky batch ran 26 % slower:
# bench_speed.py, 2026-11-27); up to 512 KiB, n <= 45 at B = 32. A longer chain's batch
# runs one state at a time (the same bits).
LANE_STACK_DOUBLES = 65536


@njit(cache=True, inline="always")
def square_lanes_fit(n, L):
    """Whether a block of L lanes may hold an n x n matrix per lane on its stack."""
    return n * n * L <= LANE_STACK_DOUBLES


@njit(cache=True, inline="always")
def new_kin(n):
    return Kin(stack_empty((2, n)), stack_empty((n, 3, 3)), stack_empty((n, 3)), stack_empty((n, 6)))


@njit(cache=True, inline="always")
def new_poses(n):
    return Poses(stack_empty((2, n)), stack_empty((n, 3, 3)), stack_empty((n, 3)),
                 stack_empty((n, 3, 3)), stack_empty((n, 3)), stack_empty((3, 3)), stack_empty((3,)))


@njit(cache=True, inline="always")
def new_chol(n):
    return Chol(scratch((n, n), n * n), scratch((n,), n))


@njit(cache=True, inline="always")
def new_art(n):
    return Art(scratch((n, 6, 6), 36 * n), scratch((n, 6), 6 * n), scratch((n, 6), 6 * n),
               scratch((n, 6), 6 * n), scratch((n, 2), 2 * n), stack_empty((3, 3)))
