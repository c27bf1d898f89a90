"""A free-floating base, compiled: the core on the *instantaneous chain*.

``P`` is the packed model of ``robot/floating.virtual_chain(model)``: three prismatic joints
along the base's x, y, z axes and three revolute joints about them, all at zero, the last
carrying the base's inertia, then the chain; its gravity is zero; ``P[n, ROOT]`` = 6. The
recursions take those six as one free-flyer root joint (Newton-Euler, composite rigid
bodies, the Cholesky route, articulated bodies: FDfb; the constant ``nb`` = 6 of
``rnea.newton_euler``, ``crba.composite_bodies``, ``forward.cholesky_route``,
``aba.articulated_bodies`` and their lanes). At that configuration the virtual joints'
rates are v's base part [v_O; omega] (base frame), so the chain's mass matrix is the
floating base's M and its generalized forces are the base wrench [f; m] (base frame) and
the joint torques; the accelerations differ by the virtual joints' velocity products
(``_products``):

    qdd_chain = a + (omega x v_O, -wy wz, wx wz, -wx wy, 0 ...)

Gravity, R^T g for the base's rotation R, enters as the base's acceleration -R^T g
(layout.W_ACC, flag BASE), a tip wrench given in world coordinates as R^T w. The NumPy
reference is ``algorithms/floating.py`` (a 6-DoF root in the recursions); the tests hold
both to Pinocchio's free-flyer.

Entry points (``ENTRY_POINTS``, in ``core.K``): q (n+7) = [x, y, z, qx, qy, qz, qw, joints],
v, a (n+6); ``gw`` (9,) = [tip wrench [f; m] in the world (read with flag WRENCH); world
gravity]; tau (n+6) or joint torques (n) for forward dynamics. Status: 0 ok, 1 a NaN/Inf or
a quaternion of zero length, 2 a wrong length. Batches: ``floating_rows`` converts N states
to the instantaneous chain's rows, the batch kernels (Newton-Euler, composite bodies and
the Cholesky route in SIMD lanes; articulated bodies) run on them (the free-flyer ones:
``floating_rnea_batch``, ``floating_crba_batch``, ``floating_fd_batch``),
``floating_accelerations`` converts back:
the same operations, in the same order, as the single-state entry points.
"""
import math

from numba import njit

from . import flags as F
from .aba import floating_aba_core
from .crba import floating_crba_inline
from .data import new_art, new_chol, new_kin, stack_empty
from .forward import floating_cholesky_core
from .joint import joint_transforms
from .layout import GROOT, W_ACC, W_ALL
from .rnea import floating_rnea_core
from .signatures import In2, Mat, Out2, Pm, Vec, i8
from .status import BAD_LENGTH, status

GW = 9            # length of gw: the tip wrench [f; m] (world), then the world's gravity


@njit(cache=True, inline="always")
def _chain_inputs(q, gw, flags, qv, w):
    """The instantaneous chain's q (``qv``) and external vector ``w`` (layout.W_*) of the
    floating state q; returns 0.0, or NaN for a quaternion of zero length or NaN/Inf."""
    x, y, z, s = q[3], q[4], q[5], q[6]
    nrm = math.sqrt(x * x + y * y + z * z + s * s)
    if not nrm > 1e-12 or not math.isfinite(nrm):
        return math.nan
    x, y, z, s = x / nrm, y / nrm, z / nrm, s / nrm
    r00, r01, r02 = 1 - 2 * (y * y + z * z), 2 * (x * y - z * s), 2 * (x * z + y * s)   # R:
    r10, r11, r12 = 2 * (x * y + z * s), 1 - 2 * (x * x + z * z), 2 * (y * z - x * s)   # world
    r20, r21, r22 = 2 * (x * z - y * s), 2 * (y * z + x * s), 1 - 2 * (x * x + y * y)   # <- base
    for i in range(6):
        qv[i] = 0.0
    for i in range(6, qv.shape[0]):
        qv[i] = q[i + 1]
    for i in range(W_ALL):
        w[i] = 0.0
    _rotate_back(r00, r01, r02, r10, r11, r12, r20, r21, r22, gw, 6, -1.0, w, W_ACC)   # -R^T g
    if (flags & F.WRENCH) != 0:                                                       # R^T w
        _rotate_back(r00, r01, r02, r10, r11, r12, r20, r21, r22, gw, 0, 1.0, w, 0)
        _rotate_back(r00, r01, r02, r10, r11, r12, r20, r21, r22, gw, 3, 1.0, w, 3)
    return 0.0


@njit(cache=True, inline="always")
def _rotate_back(r00, r01, r02, r10, r11, r12, r20, r21, r22, x, i, sign, y, j):
    """y[j:j+3] = sign R^T x[i:i+3]."""
    a, b, c = x[i], x[i + 1], x[i + 2]
    y[j] = sign * (r00 * a + r10 * b + r20 * c)
    y[j + 1] = sign * (r01 * a + r11 * b + r21 * c)
    y[j + 2] = sign * (r02 * a + r12 * b + r22 * c)


@njit(cache=True, inline="always")
def _products(v, sign, x):
    """x[:6] += sign * (omega x v_O, -wy wz, wx wz, -wx wy): the velocity products."""
    vx, vy, vz, wx, wy, wz = v[0], v[1], v[2], v[3], v[4], v[5]
    x[0] += sign * (wy * vz - wz * vy)
    x[1] += sign * (wz * vx - wx * vz)
    x[2] += sign * (wx * vy - wy * vx)
    x[3] -= sign * wy * wz
    x[4] += sign * wx * wz
    x[5] -= sign * wx * wy


@njit(cache=True, inline="always")
def rnea_inputs(q, v, a, gw, flags, qv, w, qddv):
    """The instantaneous chain's (or tree's) q, w and joint accelerations qddv = a plus the
    velocity products, for inverse dynamics; returns the check of q (``_chain_inputs``)."""
    chk = _chain_inputs(q, gw, flags, qv, w)
    for i in range(qddv.shape[0]):
        qddv[i] = a[i] if (flags & F.QDD) != 0 else 0.0
    if (flags & F.QD) != 0:
        _products(v, 1.0, qddv)
    return chk


@njit(cache=True, inline="always")
def fd_inputs(q, tau, gw, flags, qv, w, tv):
    """The instantaneous chain's (or tree's) q, w and generalized forces tv (tau, after six
    zeros when it holds the joint torques only), for forward dynamics; returns the check."""
    chk = _chain_inputs(q, gw, flags, qv, w)
    k = tv.shape[0] - tau.shape[0]                           # 6: joint torques only
    for i in range(tv.shape[0]):
        tv[i] = 0.0 if i < k else tau[i - k]
    return chk


@njit(cache=True, inline="always")
def _rnea_one(P, d, qv, w, qddv, q, v, a, gw, flags, out):
    chk = rnea_inputs(q, v, a, gw, flags, qv, w, qddv)
    chk += floating_rnea_core(P, d.sc, d.R, d.p, d.f, qv, v, qddv, w, flags | F.BASE | F.QDD,
                             out)
    return chk


@njit(cache=True, inline="always")
def _fd_one(P, d, c, art, qv, w, tv, q, v, tau, gw, flags, out):
    chk = fd_inputs(q, tau, gw, flags, qv, w, tv)
    if (flags & F.ABA) != 0:
        chk += floating_aba_core(P, d.sc, d.R, d.p, art.IA, art.pA, art.U, art.c, art.Du,
                                 art.Y, qv, v, tv, w, tv, flags | F.BASE, out)
    else:
        chk += floating_cholesky_core(P, d.sc, d.R, d.p, d.f, c.M, c.b, qv, v, tv, w, tv,
                                      flags | F.BASE, out)
    _products(v, -1.0, out)
    return chk


@njit(cache=True, inline="always")
def gravity_only(P):
    """gw (GW,) of a call without a tip wrench: zeros, then the world's gravity that
    ``layout.pack(root=6, gravity=g)`` put in P. On the caller's stack (inline it)."""
    gw = stack_empty((GW,))
    n = P.shape[0] - 1
    for i in range(6):
        gw[i] = 0.0
    for i in range(3):
        gw[6 + i] = P[n, GROOT + i]
    return gw


def floating_rnea_wrench(P, q, v, a, gw, flags, out):
    """Inverse dynamics of one floating state into ``out`` (n+6,) (flags QD, QDD, WRENCH)."""
    nv = P.shape[0] - 1
    if (q.shape[0] != nv + 1 or v.shape[0] != nv or a.shape[0] != nv or gw.shape[0] != GW
            or out.shape[0] != nv):
        return BAD_LENGTH
    d = new_kin(nv)
    qv, w, qddv = stack_empty((nv,)), stack_empty((W_ALL,)), stack_empty((nv,))
    return status(_rnea_one(P, d, qv, w, qddv, q, v, a, gw, flags, out))


def floating_rnea(P, q, v, a, flags, out):
    """``floating_rnea_wrench`` without a tip wrench, gravity from P (``gravity_only``): one
    array argument fewer, ~35 ns less of numba's dispatcher a call (bench_call_cost.py).
    Flags QD, QDD."""
    nv = P.shape[0] - 1
    if q.shape[0] != nv + 1 or v.shape[0] != nv or a.shape[0] != nv or out.shape[0] != nv:
        return BAD_LENGTH
    d = new_kin(nv)
    qv, w, qddv = stack_empty((nv,)), stack_empty((W_ALL,)), stack_empty((nv,))
    gw = gravity_only(P)
    return status(_rnea_one(P, d, qv, w, qddv, q, v, a, gw, flags & ~F.WRENCH, out))


def floating_fd(P, q, v, tau, gw, flags, out):
    """Forward dynamics a = dv/dt of one floating state into ``out`` (n+6,); ``tau`` (n+6,)
    or joint torques (n,); flags QD, WRENCH, ABA (else Cholesky)."""
    nv = P.shape[0] - 1
    if (q.shape[0] != nv + 1 or v.shape[0] != nv or (tau.shape[0] != nv and tau.shape[0] != nv - 6)
            or gw.shape[0] != GW or out.shape[0] != nv):
        return BAD_LENGTH
    d, c, art = new_kin(nv), new_chol(nv), new_art(nv)
    qv, w, tv = stack_empty((nv,)), stack_empty((W_ALL,)), stack_empty((nv,))
    return status(_fd_one(P, d, c, art, qv, w, tv, q, v, tau, gw, flags | F.QD, out))


def floating_crba(P, q, out):
    """The (n+6, n+6) mass matrix of one floating configuration into ``out``."""
    nv = P.shape[0] - 1
    if q.shape[0] != nv + 1 or out.shape[0] != nv or out.shape[1] != nv:
        return BAD_LENGTH
    d = new_kin(nv)
    qv, w, gw = stack_empty((nv,)), stack_empty((W_ALL,)), stack_empty((GW,))
    for i in range(GW):
        gw[i] = 0.0
    chk = _chain_inputs(q, gw, 0, qv, w)
    chk += joint_transforms(P, d.sc, d.R, d.p, qv, nv, 6)
    floating_crba_inline(P, d.R, d.p, out)
    return status(chk)


def floating_rows(q, v, a, gw, flags, qv, qdd, w):
    """The instantaneous chain's inputs of N floating states, for the fixed-base batch
    kernels (``rnea_batch`` in SIMD lanes, ``fd_batch``, ``crba_batch``): its q (``qv``),
    its qdd (flag QDD: ``a`` plus the velocity products; else the products alone), its
    external vectors ``w`` (N, W_ALL). Rows of one broadcast. Returns 0, or 1 (a NaN/Inf
    or a quaternion of zero length)."""
    N = qv.shape[0]
    bq, bv, ba, bg = q.shape[0] > 1, v.shape[0] > 1, a.shape[0] > 1, gw.shape[0] > 1
    bad = 0
    for k in range(N):
        chk = _chain_inputs(q[k if bq else 0], gw[k if bg else 0], flags, qv[k], w[k])
        if qdd.shape[0] == N:
            ak, vk = a[k if ba else 0], v[k if bv else 0]
            for i in range(qdd.shape[1]):
                qdd[k, i] = ak[i] if (flags & F.QDD) != 0 else 0.0
            _products(vk, 1.0, qdd[k])
        if chk != 0.0:
            bad = 1
    return bad


def floating_accelerations(v, qdd):
    """a = dv/dt of N states from the instantaneous chain's qdd (N, n+6), in place."""
    bv = v.shape[0] > 1
    for k in range(qdd.shape[0]):
        _products(v[k if bv else 0], -1.0, qdd[k])
    return 0


_FD_CALLS = ("floating_aba_core", "cholesky_solve", "floating_cholesky_core")
ENTRY_POINTS = {   # name: (function, signature, releases the GIL, typed core functions it calls)
    "floating_rnea": (floating_rnea, i8(Pm, Vec, Vec, Vec, i8, Vec), False,
                      ("floating_rnea_core",)),
    "floating_rnea_wrench": (floating_rnea_wrench, i8(Pm, Vec, Vec, Vec, Vec, i8, Vec), False,
                             ("floating_rnea_core",)),
    "floating_fd": (floating_fd, i8(Pm, Vec, Vec, Vec, Vec, i8, Vec), False, _FD_CALLS),
    "floating_crba": (floating_crba, i8(Pm, Vec, Mat), False, ()),
    "floating_rows": (floating_rows, i8(In2, In2, In2, In2, i8, Out2, Out2, Out2), True, ()),
    "floating_accelerations": (floating_accelerations, i8(In2, Out2), True, ()),
}
SINGLE_STATE = ("floating_rnea", "floating_rnea_wrench", "floating_fd", "floating_crba")
