"""The steps the kernels share, as CUDA device functions.

The Newton-Euler steps, the joint types, the frame changes, sine and cosine, the Cholesky
factor and a floating base's inputs are the compiled core's own functions (``core/rnea.py``,
``core/joint.py``, ``core/spatial.py``, ``core/cholesky.py``, ``core/floating.py``):
``device`` compiles the same Python source for the CUDA target, and the core functions they
call are compiled for it by numba-cuda too. What is new here is what the core does over
Data arrays rather than on scalars:

- ``joint_transform``: one body's (R, p) at q (``core/joint.py``'s, after sin q and cos q);
- ``composite_to_parent``: the composite-rigid-body step of ``core/crba.py``, written there
  inline in its chain loop; here a function of the child's and the parent's composites, so
  that a tree adds each child to its parent;
- ``coordinates``: joint i's value from the robot's coordinates (mimic joints);
- ``row``: a state's row copied into a per-thread array, for the core functions that take
  arrays (in numba's simulator a device array's row is no NumPy array they can take).
"""
import math
from functools import lru_cache

from numba import float64

from ..core import cholesky as _cholesky
from ..core import floating as _floating
from ..core import joint as _joint
from ..core import rnea as _rnea
from ..core import spatial as _spatial
from .runtime import cuda


def device(f):
    """A core function (a numba CPU dispatcher) as a CUDA device function, from its source."""
    return cuda.jit(device=True)(getattr(f, "py_func", f))


into_body = device(_rnea.into_body)
joint_rate = device(_joint.joint_rate)
project = device(_joint.project)
joint_momentum = device(_joint.joint_momentum)
placement = device(_joint.joint_transform)
has_armature = device(_joint.has_armature)
inertia = device(_rnea.inertia)
rigid_wrench = device(_rnea.rigid_wrench)
force_to_parent = device(_spatial.force_to_parent)
sincos = device(_spatial.sincos)
cholesky_factor = device(_cholesky.cholesky_factor)
cholesky_solve_factored = device(_cholesky.cholesky_solve_factored)
floating_rnea_inputs = device(_floating.rnea_inputs)
floating_fd_inputs = device(_floating.fd_inputs)
floating_chain_inputs = device(_floating._chain_inputs)
velocity_products = device(_floating._products)


@cuda.jit(device=True)
def body_wrench(P, i, wx, wy, wz, ax, ay, az, lx, ly, lz):
    """``rnea.body_wrench`` with the card's ``inertia`` and ``rigid_wrench`` (the source of a
    device function calls the CPU's versions of what it names)."""
    return rigid_wrench(inertia(P, i), wx, wy, wz, ax, ay, az, lx, ly, lz)


@cuda.jit(device=True)
def joint_transform(P, i, q):
    """Body i in body i-1 at q_i: R_i (nine numbers, row-major) and p_i, the core's
    ``joint.joint_transform`` of sin q_i, cos q_i."""
    if abs(q) < _spatial.SMALL_ANGLE:
        s, c = sincos(q)
    else:
        s, c = math.sin(q), math.cos(q)
    return placement(P, i, s, c, q)


@cuda.jit(device=True)
def composite_to_parent(r, px, py, pz, c, a):
    """The parent's composite ``a`` plus the child's ``c`` carried into the parent's frame;
    composites as ten numbers (m, h = m c, I_O: xx yy zz xy xz yz), r, p the child's joint
    transform. h_R = R h, I_R = R I_O R^T, then parallel axes to the parent origin
    (Featherstone 2008, eq. 2.63): I' = I_R + (2 h_R.p + m p.p) 1 - (h_R p^T + p h_R^T + m p p^T),
    h' = h_R + m p; the operations of core/crba.py in its order."""
    m, hx, hy, hz = c[0], c[1], c[2], c[3]
    Ixx, Iyy, Izz, Ixy, Ixz, Iyz = c[4], c[5], c[6], c[7], c[8], c[9]
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8]
    gx, gy, gz = r0 * hx + r1 * hy + r2 * hz, r3 * hx + r4 * hy + r5 * hz, r6 * hx + r7 * hy + r8 * hz
    t0, t1, t2 = r0 * Ixx + r1 * Ixy + r2 * Ixz, r0 * Ixy + r1 * Iyy + r2 * Iyz, r0 * Ixz + r1 * Iyz + r2 * Izz
    t3, t4, t5 = r3 * Ixx + r4 * Ixy + r5 * Ixz, r3 * Ixy + r4 * Iyy + r5 * Iyz, r3 * Ixz + r4 * Iyz + r5 * Izz
    t6, t7, t8 = r6 * Ixx + r7 * Ixy + r8 * Ixz, r6 * Ixy + r7 * Iyy + r8 * Iyz, r6 * Ixz + r7 * Iyz + r8 * Izz
    Jxx, Jyy, Jzz = t0 * r0 + t1 * r1 + t2 * r2, t3 * r3 + t4 * r4 + t5 * r5, t6 * r6 + t7 * r7 + t8 * r8
    Jxy, Jxz, Jyz = t0 * r3 + t1 * r4 + t2 * r5, t0 * r6 + t1 * r7 + t2 * r8, t3 * r6 + t4 * r7 + t5 * r8
    d = 2.0 * (gx * px + gy * py + gz * pz) + m * (px * px + py * py + pz * pz)
    return (a[0] + m,
            a[1] + gx + m * px, a[2] + gy + m * py, a[3] + gz + m * pz,
            a[4] + Jxx + d - 2.0 * gx * px - m * px * px,
            a[5] + Jyy + d - 2.0 * gy * py - m * py * py,
            a[6] + Jzz + d - 2.0 * gz * pz - m * pz * pz,
            a[7] + Jxy - gx * py - px * gy - m * px * py,
            a[8] + Jxz - gx * pz - px * gz - m * px * pz,
            a[9] + Jyz - gy * pz - py * gz - m * py * pz)


@cuda.jit(device=True)
def row(X, s, out):
    """out[:m] = X[s] (m = X.shape[1]): a state's row in a per-thread array, which the core's
    functions that take arrays (``core/floating.py``'s) read on the card and in the
    simulator alike."""
    for i in range(X.shape[1]):
        out[i] = X[s, i]


@cuda.jit(device=True)
def get9(A, i):
    return A[i, 0], A[i, 1], A[i, 2], A[i, 3], A[i, 4], A[i, 5], A[i, 6], A[i, 7], A[i, 8]


@cuda.jit(device=True)
def put9(A, i, t):
    A[i, 0], A[i, 1], A[i, 2], A[i, 3], A[i, 4], A[i, 5], A[i, 6], A[i, 7], A[i, 8] = t


@cuda.jit(device=True)
def get10(A, i):
    return (A[i, 0], A[i, 1], A[i, 2], A[i, 3], A[i, 4], A[i, 5], A[i, 6], A[i, 7], A[i, 8],
            A[i, 9])


@cuda.jit(device=True)
def put10(A, i, t):
    A[i, 0], A[i, 1], A[i, 2], A[i, 3], A[i, 4], A[i, 5], A[i, 6], A[i, 7], A[i, 8], A[i, 9] = t


@lru_cache(maxsize=None)
def coordinates(n, k, mimic):
    """(load, store, store_matrix) for n joints and k coordinates: joint i of state s is
    X[s, src[i]] mult[i] (+ offset[i] for positions), q_all = G q + o; a result goes back
    by G^T (tau = G^T tau_all, M = G^T M_all G; Featherstone 2008, Sec. 3.2). Without mimic
    joints, copies."""

    @cuda.jit(device=True)
    def load(X, s, src, mult, off, with_offset, out):
        for i in range(n):
            if mimic:
                out[i] = X[s, src[i]] * mult[i] + (off[i] if with_offset else 0.0)
            else:
                out[i] = X[s, i]

    @cuda.jit(device=True)
    def store(x, src, mult, OUT, s):
        if mimic:
            red = cuda.local.array(k, float64)
            for a in range(k):
                red[a] = 0.0
            for i in range(n):
                red[src[i]] += mult[i] * x[i]
            for a in range(k):
                OUT[s, a] = red[a]
        else:
            for i in range(n):
                OUT[s, i] = x[i]

    @cuda.jit(device=True)
    def reduce_matrix(M, src, mult, red):
        """red = G^T M G (k, k)."""
        for a in range(k):
            for b in range(k):
                red[a, b] = 0.0
        for i in range(n):
            for j in range(n):
                red[src[i], src[j]] += (mult[i] * mult[j]) * M[i, j]

    return load, store, reduce_matrix
