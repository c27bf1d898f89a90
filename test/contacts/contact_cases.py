"""The robots and the matching Pinocchio models the contact tests share: Solo12 on a free
flyer (its four feet) and the Panda arm without fingers on a fixed base (its hand), with a
tilted gravity so that every component is exercised, and Pinocchio's constraint models for
our contacts (``constraint``: LOCAL_WORLD_ALIGNED, so its forces are in world axes at the
contact point, as ours)."""
import warnings

import numpy as np

from pin_reference import PinReference, erd, pin

import serial_dynamics as sd

G_TILTED = np.array([0.8, -1.3, -9.7])
SOLO = "solo_description/robots/solo12.urdf"
PANDA = "panda_description/urdf/panda.urdf"
FEET = ["FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"]


def rel_err(a, b):
    return np.max(np.abs(np.asarray(a) - b)) / max(1.0, np.max(np.abs(b)))


class Solo:
    """Solo12 floating, ours and Pinocchio's free-flyer, and the maps between their states."""

    def __init__(self, gravity=G_TILTED):
        self.robot = sd.load_urdf(erd(SOLO), gravity=gravity, floating_base=True)
        self.pm = pin.buildModelFromUrdf(erd(SOLO), pin.JointModelFreeFlyer())
        self.pm.gravity.linear[:] = gravity
        self.pd = self.pm.createData()
        jid = [self.pm.getJointId(n) for n in self.robot.joint_names]
        self.iq = [self.pm.idx_qs[j] for j in jid]
        self.idx = list(range(6)) + [self.pm.idx_vs[j] for j in jid]

    def state(self, rng):
        quat = rng.standard_normal(4)
        q = np.concatenate([rng.uniform(-1, 1, 3), quat / np.linalg.norm(quat),
                            rng.uniform(-1.5, 1.5, self.robot.dof)])
        return q, rng.uniform(-1, 1, self.robot.nv)

    def q(self, q):
        qp = pin.neutral(self.pm)
        qp[:7], qp[self.iq] = q[:7], q[7:]
        return qp

    def v(self, x):
        out = np.zeros(self.pm.nv)
        out[self.idx] = x
        return out


class Panda:
    """The Panda without fingers on a fixed base (the fingers held), and Pinocchio's."""

    def __init__(self, gravity=G_TILTED):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", sd.HeldJointsWarning)
            self.robot = sd.load_urdf(erd(PANDA), tip_link="panda_hand", gravity=gravity)
        self.ref = PinReference(self.robot, erd(PANDA))
        self.pm, self.pd = self.ref.model, self.ref.data

    def state(self, rng):
        return self.robot.random_state(rng)

    def q(self, q):
        return self.ref.q(q)

    def v(self, x):
        return self.ref.v(x)


def constraint(pm, contact, ref=pin.ReferenceFrame.LOCAL_WORLD_ALIGNED, gains=None):
    """Pinocchio's RigidConstraintModel of our ``contact``: the link's frame moved to the
    point on joint 1; on joint 2 ``other_link``'s frame moved by the anchor (a loop), or the
    anchor in the world (a contact with the environment)."""
    kind = pin.ContactType.CONTACT_6D if contact.frame else pin.ContactType.CONTACT_3D
    f1 = pm.frames[pm.getFrameId(contact.link)]
    p1 = f1.placement * pin.SE3(np.eye(3), np.array(contact.point))
    A = np.eye(4)
    if contact.anchor is not None:
        A = np.array(contact.anchor) if contact.frame else np.r_[np.c_[np.eye(3), contact.anchor],
                                                                   [[0, 0, 0, 1]]]
    A = pin.SE3(A[:3, :3].copy(), A[:3, 3].copy())
    if contact.other_link is None:
        cm = pin.RigidConstraintModel(kind, pm, f1.parentJoint, p1, 0, A, ref)
    else:
        f2 = pm.frames[pm.getFrameId(contact.other_link)]
        cm = pin.RigidConstraintModel(kind, pm, f1.parentJoint, p1, f2.parentJoint,
                                      f2.placement * A, ref)
    if gains is not None:                      # Baumgarte's (kp, kd), Pinocchio 4's scalars
        cm.m_baumgarte_parameters.Kp, cm.m_baumgarte_parameters.Kd = gains
    return cm


def pin_constrained(case, q, v, tau, contacts, gains=None,
                    ref=pin.ReferenceFrame.LOCAL_WORLD_ALIGNED):
    """Pinocchio's constraintDynamics (proximal settings: accuracy 1e-14, mu 0): (a, forces)
    in our layout (forces in the ``ref`` frame of each contact)."""
    cms, cds = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
    for c in contacts:
        cms.append(constraint(case.pm, c, ref, gains))
        cds.append(cms[len(cms) - 1].createData())
    pin.initConstraintDynamics(case.pm, case.pd, cms, cds)
    a = pin.constraintDynamics(case.pm, case.pd, case.q(q), case.v(v), case.v(tau), cms, cds,
                               pin.ProximalSettings(1e-14, 0.0, 1))
    idx = case.idx if isinstance(case, Solo) else case.ref.iv
    return a[idx], case.pd.lambda_c.copy()
