"""Kinematic trees, compiled: the composite-rigid-body algorithm, forward dynamics (the
sparse L^T D L factor of M, or articulated bodies: ``aba.py`` serves chains and trees),
dT/dq (symplectic Euler's gradient) and the tree kernels' entry points, on the parent array
lambda(i) (``P[i, PARENT]``; Featherstone 2008, Tables 5.1 and 6.2, whose loops are written
for trees). Newton-Euler is ``rnea.newton_euler``, one skeleton for chains and trees
(``tree_rnea_core``: its tree kernel).

The CRBA climbs the ancestors j = lambda(j) for the off-diagonal entries, with the chain
kernels' steps (``crba.add_in_parent``, ``joint.joint_momentum``; ``spatial.to_parent``). A
chain keeps the chain kernels (``Robot`` picks the table from the model; their bits are the
chain's). The tip wrench acts on body n-1 (the last leaf) and is carried into its frame along
its path (``P[i, TIPPATH]``).
"""
from numba import njit, types

from . import flags as F
from .aba import floating_tree_aba_core, tree_aba_core
from .aba_lanes import aba_block, aba_lanes_fit, floating_aba_block
from .cholesky import ltdl_factor, ltdl_solve_factored
from .crba import add_in_parent, root_block
from .floating import GW, _chain_inputs, _products, fd_inputs, gravity_only, rnea_inputs
from .data import new_art, new_chol, new_kin, scratch, square_lanes_fit, stack_empty
from .energy import axis_gradient, body_momentum, body_velocity
from .joint import armature_diagonal, armature_torques, joint_momentum, joint_transforms, project
from .layout import H, IO, KIND, LANES, MASS, PARENT, ROOT, TIPPATH, W_ALL, W_WRENCH
from .rnea import tree_rnea_core
from .signatures import D2, D3, In1, In2, Mat, Out1, Out2, Out3, Pm, Vec, f8, i8, internal
from .spatial import finite, rotation, to_child, to_parent
from .status import BAD_LENGTH, NOT_FINITE, OK, status
from .tree_lanes import (floating_tree_fd_block, floating_tree_rnea_block, tree_crba_block,
                         tree_fd_block, tree_rnea_block)


def tree_crba_core(P, R, p, IC, M):
    """M of a tree into ``M`` (n, n); R, p hold the joint transforms. IC (n, 10): the
    composite bodies' (m, h, I_O: xx yy zz xy xz yz), each in its joint frame.
    On a floating base's virtual tree (robot/floating.virtual_chain; ``P[n, ROOT]`` = 6)
    bodies 0-5 are the free-flyer root: its six columns are each joint's composite F
    carried into the base frame, its block the composite inertia of the whole robot
    (Featherstone 2008, Sec. 9.2), not six single-axis joints climbed one by one."""
    n = M.shape[0]
    nb = int(P[n, ROOT])
    for i in range(n):
        for j in range(n):
            M[i, j] = 0.0                            # bodies on other branches: no coupling
        IC[i, 0], IC[i, 1], IC[i, 2], IC[i, 3] = P[i, MASS], P[i, H], P[i, H + 1], P[i, H + 2]
        for k in range(6):
            IC[i, 4 + k] = P[i, IO + k]
    for i in range(n - 1, nb - 1, -1):
        m, hx, hy, hz = IC[i, 0], IC[i, 1], IC[i, 2], IC[i, 3]
        Ixx, Iyy, Izz, Ixy, Ixz, Iyz = IC[i, 4], IC[i, 5], IC[i, 6], IC[i, 7], IC[i, 8], IC[i, 9]
        # F = IC_i S_i; M_ii = S_i^T F
        nx, ny, nz, fx, fy, fz, M[i, i] = joint_momentum(P[i, KIND], m, hx, hy, Ixz, Iyz, Izz)
        j = i
        while P[j, PARENT] >= nb:   # up the ancestors: F = Xup_j^T F, M_ji = S_j^T F
            nx, ny, nz, fx, fy, fz = to_parent(R, p, j, nx, ny, nz, fx, fy, fz)
            j = int(P[j, PARENT])
            M[j, i] = project(P[j, KIND], nz, fz)
            M[i, j] = M[j, i]
        if nb > 0:                  # into the base frame: M_root,i = F (v = [v_O, omega])
            nx, ny, nz, fx, fy, fz = to_parent(R, p, j, nx, ny, nz, fx, fy, fz)
            M[0, i], M[1, i], M[2, i], M[3, i], M[4, i], M[5, i] = fx, fy, fz, nx, ny, nz
            M[i, 0], M[i, 1], M[i, 2], M[i, 3], M[i, 4], M[i, 5] = fx, fy, fz, nx, ny, nz
        l = int(P[i, PARENT])
        if l >= 0:                  # IC_lambda(i) += Xup_i^T IC_i Xup_i
            (IC[l, 0], IC[l, 1], IC[l, 2], IC[l, 3], IC[l, 4], IC[l, 5], IC[l, 6], IC[l, 7],
             IC[l, 8], IC[l, 9]) = add_in_parent(
                IC[l, 0], IC[l, 1], IC[l, 2], IC[l, 3], IC[l, 4], IC[l, 5], IC[l, 6], IC[l, 7],
                IC[l, 8], IC[l, 9], rotation(R, i), p[i, 0], p[i, 1], p[i, 2],
                m, hx, hy, hz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz)
    if nb > 0:                      # the root's block: IC of everything, in the base frame
        r = nb - 1
        root_block(M, IC[r, 0], IC[r, 1], IC[r, 2], IC[r, 3], IC[r, 4], IC[r, 5], IC[r, 6],
                   IC[r, 7], IC[r, 8], IC[r, 9])
    armature_diagonal(P, M, nb)     # M_ii += I_a,i


tree_crba_core = internal(types.void(Pm, D3, D2, D2, Out2))(tree_crba_core)


def tree_fd_core(P, sc, R, p, f, mo, IC, M, q, qd, tau, w, flags, out):
    """qdd of a tree into ``out``: M qdd = tau - b + J^T w by the sparse factor M = L^T D L
    (Featherstone 2008, Sec. 6.5). Returns 0.0, or NaN on a NaN/Inf input."""
    n = out.shape[0]
    chk = tree_rnea_core(P, sc, R, p, f, mo, q, qd, q, w, flags & (F.QD | F.WRENCH | F.BASE),
                         out)                                # b
    for i in range(n):
        chk += finite(tau[i])
        out[i] = tau[i] - out[i]
    tree_crba_core(P, R, p, IC, M)
    ltdl_factor(P, M)
    ltdl_solve_factored(P, M, out)
    return chk


tree_fd_core = internal(f8(Pm, D2, D3, D2, D2, D2, D2, D2, In1, In1, In1, In1, i8, Out1),
                        calls=("tree_rnea_core", "tree_crba_core", "ltdl_factor",
                               "ltdl_solve_factored"))(tree_fd_core)


def tree_ke_gradient_core(P, R, p, qd, V, out):
    """dT/dq of a tree at fixed qd into ``out`` (energy.py's ``ke_gradient_core`` on
    lambda(i)); R, p the joint transforms at q; V (n, 12) each body's velocity (omega; v) at
    its origin and then the momentum H of its subtree, in its frame."""
    n = out.shape[0]
    for i in range(n):
        l = int(P[i, PARENT])
        wx = wy = wz = vx = vy = vz = 0.0           # the parent's velocity (the base's: 0)
        if l >= 0:
            wx, wy, wz, vx, vy, vz = V[l, 0], V[l, 1], V[l, 2], V[l, 3], V[l, 4], V[l, 5]
        wx, wy, wz, vx, vy, vz = body_velocity(P, R, p, i, wx, wy, wz, vx, vy, vz, qd[i])
        V[i, 0], V[i, 1], V[i, 2], V[i, 3], V[i, 4], V[i, 5] = wx, wy, wz, vx, vy, vz
        V[i, 6], V[i, 7], V[i, 8], V[i, 9], V[i, 10], V[i, 11] = body_momentum(
            P, i, wx, wy, wz, vx, vy, vz)
    for k in range(n - 1, -1, -1):    # H_k complete: its children were added before it
        nx, ny, nz, fx, fy, fz = V[k, 6], V[k, 7], V[k, 8], V[k, 9], V[k, 10], V[k, 11]
        out[k] = axis_gradient(P, k, V[k, 0], V[k, 1], V[k, 2], V[k, 3], V[k, 4], V[k, 5],
                               nx, ny, nz, fx, fy, fz)
        l = int(P[k, PARENT])
        if l >= 0:                    # H_lambda(k) += X_k^T H_k
            nx, ny, nz, fx, fy, fz = to_parent(R, p, k, nx, ny, nz, fx, fy, fz)
            V[l, 6], V[l, 7], V[l, 8] = V[l, 6] + nx, V[l, 7] + ny, V[l, 8] + nz
            V[l, 9], V[l, 10], V[l, 11] = V[l, 9] + fx, V[l, 10] + fy, V[l, 11] + fz


tree_ke_gradient_core = internal(types.void(Pm, D3, D2, In1, D2, Out1))(tree_ke_gradient_core)


# ------------------------------------------------------------------ entry points
# The chain kernels' signatures (dispatch.py), so that ``Robot`` calls either table alike.
def tree_rnea(P, q, qd, qdd, flags, out):
    n = P.shape[0] - 1
    if q.shape[0] != n or qd.shape[0] != n or qdd.shape[0] != n or out.shape[0] != n:
        return BAD_LENGTH
    d = new_kin(n)
    return status(tree_rnea_core(P, d.sc, d.R, d.p, d.f, stack_empty((n, 9)), q, qd, qdd, q,
                                 flags & (F.QD | F.QDD), out))


def tree_rnea_wrench(P, q, qd, qdd, w, flags, out):
    n = P.shape[0] - 1
    if (q.shape[0] != n or qd.shape[0] != n or qdd.shape[0] != n or out.shape[0] != n
            or w.shape[0] != (W_ALL if (flags & F.BASE) != 0 else W_WRENCH)):
        return BAD_LENGTH
    d = new_kin(n)
    return status(tree_rnea_core(P, d.sc, d.R, d.p, d.f, stack_empty((n, 9)), q, qd, qdd, w,
                                 flags, out))


def tree_crba(P, q, out):
    n = P.shape[0] - 1
    if q.shape[0] != n or out.shape[0] != n or out.shape[1] != n:
        return BAD_LENGTH
    d = new_kin(n)
    chk = joint_transforms(P, d.sc, d.R, d.p, q, n)
    tree_crba_core(P, d.R, d.p, stack_empty((n, 10)), out)
    return status(chk)


def tree_fd(P, q, qd, tau, w, flags, out):
    n = P.shape[0] - 1
    if (q.shape[0] != n or qd.shape[0] != n or tau.shape[0] != n or out.shape[0] != n
            or w.shape[0] != (W_ALL if (flags & F.BASE) != 0 else W_WRENCH)):
        return BAD_LENGTH
    d = new_kin(n)
    flags &= ~F.DAMPING                  # tau stands in for the unread damping argument
    if (flags & F.ABA) != 0:             # articulated bodies (aba.py, on lambda(i))
        a, va = new_art(n), scratch((n, 6), 6 * n)
        return status(tree_aba_core(P, d.sc, d.R, d.p, a.IA, a.pA, a.U, a.c, a.Du, a.Y, va,
                               q, qd, tau, w, tau, flags, out))
    c = new_chol(n)
    return status(tree_fd_core(P, d.sc, d.R, d.p, d.f, stack_empty((n, 9)),
                               stack_empty((n, 10)), c.M, q, qd, tau, w, flags, out))


def tree_rnea_batch(P, q, qd, qdd, w, flags, out):
    """Inverse dynamics of N states (a row of 1 broadcasts), B at a time in SIMD lanes
    (``tree_lanes.py``; on a floating base's virtual tree with its free-flyer root). Returns
    OK or NOT_FINITE."""
    N, n = out.shape[0], P.shape[0] - 1
    bad = OK
    for k0 in range(0, N, int(P[n, LANES])):
        if P[n, ROOT] == 0.0:
            bad |= tree_rnea_block(P, q, qd, qdd, w, flags, out, k0)
        else:
            bad |= floating_tree_rnea_block(P, q, qd, qdd, w, flags, out, k0)
    return bad


def tree_crba_batch(P, q, out):
    """Mass matrices of N configurations: on a fixed base B at a time in SIMD lanes; on a
    floating one, or a tree too big for the lanes' stack (``data.square_lanes_fit``), one
    state after the other (the same bits). Returns OK or NOT_FINITE."""
    N, n = out.shape[0], P.shape[0] - 1
    L = int(P[n, LANES])
    if P[n, ROOT] == 0.0 and square_lanes_fit(n, L):   # a fixed base: B at a time in lanes
        bad = OK
        for k0 in range(0, N, L):
            bad |= tree_crba_block(P, q, out, k0)
        return bad
    d, IC = new_kin(n), stack_empty((n, 10))
    bad = OK
    for k in range(N):
        if joint_transforms(P, d.sc, d.R, d.p, q[k], n) != 0.0:
            bad = NOT_FINITE
        tree_crba_core(P, d.R, d.p, IC, out[k])
    return bad


def tree_fd_batch(P, q, qd, tau, w, flags, out):
    """Forward dynamics of N states, as ``tree_crba_batch`` splits them (a row of 1
    broadcasts): the sparse factor (``tree_lanes.fd_lanes``, with the free-flyer root on a
    floating base's virtual tree), or with flag ABA articulated bodies (``aba_lanes.py``, FDfb
    on a floating base's virtual tree), B at a time in lanes where they fit. Returns OK or
    NOT_FINITE."""
    N, n = out.shape[0], P.shape[0] - 1
    L = int(P[n, LANES])
    flags &= ~F.DAMPING                  # tau stands in for the unread damping argument
    aba, floating = (flags & F.ABA) != 0, P[n, ROOT] != 0.0
    if aba_lanes_fit(n, L) if aba else square_lanes_fit(n, L):
        bad = OK                         # B at a time in lanes
        for k0 in range(0, N, L):
            if not aba and floating:
                bad |= floating_tree_fd_block(P, q, qd, tau, w, flags, out, k0)
            elif not aba:
                bad |= tree_fd_block(P, q, qd, tau, w, flags, out, k0)
            elif floating:
                bad |= floating_aba_block(P, q, qd, tau, w, flags, out, k0)
            else:
                bad |= aba_block(P, q, qd, tau, w, flags, out, k0)
        return bad
    d, c, mo, IC = new_kin(n), new_chol(n), stack_empty((n, 9)), stack_empty((n, 10))
    a, va = new_art(n), scratch((n, 6), 6 * n)
    nq, nv, nt, nw = q.shape[0] > 1, qd.shape[0] > 1, tau.shape[0] > 1, w.shape[0] > 1
    bad = OK
    for k in range(N):
        qk, qdk, tk, wk = q[k if nq else 0], qd[k if nv else 0], tau[k if nt else 0], w[k if nw else 0]
        if aba and floating:             # FDfb on a floating base's virtual tree
            chk = floating_tree_aba_core(P, d.sc, d.R, d.p, a.IA, a.pA, a.U, a.c, a.Du, a.Y, va,
                                         qk, qdk, tk, wk, tk, flags, out[k])
        elif aba:
            chk = tree_aba_core(P, d.sc, d.R, d.p, a.IA, a.pA, a.U, a.c, a.Du, a.Y, va,
                           qk, qdk, tk, wk, tk, flags, out[k])
        else:
            chk = tree_fd_core(P, d.sc, d.R, d.p, d.f, mo, IC, c.M, qk, qdk, tk, wk, flags, out[k])
        if chk != 0.0:
            bad = NOT_FINITE
    return bad


# ------------------------------------------------------------------ a floating base on a tree
# core/floating.py's entry points on the instantaneous tree (robot/floating.virtual_chain of a
# tree: the six virtual joints, then the tree hanging from the last): the same conversions
# (rnea_inputs, fd_inputs, _products) around the tree kernels, which take the six as one
# free-flyer root (P[n, ROOT]); forward dynamics by L^T D L or articulated bodies (FDfb).
@njit(cache=True, inline="always")
def _floating_tree_rnea_one(P, q, v, a, gw, flags, out):
    nv = P.shape[0] - 1
    d = new_kin(nv)
    qv, w, qddv = stack_empty((nv,)), stack_empty((W_ALL,)), stack_empty((nv,))
    chk = rnea_inputs(q, v, a, gw, flags, qv, w, qddv)
    chk += tree_rnea_core(P, d.sc, d.R, d.p, d.f, stack_empty((nv, 9)), qv, v, qddv, w,
                          flags | F.BASE | F.QDD, out)
    return status(chk)


def floating_tree_rnea_wrench(P, q, v, a, gw, flags, out):
    nv = P.shape[0] - 1
    if (q.shape[0] != nv + 1 or v.shape[0] != nv or a.shape[0] != nv or gw.shape[0] != GW
            or out.shape[0] != nv):
        return BAD_LENGTH
    return _floating_tree_rnea_one(P, q, v, a, gw, flags, out)


def floating_tree_rnea(P, q, v, a, flags, out):
    """Without a tip wrench, gravity from P (core/floating.py's ``floating_rnea``)."""
    nv = P.shape[0] - 1
    if q.shape[0] != nv + 1 or v.shape[0] != nv or a.shape[0] != nv or out.shape[0] != nv:
        return BAD_LENGTH
    gw = gravity_only(P)
    return _floating_tree_rnea_one(P, q, v, a, gw, flags & ~F.WRENCH, out)


def floating_tree_fd(P, q, v, tau, gw, flags, out):
    nv = P.shape[0] - 1
    if (q.shape[0] != nv + 1 or v.shape[0] != nv or (tau.shape[0] != nv and tau.shape[0] != nv - 6)
            or gw.shape[0] != GW or out.shape[0] != nv):
        return BAD_LENGTH
    d = new_kin(nv)
    qv, w, tv = stack_empty((nv,)), stack_empty((W_ALL,)), stack_empty((nv,))
    chk = fd_inputs(q, tau, gw, flags, qv, w, tv)
    flags = (flags | F.QD | F.BASE) & ~F.DAMPING
    if (flags & F.ABA) != 0:             # articulated bodies through the free-flyer root
        a, va = new_art(nv), scratch((nv, 6), 6 * nv)
        chk += floating_tree_aba_core(P, d.sc, d.R, d.p, a.IA, a.pA, a.U, a.c, a.Du, a.Y, va,
                                      qv, v, tv, w, tv, flags, out)
    else:
        c = new_chol(nv)
        chk += tree_fd_core(P, d.sc, d.R, d.p, d.f, stack_empty((nv, 9)),
                            stack_empty((nv, 10)), c.M, qv, v, tv, w, flags, out)
    _products(v, -1.0, out)
    return status(chk)


def floating_tree_crba(P, q, out):
    nv = P.shape[0] - 1
    if q.shape[0] != nv + 1 or out.shape[0] != nv or out.shape[1] != nv:
        return BAD_LENGTH
    d = new_kin(nv)
    qv, w, gw = stack_empty((nv,)), stack_empty((W_ALL,)), stack_empty((GW,))
    for i in range(GW):
        gw[i] = 0.0
    chk = _chain_inputs(q, gw, 0, qv, w)
    chk += joint_transforms(P, d.sc, d.R, d.p, qv, nv, 6)
    tree_crba_core(P, d.R, d.p, stack_empty((nv, 10)), out)
    return status(chk)


def tree_kinetic_energy_gradient(P, q, qd, out):
    """dT/dq of one state of a fixed-base tree into ``out`` (n,)."""
    n = P.shape[0] - 1
    if q.shape[0] != n or qd.shape[0] != n or out.shape[0] != n:
        return BAD_LENGTH
    d = new_kin(n)
    chk = joint_transforms(P, d.sc, d.R, d.p, q, n)
    for i in range(n):
        chk += finite(qd[i])
    tree_ke_gradient_core(P, d.R, d.p, qd, stack_empty((n, 12)), out)
    return status(chk)


_FD = ("tree_fd_core", "tree_aba_core", "floating_tree_aba_core")
ENTRY_POINTS = {
    "tree_rnea": (tree_rnea, i8(Pm, Vec, Vec, Vec, i8, Vec), False, ("tree_rnea_core",)),
    "tree_rnea_wrench": (tree_rnea_wrench, i8(Pm, Vec, Vec, Vec, Vec, i8, Vec), False,
                         ("tree_rnea_core",)),
    "tree_crba": (tree_crba, i8(Pm, Vec, Mat), False, ("tree_crba_core",)),
    "tree_fd": (tree_fd, i8(Pm, Vec, Vec, Vec, Vec, i8, Vec), False, _FD),
    "tree_rnea_batch": (tree_rnea_batch, i8(Pm, In2, In2, In2, In2, i8, Out2), True,
                        ("tree_rnea_block", "floating_tree_rnea_block")),
    "tree_crba_batch": (tree_crba_batch, i8(Pm, In2, Out3), True, ("tree_crba_core", "tree_crba_block")),
    "tree_fd_batch": (tree_fd_batch, i8(Pm, In2, In2, In2, In2, i8, Out2), True,
                      _FD + ("tree_fd_block", "floating_tree_fd_block", "aba_block",
                             "floating_aba_block")),
    "floating_tree_rnea": (floating_tree_rnea, i8(Pm, Vec, Vec, Vec, i8, Vec), False,
                           ("tree_rnea_core",)),
    "floating_tree_rnea_wrench": (floating_tree_rnea_wrench, i8(Pm, Vec, Vec, Vec, Vec, i8, Vec),
                                  False, ("tree_rnea_core",)),
    "floating_tree_fd": (floating_tree_fd, i8(Pm, Vec, Vec, Vec, Vec, i8, Vec), False, _FD),
    "floating_tree_crba": (floating_tree_crba, i8(Pm, Vec, Mat), False, ("tree_crba_core",)),
    "tree_kinetic_energy_gradient": (tree_kinetic_energy_gradient, i8(Pm, Vec, Vec, Vec), False,
                                     ("tree_ke_gradient_core",)),
}
SINGLE_STATE = ("tree_rnea", "tree_rnea_wrench", "tree_crba", "tree_fd", "floating_tree_rnea",
                "floating_tree_rnea_wrench",
                "floating_tree_fd", "floating_tree_crba", "tree_kinetic_energy_gradient")
