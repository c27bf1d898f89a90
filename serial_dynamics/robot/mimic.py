"""Mimic joints: the reduced system of a chain whose joints follow others.

A joint with ``<mimic joint="leader" multiplier="m" offset="o">`` moves as
q_i = m q_leader + o. With G the constant (n, k) matrix of the map from the k independent
joints to all n joints of the chain (``Model.mimic_matrix``), q_all = G q + o,
qd_all = G qd and qdd_all = G qdd (G constant: no velocity-product term), and by virtual
work the reduced system is

    tau = G^T tau_all(q_all, qd_all, qdd_all)       M = G^T M_all G       C = G^T C_all G

(Featherstone 2008, Sec. 3.2: a constraint q_all = G q). ``Mimic`` holds what
``MimicRobot`` (``facade.py``: ``class MimicRobot(Mimic, Robot)``) overrides: every method
maps its inputs to all joints, calls the chain's algorithms (compiled or reference,
``super()``) on them, and maps the results back; forward dynamics solves
(G^T M G) qdd = tau - G^T b. On the compiled backend a single state's inverse dynamics,
bias torques, M and forward dynamics are one call each (``core/mimic.py``, with the maps and
the reduced tree of ``mimic_layout``), and so is a batch of them (each state as alone,
split over the cores). Its coordinates, names, limits and dissipation are the
independent joints'; a mimic joint's viscous and Coulomb friction act on its leader as
m^2 beta and |m| tau_c (exact: its friction torque, times m by virtual work).
"""
from __future__ import annotations

import numpy as np

from ..algorithms import floating as fb
from ..algorithms._batch import as_batch
from ..core import OK
from ..core import flags as F
from ..core.cache import njit_in
from ..core.floating import GW
from ..core.layout import PARENT, WIDTH
from ..core.mimic import (FM, FT, FW, IW, NF, NPAIRS, PAIR, PI, PJ, PM, PSI, PSJ, QMUL,
                          QOFF, QSRC, SPARSE, VMUL, VSRC, reduce_mass, reduce_matrix,
                          reduce_vector, reduced_fd)
from ..model.dissipation import Dissipation
from . import derivatives, regressor
from .wrenches import generalized_forces
from .batches import kernel_rows, run_split
from .common import FD_METHODS, PARALLEL_MIN
from .common import into as _into


class _Independent:
    """What ``as_batch`` needs to validate the reduced coordinates: dof and names."""

    def __init__(self, names):
        self.dof, self.joint_names = len(names), tuple(names)


def _with_base(nb, src, m, o):
    """The maps (src, m, o) of x_all = G x + o with ``nb`` base coordinates first, each
    its own image (a floating base: 7 in q, 6 in v; a fixed base: none)."""
    return (np.r_[np.arange(nb), nb + src].astype(np.int64), np.r_[np.ones(nb), m],
            np.r_[np.zeros(nb), o])


class Mimic:
    """What a chain with mimic joints overrides: its coordinates are the independent joints
    (see the module docstring). ``sd.load_urdf`` and ``sd.Robot(model)`` return a
    ``MimicRobot`` for a model with mimic joints."""

    def __init__(self, model, dissipation=None, backend=None, **kwargs):
        self._G, self._o = model.mimic_matrix
        self._src = np.argmax(self._G != 0.0, axis=1)     # joint i follows coordinate src[i]
        self._m = self._G[np.arange(model.dof), self._src]  # with multiplier m[i] (1: itself)
        # the same maps on a whole state: a floating base's 7 (q) and 6 (v) coordinates first
        bq, bv = (7, 6) if model.floating else (0, 0)
        self._bq, self._bv = bq, bv
        self._q_map = _with_base(bq, self._src, self._m, self._o)
        self._v_map = _with_base(bv, self._src, self._m, np.zeros(model.dof))
        self._ind = np.r_[np.arange(bv), bv + model.independent].astype(np.int64)
        fi = np.flatnonzero(model.mimic_leader >= 0)         # the followers, in chain order:
        self._fi, self._fk, self._fm = bv + fi, bv + self._src[fi], self._m[fi]
        self._view = _Independent([model.joint_names[i] for i in model.independent])
        k = len(model.independent)           # name -> (the reduced shape, the map to all joints)
        self._maps = {"q": ((k + bq,), self._q_map), "qd": ((k + bv,), self._v_map),
                      "qdd": ((k + bv,), self._v_map), "tau": ((k + bv,), None)}
        if dissipation is None:
            dissipation = _reduced_dissipation(model, self._G, self._view.joint_names)
        super().__init__(model, dissipation, backend, **kwargs)
        # the compiled reduced system (core/mimic.py): the maps, the reduced tree; its
        # entry points run the whole model's kernels on P (a floating base's instantaneous
        # chain or tree)
        self._Gm, self._parent_r = mimic_layout(
            model, self._q_map, self._v_map, self._ind, (self._fi, self._fk, self._fm),
            self._v_parent_whole)
        self._Pk = self._chain if model.floating else self._P
        self._gwk = self._gw if model.floating else np.zeros(GW)
        self._rest = np.zeros(self.nv)     # gravity_torques' rates (read, never written)
        # a batch of inverse dynamics (bias, gravity torques) through the whole model's batch
        # kernel in SIMD lanes between NumPy's gather and sum (``_all``, ``_reduce``), where it
        # has one: 646 -> 221-264 ns a state (the Panda with its fingers) and 1110 -> 489-505
        # (Baxter with its grippers) against each state in one compiled call (``_batch``),
        # 10,000 states, one core, 2026-11-29. On a floating base's tree (the full Talos) the
        # two measured the same (2749-2936 against 2646-2886 ns: the NumPy gather and sums of
        # 50 coordinates cost what the lanes save), and for M and forward dynamics (whose
        # whole-model M is written out and read back) ``_batch`` is faster. Each row is its
        # single call's bits either way (test_mimic.py).
        self._whole_lanes = not (model.floating and not model.is_chain)

    # ------------------------------------------------------------- description
    dof = property(lambda self: self._view.dof)
    joint_names = property(lambda self: list(self._view.joint_names))
    joint_types = property(lambda self: [self.model.joint_types[i] for i in self.model.independent])
    lower = property(lambda self: self.model.lower[self.model.independent])
    upper = property(lambda self: self.model.upper[self.model.independent])
    velocity_limit = property(lambda self: self.model.velocity_limit[self.model.independent])
    effort_limit = property(lambda self: self.model.effort_limit[self.model.independent])
    armature = property(lambda self: (self._G ** 2).T @ self.model.armature,
                        doc="the reduced armature: sum of m^2 I_a over each joint's followers")
    all_joint_names = property(lambda self: list(self.model.joint_names),
                               doc="every joint of the model, mimic joints included")

    nq = property(lambda self: self._view.dof + self._bq, doc="the length of q (reduced)")
    nv = property(lambda self: self._view.dof + self._bv, doc="the length of qd (reduced)")

    def all_joint_positions(self, q):
        """Positions of every joint of the chain (e.g. for robot_state_publisher)."""
        return self._expand(np.asarray(q, dtype=float), self._o)

    def all_joint_velocities(self, qd):
        return self._expand(np.asarray(qd, dtype=float), 0.0)

    # G x and G^T y as gathers and ordered sums (not matrix products, whose summation order
    # BLAS may change with the shape): a state gives the same bits alone or in a batch. One
    # state goes through small compiled loops (_gather; core/mimic.py's reduce_vector and
    # reduce_matrix), a batch through the same operations in NumPy; the dynamics (one state
    # or a batch) through compiled calls (core/mimic.py's entry points).
    def _expand(self, x, offset):
        """G x + offset over the last axis (the joints): x[src] m + offset."""
        return x[..., self._src] * self._m + offset

    def _reduce(self, y):
        """G^T y over the last axis (v's coordinates): y[independent] + sum of m y[follower],
        in joint order."""
        if y.ndim == 1:
            out = np.empty(self.nv)
            reduce_vector(self._Gm, y, out)
            return out
        out = y[..., self._ind].copy()
        for i, k, m in zip(self._fi, self._fk, self._fm):
            out[..., k] += m * y[..., i]
        return out

    def _reduce2(self, M):
        """G^T M G (the same operations, in the same order, for one matrix or a stack)."""
        if M.ndim == 2:
            k = self.nv
            A, out = np.empty((M.shape[0], k)), np.empty((k, k))
            reduce_matrix(self._Gm, M, A, out)
            return out
        return np.swapaxes(self._reduce(np.swapaxes(self._reduce(M), -1, -2)), -1, -2)

    def _lean(self, named):
        """Every joint's arrays of one state whose arrays are float64, C-contiguous, 1-D of
        their lengths and finite (torques: None); else None (``_all``'s general path)."""
        full = []
        for name, x in named:
            size, mp = self._maps[name]
            if type(x) is not np.ndarray or x.shape != size or x.dtype != _F8 \
                    or not x.flags.c_contiguous:
                return None
            if mp is None:
                if _not_finite(x):
                    return None
                full.append(None)
            else:
                f = np.empty(mp[0].shape[0])
                if _gather(mp[0], mp[1], mp[2], x, f):
                    return None
                full.append(f)
        return full

    def _all(self, *named):
        """Validate the reduced states together (as ``as_batch``: errors name the culprit);
        return (single, the reduced arrays, every joint's arrays): q_all = G q + o, rates
        G x (torques are not expanded: None). A single state's are 1-D arrays (the compiled
        single-state path); a batch's (N, k) and (N, n)."""
        full = self._lean(named)                          # one state: the lean path
        if full is not None:
            return True, [x for _, x in named], full
        maps = [self._maps[name][1] for name, _ in named]
        single, reduced = self._reduced(named)
        reduced = [x[0] if single else x for x in reduced]
        full = [None if mp is None else np.ascontiguousarray(x[..., mp[0]] * mp[1] + mp[2])
                for mp, x in zip(maps, reduced)]
        return single, reduced, full

    def _reduced(self, named):
        """(single, the reduced states as (N, .) arrays), validated (errors name the
        culprit); a floating base's quaternion as given (the kernels normalize it)."""
        if self._bq:                                     # a floating base (q: k + 7, v: k + 6)
            d = dict(named)
            single, q, _, rest = fb.as_batch(self._view, d.pop("q", None), False, **d)
            return single, [q if name == "q" else rest[name] for name, _ in named]
        return as_batch(self._view, *named)             # a batch, other types, or a NaN/Inf

    def _batch(self, kernel, named, extra, shape):
        """A batch through the compiled ``kernel`` (core/mimic.py's ``mimic_*_batch``: each
        state the single call's bits), split over the cores; the result of shape (N, *shape)
        or, for one state given otherwise (a list, another dtype), shape."""
        single, reduced = self._reduced(named)
        N = max(x.shape[0] for x in reduced)
        out = np.empty((N,) + shape)
        rows = [kernel_rows(x) for x in reduced] + ([self._gwk[None]] if extra else [])
        run_split(kernel, self._Pk, N, rows, (self._Gm,) + extra, (out,), PARALLEL_MIN)
        return out[0] if single else out

    # ------------------------------------------------------------- dynamics
    def inverse_dynamics(self, q, qd, qdd, wrench=None, base_motion=None, out=None,
                         wrenches=None):
        if wrenches is not None:     # wrenches on links: - sum_k J_k^T w_k (robot/wrenches.py)
            return _into(out, self.inverse_dynamics(q, qd, qdd, wrench, base_motion)
                         - generalized_forces(self, q, wrenches))
        if self._k is not None and wrench is None and base_motion is None:   # one call
            o = _empty(self.nv) if out is None else out
            if self._k.mimic_rnea(self._Pk, self._Gm, q, qd, qdd, self._gwk, _QD_QDD, o) == OK:
                return o
            if not self._whole_lanes:
                return _into(out, self._batch(self._k.mimic_rnea_batch,
                                              (("q", q), ("qd", qd), ("qdd", qdd)),
                                              (_QD_QDD,), (self.nv,)))
        _, _, (q, qd, qdd) = self._all(("q", q), ("qd", qd), ("qdd", qdd))
        tau = super().inverse_dynamics(q, qd, qdd, wrench, base_motion)
        return _into(out, self._reduce(tau))             # tau = G^T tau_all

    def bias_torques(self, q, qd, wrench=None, base_motion=None, out=None, wrenches=None):
        if wrenches is not None:
            return _into(out, self.bias_torques(q, qd, wrench, base_motion)
                         - generalized_forces(self, q, wrenches))
        if self._k is not None and wrench is None and base_motion is None:
            o = _empty(self.nv) if out is None else out
            if self._k.mimic_rnea(self._Pk, self._Gm, q, qd, qd, self._gwk, F.QD, o) == OK:
                return o
            if not self._whole_lanes:
                return _into(out, self._batch(self._k.mimic_rnea_batch,
                                              (("q", q), ("qd", qd), ("qdd", qd)), (F.QD,),
                                              (self.nv,)))
        _, _, (q, qd) = self._all(("q", q), ("qd", qd))
        return _into(out, self._reduce(super().bias_torques(q, qd, wrench, base_motion)))

    def gravity_torques(self, q, out=None):
        if self._k is not None:          # mimic_rnea at zero rates (flags 0: neither read)
            rest = self._rest
            o = _empty(self.nv) if out is None else out
            if self._k.mimic_rnea(self._Pk, self._Gm, q, rest, rest, self._gwk, 0, o) == OK:
                return o
            if not self._whole_lanes:
                return _into(out, self._batch(self._k.mimic_rnea_batch,
                                              (("q", q), ("qd", rest), ("qdd", rest)), (0,),
                                              (self.nv,)))
        _, _, (q,) = self._all(("q", q))
        return _into(out, self._reduce(super().gravity_torques(q)))

    @property
    def _v_parent(self):            # G^T M G's zeros: the reduced tree (mimic_layout)
        return self._parent_r

    @property
    def _v_parent_whole(self):      # the whole model's M (the kind's own _v_parent)
        return super()._v_parent

    def mass_matrix(self, q, out=None):
        if self._k is not None:
            o = _empty((self.nv, self.nv)) if out is None else out
            if self._k.mimic_crba(self._Pk, self._Gm, q, o) == OK:
                return o
            return _into(out, self._batch(self._k.mimic_crba_batch, (("q", q),), (),
                                          (self.nv, self.nv)))
        _, _, (q,) = self._all(("q", q))
        return _into(out, self._reduce_mass(super().mass_matrix(q)))   # G^T M_all G

    def _reduce_mass(self, M):
        """G^T M G of one mass matrix or a stack, state by state as the single call
        (core/mimic.reduce_mass: on a tree from M's nonzeros)."""
        k, nw = self.nv, M.shape[-1]
        Mr = np.empty(M.shape[:-2] + (k, k))
        for Mk, ok in ((M, Mr),) if M.ndim == 2 else zip(M, Mr):
            reduce_mass(self._Gm, Mk, np.empty((nw, k)), ok)
        return Mr

    def coriolis_matrix(self, q, qd):
        _, _, (q, qd) = self._all(("q", q), ("qd", qd))
        return self._reduce2(super().coriolis_matrix(q, qd))

    def forward_dynamics(self, q, qd, tau, wrench=None, method="auto", base_motion=None,
                         out=None, wrenches=None):
        """qdd of the reduced system, (G^T M G) qdd = tau - G^T b, for every ``method``
        (the articulated-body recursion has no mimic constraint)."""
        if wrenches is not None:     # wrenches on links: tau + sum_k J_k^T w_k
            return _into(out, self.forward_dynamics(
                q, qd, np.asarray(tau, dtype=float) + generalized_forces(self, q, wrenches),
                wrench, method, base_motion))
        if method not in FD_METHODS:
            raise ValueError(f"forward-dynamics method {method!r} unknown; use one of "
                             f"{FD_METHODS}")
        if self._k is not None and wrench is None and base_motion is None:   # one call
            o = _empty(self.nv) if out is None else out
            if self._k.mimic_fd(self._Pk, self._Gm, q, qd, tau, self._gwk, 0, o) == OK:
                return o
            return _into(out, self._batch(self._k.mimic_fd_batch,
                                          (("q", q), ("qd", qd), ("tau", tau)), (0,),
                                          (self.nv,)))
        single, (_, _, tau), (q, qd, _) = self._all(("q", q), ("qd", qd), ("tau", tau))
        M, b = super().mass_matrix(q), super().bias_torques(q, qd, wrench, base_motion)
        o = np.empty(np.shape(tau))
        for Mk, bk, tk, ok in ((M, b, tau, o),) if single else zip(M, b, tau, o):
            reduced_fd(self._Gm, Mk, bk, tk, ok)      # G^T M G and G^T b, factored, solved
        return _into(out, o)

    def kernels(self, batch=False, kinematics=False):
        return super().kernels(batch, kinematics) + (_MIMIC_KERNELS if self._k is not None else ())

    # ------------------------------------------------------------- kinematics, energy
    def forward_kinematics(self, q, link=None):
        return super().forward_kinematics(self._all(("q", q))[2][0], link)

    def jacobian(self, q, link=None):
        return self._reduce(super().jacobian(self._all(("q", q))[2][0], link))

    def frame_acceleration(self, q, qd, qdd, link=None):
        """The whole model's at q_all = G q + o, qd_all = G qd, qdd_all = G qdd (with
        J_r = J_all G: J_r qdd + J-dot_r qd = J_all qdd_all + J-dot_all qd_all)."""
        if qdd is None:
            qdd = np.zeros(np.shape(qd))
        _, _, (q, qd, qdd) = self._all(("q", q), ("qd", qd), ("qdd", qdd))
        return super().frame_acceleration(q, qd, qdd, link)

    def kinetic_energy(self, q, qd):
        """T = 1/2 qd^T (G^T M G) qd (J)."""
        single, (_, qd), (q, _) = self._all(("q", q), ("qd", qd))
        M = self._reduce_mass(super().mass_matrix(q))
        return 0.5 * np.einsum("...i,...ij,...j->...", qd, M, qd)

    def potential_energy(self, q):
        return super().potential_energy(self._all(("q", q))[2][0])

    def center_of_mass(self, q):
        return super().center_of_mass(self._all(("q", q))[2][0])

    def centroidal_momentum(self, q, qd):
        _, _, (q, qd) = self._all(("q", q), ("qd", qd))
        return super().centroidal_momentum(q, qd)

    def kinetic_energy_gradient(self, q, qd):
        """dT_r/dq_r = G^T dT/dq(G q_r + o, G qd_r) (a floating base's rows: zeros)."""
        _, _, (q, qd) = self._all(("q", q), ("qd", qd))
        return self._reduce(super().kinetic_energy_gradient(q, qd))

    compiled_chain = None    # sim/'s whole-step kernels know no mimic constraint

    # ------------------------------------------------------------- identification, derivatives
    def regressor(self, q, qd, qdd, friction=False, armature=None):
        """G^T Y_all: every body's columns through the reduction (tau = G^T tau_all), then the
        friction columns of the independent joints."""
        friction = regressor.check_friction(friction)
        arm = regressor.armature_on(self, armature)
        _, (q, qd, qdd), (qa, qda, qdda) = self._all(("q", q), ("qd", qd), ("qdd", qdd))
        Y = regressor.rigid_columns(self, qa, qda, qdda, arm)
        Y = np.swapaxes(self._reduce(np.swapaxes(Y, -1, -2)), -1, -2)     # G^T Y_all
        return np.concatenate([Y, regressor.friction_columns(qd)], axis=-1) if friction else Y

    def inverse_dynamics_derivatives(self, q, qd, qdd, wrench=None, base_motion=None):
        """G^T (d tau_all/d x_all) G, x = q, qd."""
        _, _, (qa, qda, qdda) = self._all(("q", q), ("qd", qd), ("qdd", qdd))
        dq, dqd = derivatives.chain_derivatives(self, qa, qda, qdda, wrench, base_motion, True)
        return self._reduce2(dq), self._reduce2(dqd)

    def forward_dynamics_derivatives(self, q, qd, tau, wrench=None, base_motion=None):
        """d qdd/d x = -(G^T M G)^-1 G^T (d tau_all/d x_all) G at qdd = the reduced forward
        dynamics, and (G^T M G)^-1 (implicit function theorem on the reduced system)."""
        _, (q, qd, tau), _ = self._all(("q", q), ("qd", qd), ("tau", tau))
        qdd = self.forward_dynamics(q, qd, tau, wrench, base_motion=base_motion)
        dq, dqd = self.inverse_dynamics_derivatives(q, qd, qdd, wrench, base_motion)
        Minv = np.linalg.inv(self.mass_matrix(q))
        Minv = 0.5 * (Minv + np.swapaxes(Minv, -1, -2))
        return -Minv @ dq, -Minv @ dqd, Minv


_F8 = np.dtype(np.float64)
_QD_QDD = F.QD | F.QDD
_empty = np.empty
_MIMIC_KERNELS = ("mimic_rnea", "mimic_crba", "mimic_fd")


def mimic_layout(model, q_map, v_map, ind, followers, whole):
    """(Gm, parent_r): core/mimic.py's layout of the maps q_all = G q + o and x_all = G x over
    whole states (``Mimic``'s: (src, m, o) of q and of the rates, the independent coordinates
    ``ind``, the followers (whole coordinate, reduced one, multiplier)), and the reduced tree
    from the whole model's parents ``whole``: parent_r[k], the parent of reduced coordinate
    k. G^T M G couples k and l when a coordinate of k's and one of l's are on one path; where
    each coordinate's coupled lower ones are its ancestors through parent_r, L^T D L on
    parent_r has no fill-in (SPARSE: a tree's; a chain keeps dense Cholesky, and its bits).
    Else parent_r = k - 1 (dense)."""
    (qsrc, qmul, qoff), (vsrc, vmul, _), (fw, ft, fm) = q_map, v_map, followers
    nq, nv, k, nf = qsrc.size, vsrc.size, ind.size, fw.size
    Gm = np.zeros((nq, WIDTH))
    Gm[:, QSRC], Gm[:, QMUL], Gm[:, QOFF] = qsrc, qmul, qoff
    Gm[:nv, VSRC], Gm[:nv, VMUL] = vsrc, vmul
    Gm[:k, IW] = ind
    Gm[:nf, FW], Gm[:nf, FT], Gm[:nf, FM] = fw, ft, fm
    coupled = np.zeros((k, k), dtype=bool)        # whole coordinates on one path, reduced
    for i in range(nv):
        j = i
        while j >= 0:
            coupled[vsrc[i], vsrc[j]] = coupled[vsrc[j], vsrc[i]] = True
            j = whole[j]
    parent_r = np.array([max((l for l in range(r) if coupled[r, l]), default=-1)
                         for r in range(k)], dtype=np.int64)
    ok = not model.is_chain
    for r in range(k):
        up, l = set(), parent_r[r]
        while l >= 0:
            up.add(l)
            l = parent_r[l]
        ok &= all(l in up for l in range(r) if coupled[r, l])
    if not ok:
        parent_r = np.arange(k) - 1
    Gm[:k, PARENT] = parent_r
    follows = np.zeros(nv, dtype=bool)
    follows[fw] = True
    pairs = []
    for i in range(nv if ok else 0):               # M's nonzeros with a follower: i and
        j = i                                      # its ancestors j
        while j >= 0:
            if follows[i] or follows[j]:
                pairs.append((i, j, vmul[i] * vmul[j], vsrc[i], vsrc[j]))
            j = whole[j]
    flat = np.zeros(-(-PAIR * len(pairs) // WIDTH) * WIDTH)    # packed, PAIR numbers each
    rows = flat[:PAIR * len(pairs)].reshape(-1, PAIR)
    index = rows.view(np.int64)                    # the indices as int64 bit patterns
    for p, (i, j, mm, si, sj) in enumerate(pairs):
        index[p, [PI, PJ, PSI, PSJ]] = i, j, si, sj
        rows[p, PM] = mm
    head = np.zeros((1, WIDTH))
    head[0, [SPARSE, NF, NPAIRS]] = float(ok), nf, len(pairs)
    return np.vstack([Gm, flat.reshape(-1, WIDTH), head]), parent_r


@njit_in("robot")
def _not_finite(x):
    """1 if x has a NaN/Inf, else 0."""
    bad = 0
    for i in range(x.shape[0]):
        bad |= not (x[i] * 0.0 == 0.0)
    return bad


@njit_in("robot")
def _gather(src, m, o, x, out):
    """out = x[src] m + o (G x + o); returns 1 if x has a NaN/Inf, else 0."""
    bad = 0
    for i in range(out.shape[0]):
        v = x[src[i]]
        bad |= not (v * 0.0 == 0.0)
        out[i] = v * m[i] + o[i]
    return bad


def _reduced_dissipation(model, G, names):
    """Joint friction of the independent joints: a mimic joint's viscous beta and Coulomb
    tau_c act on its leader as m^2 beta and |m| tau_c."""
    zero = np.zeros(len(names))
    return Dissipation(tuple(names), (G ** 2).T @ model.damping, np.abs(G).T @ model.friction,
                       zero, zero)

