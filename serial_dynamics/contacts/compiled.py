"""Constrained forward dynamics of one state in one compiled call: ``constrained.py``'s
``_one`` (the same steps and stopping rules) on the compiled core's own kernels.

Per call, one numba kernel (``constrained_one``):

1. M by the robot's composite-rigid-body kernel and b by its Newton-Euler kernel at zero
   acceleration (``crba``/``rnea``, or their tree and floating-base versions: the ones
   ``mass_matrix`` and ``bias_torques`` call), M = L L^T and a0 = M^-1 (tau - b)
   (``core/cholesky.py``);
2. each contact's rows at its link's frame from the poses of every body, computed once
   (the steps of the core's ``frame_pose_one``, ``frame_jacobian_one`` and
   ``frame_acceleration`` at zero acceleration), moved to the contact point as
   ``jacobians.contact_rows`` moves them (``compiled_rows.py``); a set of
   contacts with the environment whose position errors are not read takes each point as a
   frame of its body, as ``jacobians.world_rows`` does (``contact_table``: the point folded
   into the frame);
3. Y = L^-1 J^T, the Delassus matrix G = Y^T Y = J M^-1 J^T, and
   r = -J-dot v - kd J v - kp e - J a0;
4. G f = r directly where G is firm (every squared pivot of its Cholesky factor above
   ``DIRECT`` of its largest diagonal entry: ``dense.firm_factor``'s test) and the residual
   meets the tolerance, else by the proximal iterations of ``constrained.proximal_solve``
   (Carpentier et al. 2021); a = a0 + L^-T Y f.

The contacts enter as one array (``contact_table``: a row per contact), the settings as
another (``numbers``). The kernel returns OK; NOT_FINITE where an input is not finite or a
factor fails (M, or G + mu, not positive definite); NOT_CONVERGED where the iterations did
not converge. ``solve`` answers None for those, and for robots it has no kernel for (mimic
joints: their Jacobians are reduced on the facade; the NumPy backend): the caller then
takes the reference path, which raises its error naming the cause or answers.
"""
from __future__ import annotations

import math
import weakref

import numpy as np
from numba import njit

from ..core import K, OK
from ..core import flags as FL
from ..core.cholesky import cholesky_factor, cholesky_solve_factored
from ..core.data import scratch, stack_empty
from ..core.kinematics import not_finite_one
from ..core.cabi import entry
from ..core.signatures import Mat, Pm, Vec, compile_internal, i8
from ..core.status import BAD_LENGTH, NOT_CONVERGED, NOT_FINITE
from .compiled_rows import FRAME, WIDTH, contact_rows, contact_table
from .contact import check_contacts

# the settings (``numbers``)
MU, TOLERANCE, ITERATIONS, KP, KD, DIRECT = 0, 1, 2, 3, 4, 5
NUMBERS = 6
TINY = 2.2250738585072014e-308      # np.finfo(float).tiny


# ------------------------------------------------------------------ linear algebra
@njit(inline="always")
def factor(L):
    """L L^T = L's lower triangle in place; False where a pivot is not positive (LAPACK
    dpotrf's info != 0: G singular, or not positive definite). Unlike core's
    ``cholesky_factor`` it stops at such a pivot instead of dividing by it."""
    n = L.shape[0]
    for j in range(n):
        s = L[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > 0.0:
            return False
        d = math.sqrt(s)
        L[j, j] = d
        d = 1.0 / d
        for i in range(j + 1, n):
            s = L[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s * d
    return True


@njit(inline="always")
def firm_factor(G, L, pivot):
    """L L^T = G (L a copy of G factored by ``factor``) where G is firm: every squared
    pivot at least ``pivot`` of G's largest diagonal entry (``dense.firm_factor``'s test).
    False where the factor fails or a pivot is below that."""
    m = G.shape[0]
    g_max = TINY
    for i in range(m):
        g_max = max(g_max, G[i, i])
        for j in range(m):
            L[i, j] = G[i, j]
    if not factor(L):
        return False
    for i in range(m):
        if L[i, i] ** 2 < pivot * g_max:
            return False
    return True


@njit(inline="always")
def lower_solve(L, B, Y):
    """Y = L^-1 B^T (L lower triangular (n, n), B (m, n)): forward substitution, a row of
    Y at a time (its columns contiguous)."""
    n, m = L.shape[0], B.shape[0]
    for i in range(n):
        for c in range(m):
            Y[i, c] = B[c, i]
        for k in range(i):
            lik = L[i, k]
            for c in range(m):
                Y[i, c] -= lik * Y[k, c]
        d = 1.0 / L[i, i]
        for c in range(m):
            Y[i, c] *= d


@njit(inline="always")
def upper_solve(L, x):
    """x <- L^-T x (L lower triangular): back substitution."""
    n = x.shape[0]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, n):
            s -= L[k, i] * x[k]
        x[i] = s / L[i, i]


@njit(inline="always")
def _residual(G, f, r):
    """max |G f - r|."""
    out = 0.0
    for i in range(r.shape[0]):
        s = -r[i]
        for j in range(r.shape[0]):
            s += G[i, j] * f[j]
        out = max(out, abs(s))
    return out


@njit(inline="always")
def _proximal(G, r, mu, tolerance, max_iterations, direct, L, f, x, info):
    """f with G f = r (``constrained.proximal_solve``, its rules): directly where G is firm
    and the residual meets the tolerance, else f_k+1 = (G + mu 1)^-1 (r + mu f_k) from 0.
    OK, NOT_FINITE (G + mu not positive definite) or NOT_CONVERGED; info[0] the residual,
    info[1] the iterations."""
    m = r.shape[0]
    scale, g_max = 1.0, TINY
    for i in range(m):
        scale, g_max = max(scale, abs(r[i])), max(g_max, G[i, i])
    info[1] = 0.0
    if firm_factor(G, L, direct):
        for i in range(m):
            f[i] = r[i]
        cholesky_solve_factored(L, f)
        info[0] = _residual(G, f, r)
        if info[0] <= tolerance * scale:
            return OK
    mu_abs = mu * g_max
    for i in range(m):
        for j in range(m):
            L[i, j] = G[i, j] + (mu_abs if i == j else 0.0)
    if not factor(L):
        return NOT_FINITE
    residual = 0.0
    for i in range(m):
        f[i] = 0.0
        residual = max(residual, abs(r[i]))
    for it in range(max_iterations):
        for i in range(m):
            x[i] = r[i] + mu_abs * f[i]
        cholesky_solve_factored(L, x)
        step, size = 0.0, 1.0
        for i in range(m):
            step = max(step, abs(x[i] - f[i]))
            f[i] = x[i]
            size = max(size, abs(f[i]))
        previous, residual = residual, _residual(G, f, r)
        info[0], info[1] = residual, it + 1.0
        if step <= tolerance * size or tolerance * scale >= residual > 0.5 * previous:
            return OK
    return NOT_CONVERGED


# ------------------------------------------------------------------ the kernel
@njit(inline="always")
def constrained_one(crba, rnea, floating, Pd, Pk, q, v, tau, spec, num, flags, a, F):
    """a (nv,) and the forces table F (k, 3 or 6) of one state (module docstring): ``crba``
    and ``rnea`` the robot's kernels on ``Pd`` (a floating base's instantaneous chain, or
    the model's ``Pk``), the contacts' kinematics on ``Pk``; tau (nv,) or a floating base's
    joint torques (the base's then zero); ``flags`` Newton-Euler's for b."""
    nv, k = v.shape[0], spec.shape[0]
    m, width = 0, 3
    for c in range(k):
        m += 6 if spec[c, FRAME] != 0.0 else 3
        width = 6 if spec[c, FRAME] != 0.0 else width
    if (nv != Pd.shape[0] - 1 or q.shape[0] != nv + (1 if floating else 0)
            or (tau.shape[0] != nv and not (floating and tau.shape[0] == nv - 6))
            or a.shape[0] != nv or F.shape[0] != k or F.shape[1] != width
            or spec.shape[1] != WIDTH or num.shape[0] != NUMBERS):
        return BAD_LENGTH
    info = stack_empty((2,))
    if not_finite_one(q) or not_finite_one(v) or not_finite_one(tau):
        return NOT_FINITE
    M, b, h = scratch((nv, nv), nv * nv), stack_empty((nv,)), stack_empty((nv,))
    for i in range(nv):
        h[i] = 0.0
    # 1. M, b (the robot's own kernels), M = L L^T, a0 = M^-1 (tau - b) (into a)
    if crba(Pd, q, M) != OK or rnea(Pd, q, v, h, flags, b) != OK:
        return NOT_FINITE
    cholesky_factor(M)
    for i in range(nv):
        if not M[i, i] > 0.0:
            return NOT_FINITE
    off = nv - tau.shape[0]            # 6: joint torques of a floating base (the base free)
    for i in range(nv):
        a[i] = (0.0 if i < off else tau[i - off]) - b[i]
    cholesky_solve_factored(M, a)
    # 2. the rows: J, J-dot v, position errors
    Jc, drift, err = scratch((m, nv), m * nv), stack_empty((m,)), stack_empty((m,))
    if not contact_rows(Pk, q, v, spec, num[KP], Jc, drift, err):
        return NOT_FINITE
    # 3. Y = L^-1 J^T, G = Y^T Y = J M^-1 J^T, r = -J-dot v - kd J v - kp e - J a0
    Y = scratch((nv, m), nv * m)
    lower_solve(M, Jc, Y)
    G, r = scratch((m, m), m * m), stack_empty((m,))
    for i in range(m):
        Jv, Ja = 0.0, 0.0
        for j in range(nv):
            Jv += Jc[i, j] * v[j]
            Ja += Jc[i, j] * a[j]
        r[i] = -drift[i] - num[KD] * Jv - num[KP] * err[i] - Ja
        for j in range(i + 1):
            G[i, j] = 0.0
    for l in range(nv):                # G's lower triangle, row l of Y at a time
        for i in range(m):
            y = Y[l, i]
            for j in range(i + 1):
                G[i, j] += y * Y[l, j]
    for i in range(m):
        for j in range(i + 1, m):
            G[i, j] = G[j, i]
    # 4. G f = r, a = a0 + L^-T (Y f)
    L, f, x = scratch((m, m), m * m), stack_empty((m,)), stack_empty((m,))
    st = _proximal(G, r, num[MU], num[TOLERANCE], int(num[ITERATIONS]), num[DIRECT], L, f, x,
                   info)
    if st != OK:
        return st
    for i in range(nv):
        s = 0.0
        for j in range(m):
            s += Y[i, j] * f[j]
        b[i] = s
    upper_solve(M, b)
    for i in range(nv):
        a[i] += b[i]
    i = 0
    for c in range(k):                 # the forces table, a point's moment 0
        size = 6 if spec[c, FRAME] != 0.0 else 3
        for j in range(F.shape[1]):
            F[c, j] = f[i + j] if j < size else 0.0
        i += size
    return OK


# One kernel per kind of robot: its mass-matrix and Newton-Euler kernels of the kernel
# table (``core.K``; a tree's ``core.dispatch.TREE`` names), set by ``kernel`` before it
# compiles the kind's function (numba reads a global when it compiles).
KINDS = {"chain": ("crba", "rnea"), "tree": ("tree_crba", "tree_rnea"),
         "floating": ("floating_crba", "floating_rnea"),
         "floating_tree": ("floating_tree_crba", "floating_tree_rnea")}
chain_crba = chain_rnea = tree_crba = tree_rnea = None
floating_crba = floating_rnea = floating_tree_crba = floating_tree_rnea = None


def chain_one(Pd, Pk, q, v, tau, spec, num, flags, a, F):
    return constrained_one(chain_crba, chain_rnea, False, Pd, Pk, q, v, tau, spec, num, flags,
                           a, F)


def tree_one(Pd, Pk, q, v, tau, spec, num, flags, a, F):
    return constrained_one(tree_crba, tree_rnea, False, Pd, Pk, q, v, tau, spec, num, flags,
                           a, F)


def floating_one(Pd, Pk, q, v, tau, spec, num, flags, a, F):
    return constrained_one(floating_crba, floating_rnea, True, Pd, Pk, q, v, tau, spec, num,
                           flags, a, F)


def floating_tree_one(Pd, Pk, q, v, tau, spec, num, flags, a, F):
    return constrained_one(floating_tree_crba, floating_tree_rnea, True, Pd, Pk, q, v, tau,
                           spec, num, flags, a, F)


_FUNCTIONS = {"chain": chain_one, "tree": tree_one, "floating": floating_one,
              "floating_tree": floating_tree_one}
_KERNELS = {}


SIGNATURE = i8(Pm, Pm, Vec, Vec, Vec, Mat, Vec, i8, Vec, Mat)


def kernel(kind):
    """The kernel of ``kind`` (a key of KINDS), compiled on first use after the core's
    kernels it calls (built, or loaded from the cache, by ``core.K``): a single-state entry
    point (``core/cabi.py``: its arguments' types checked in C, OTHER_TYPES for others)."""
    if kind not in _KERNELS:
        g = globals()
        crba, rnea = KINDS[kind]
        g[f"{kind}_crba"], g[f"{kind}_rnea"] = getattr(K, crba).kernel, getattr(K, rnea).kernel
        compile_internal(("cholesky_factor", "cholesky_solve_factored"))
        _KERNELS[kind] = entry(f"constrained_{kind}", _FUNCTIONS[kind], SIGNATURE,
                                 folder="contacts")
    return _KERNELS[kind]


# ------------------------------------------------------------------ Python side
class _Robot:
    """What ``solve`` needs of one robot: its kind's kernel (compiled on first use), packed
    models and Newton-Euler flags, and the contact sets it was called with."""
    __slots__ = ("kind", "kernel", "Pd", "Pk", "flags", "nv", "sets")

    def __init__(self, robot):
        floating = robot.is_floating
        tree = not robot.model.is_chain       # the robot's kernel table: core.K or TREE
        self.kind = ("floating_tree" if tree else "floating") if floating else \
            ("tree" if tree else "chain")
        self.kernel = None
        self.Pk = robot.packed_model
        self.Pd = robot.packed_dynamics_model           # a floating base: its instantaneous chain
        # bias_torques' own flags: a floating base's inverse dynamics at a = 0
        self.flags = FL.QD | FL.QDD if floating else FL.QD
        self.nv = robot.nv
        self.sets = {}


_ROBOTS = {}         # id(robot) -> _Robot (None: no kernel for it), dropped with the robot
SETS = 64            # contact sets remembered per robot


def _entry(robot):
    """The robot's ``_Robot`` (by its identity: a plain dict's lookup is a fraction of a
    WeakKeyDictionary's; ``weakref.finalize`` drops it when the robot goes)."""
    key = id(robot)
    e = _ROBOTS.get(key, False)
    if e is False:
        ok = robot.packed_model is not None and not robot.model.has_mimic_joints
        e = _ROBOTS[key] = _Robot(robot) if ok else None
        weakref.finalize(robot, _ROBOTS.pop, key, None)
    return e


class ContactSet:
    """A checked set of contacts of one robot as its kernel takes it: the tables
    (``contact_table``), folded or not, made on first use."""
    __slots__ = ("contacts", "robot", "loops", "shape", "tables")

    def __init__(self, contacts, robot):
        self.contacts, self.robot = contacts, robot
        self.loops = any(c.other_link is not None for c in contacts)
        self.shape = (len(contacts), 6 if any(c.frame for c in contacts) else 3)   # f's
        self.tables = {}


def checked(robot, contacts):
    """(``check_contacts(robot, contacts)``, its ``ContactSet``, or None without a kernel).
    A list or tuple of contacts is remembered per robot by the identities of its
    ``Contact`` objects (frozen, and kept alive by the memo, so that no identity is reused
    while remembered): a set is checked once (up to ``SETS`` sets, then the memo starts
    over)."""
    e = _entry(robot)
    if e is None or type(contacts) not in (list, tuple):
        return check_contacts(robot, contacts), None
    key = tuple(map(id, contacts))
    known = e.sets.get(key)
    if known is None:
        checked_ = check_contacts(robot, contacts)       # raises naming a bad contact
        if len(e.sets) >= SETS:
            e.sets.clear()
        known = e.sets[key] = (checked_, ContactSet(checked_, e))
    return known


def numbers(mu, tolerance, max_iterations, kp, kd, direct):
    """The kernel's settings array (columns MU .. DIRECT)."""
    return np.array([mu, tolerance, max_iterations, kp, kd, direct], dtype=float)


def solve(robot, q, v, tau, cset, num, kp):
    """(a, f) of one state by the compiled kernel, or None: no kernel for this robot
    (``cset`` None), arguments other than float64 vectors of the robot's lengths (q, v,
    and tau (nv,) or a floating base's joint torques), or a status other than OK (the
    reference path then answers, or raises naming the cause). ``cset``: ``checked``'s;
    ``num``: ``numbers``; ``kp``: Baumgarte's position gain."""
    if cset is None:
        return None
    e = cset.robot
    if e.kernel is None:
        e.kernel = kernel(e.kind)
    folded = kp == 0.0 and not cset.loops       # jacobians.contact_rows' test
    table = cset.tables.get(folded)
    if table is None:
        table = cset.tables[folded] = contact_table(robot, cset.contacts, folded)
    a, F = np.empty(e.nv), np.empty(cset.shape)
    if e.kernel(e.Pd, e.Pk, q, v, tau, table, num, e.flags, a, F) != OK:
        return None
    return a, F
