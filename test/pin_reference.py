"""Pinocchio as an oracle: the same chain, with the joints we hold locked at zero."""
import os
import sysconfig
import warnings

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")

ERD_ROOT = os.path.join(sysconfig.get_paths()["purelib"], "cmeel.prefix", "share",
                        "example-robot-data", "robots")


def erd(rel):
    """Path of a URDF shipped by the example-robot-data wheel."""
    path = os.path.join(ERD_ROOT, rel)
    if not os.path.isfile(path):
        pytest.skip(f"example-robot-data has no {rel}")
    return path


class PinReference:
    """Pinocchio model of the same chain, and conversions of our (q, qd) to its layout."""

    def __init__(self, robot, path):
        full = pin.buildModelFromUrdf(path)
        keep = set(robot.joint_names)
        lock = [full.getJointId(n) for n in full.names[1:] if n not in keep]
        self.model = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
        # our gravity is in the base frame; with base_link = root both frames agree
        self.model.gravity.linear[:] = robot.gravity
        self.data = self.model.createData()
        self.robot = robot
        self.jid = [self.model.getJointId(n) for n in robot.joint_names]
        self.iv = np.array([self.model.idx_vs[j] for j in self.jid])

    def q(self, q):
        return configuration(self.model, self.jid, q)

    def v(self, x):
        out = np.zeros(self.model.nv)
        out[self.iv] = x
        return out

    def rnea(self, q, qd, qdd, fext_tip=None):
        if fext_tip is None:
            return pin.rnea(self.model, self.data, self.q(q), self.v(qd), self.v(qdd))[self.iv]
        return pin.rnea(self.model, self.data, self.q(q), self.v(qd), self.v(qdd), fext_tip)[self.iv]

    def mass_matrix(self, q):
        M = pin.crba(self.model, self.data, self.q(q))
        M = np.triu(M) + np.triu(M, 1).T
        return M[np.ix_(self.iv, self.iv)]

    def gravity(self, q):
        return pin.computeGeneralizedGravity(self.model, self.data, self.q(q))[self.iv]

    def aba(self, q, qd, tau):
        return pin.aba(self.model, self.data, self.q(q), self.v(qd), self.v(tau))[self.iv]

    def coriolis_times_qd(self, q, qd):
        C = pin.computeCoriolisMatrix(self.model, self.data, self.q(q), self.v(qd))
        return (C @ self.v(qd))[self.iv]


def configuration(model, jid, q):
    """Pinocchio's configuration vector of ``model`` with our ``q`` on the joints ``jid``
    (the others, a free-flyer root included, at neutral)."""
    qp = pin.neutral(model)
    for k, j in enumerate(jid):
        i = model.idx_qs[j]
        if model.nqs[j] == 2:               # continuous joint: (cos, sin)
            qp[i:i + 2] = np.cos(q[k]), np.sin(q[k])
        else:
            qp[i] = q[k]
    return qp


def load(path, base=None, tip=None, **kw):
    import serial_dynamics as sd
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        return sd.load_urdf(path, base, tip, **kw)
