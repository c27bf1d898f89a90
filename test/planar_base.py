"""A mobile manipulator on a URDF ``planar`` joint, and Pinocchio's answers for it.

The URDF: example-robot-data's UR5 on a 40 kg base that moves in the floor plane through
a planar joint ``base_joint`` (axis z, placed off the map's origin). Our model holds it as
base_joint/x, base_joint/y (prismatic) and base_joint/theta (continuous): q = [x, y,
theta, arm], qd = [xd, yd, thetad, arm]. Pinocchio's ``JointModelPlanar`` has q = [x, y,
cos theta, sin theta, arm] and v = T(theta) qd with T = diag(R(theta)^T, 1, 1_6): its
linear velocity in the joint's own axes. So, with v = T qd and a = T qdd + thetad T' qd,

    tau(q, qd, qdd) = T^T tau_pin(q_pin, v, a),       M = T^T M_pin T,

and the chain rule gives d tau/d q, d tau/d qd from Pinocchio's derivatives (its d/dq is
along the tangent T dq); forward dynamics and its derivatives follow from
M qdd_dot = tau - b (d qdd/d x = -M^-1 d tau/d x at qdd = FD)."""
import re

import numpy as np

from pin_reference import erd, pin

BASE = """
  <link name="map"/>
  <joint name="base_joint" type="planar">
    <parent link="map"/>
    <child link="mobile_base"/>
    <origin xyz="0.3 -0.2 0.1" rpy="0 0 0.4"/>
    <axis xyz="0 0 1"/>
    <limit effort="200" velocity="1.5"/>
  </joint>
  <link name="mobile_base">
    <inertial>
      <origin xyz="0.05 -0.02 0.15" rpy="0 0 0"/>
      <mass value="40.0"/>
      <inertia ixx="1.1" ixy="0.02" ixz="-0.01" iyy="1.6" iyz="0.03" izz="2.1"/>
    </inertial>
  </link>
"""


def mobile_manipulator_urdf():
    """The UR5 of example-robot-data mounted on a planar base (module docstring)."""
    text = open(erd("ur_description/urdf/ur5_robot.urdf")).read()
    text = text.replace('<link name="world"/>', BASE)
    text = re.sub(r'(<joint name="world_joint" type="fixed">\s*<parent link=)"world"',
                  r'\1"mobile_base"', text)
    return text


def _T(theta):
    """T(theta) and its first two derivatives, 9 x 9 (the arm's block the identity)."""
    c, s = np.cos(theta), np.sin(theta)
    T, dT, ddT = np.eye(9), np.zeros((9, 9)), np.zeros((9, 9))
    T[:2, :2] = [[c, s], [-s, c]]              # R(theta)^T
    dT[:2, :2] = [[-s, c], [-c, -s]]
    ddT[:2, :2] = [[-c, -s], [s, -c]]
    return T, dT, ddT


class PlanarPinocchio:
    """Pinocchio's planar-joint model of ``mobile_manipulator_urdf`` and our quantities
    from it (module docstring)."""

    def __init__(self, path, robot):
        self.model = pin.buildModelFromUrdf(path)
        assert self.model.joints[1].shortname() == "JointModelPlanar", self.model.joints[1]
        self.model.gravity.linear[:] = robot.gravity
        self.data = self.model.createData()

    @staticmethod
    def q(q):
        return np.concatenate([q[:2], [np.cos(q[2]), np.sin(q[2])], q[3:]])

    def _maps(self, q, qd, qdd):
        T, dT, ddT = _T(q[2])
        return T, dT, ddT, T @ qd, T @ qdd + qd[2] * dT @ qd

    def inverse_dynamics(self, q, qd, qdd):
        T, _, _, v, a = self._maps(q, qd, qdd)
        return T.T @ pin.rnea(self.model, self.data, self.q(q), v, a)

    def mass_matrix(self, q):
        T = _T(q[2])[0]
        M = pin.crba(self.model, self.data, self.q(q))
        M = np.triu(M) + np.triu(M, 1).T
        return T.T @ M @ T

    def forward_dynamics(self, q, qd, tau):
        T, dT, _, v, _ = self._maps(q, qd, qd)
        a = pin.aba(self.model, self.data, self.q(q), v, np.linalg.solve(T.T, tau))
        return np.linalg.solve(T, a - qd[2] * dT @ qd)

    def inverse_dynamics_derivatives(self, q, qd, qdd):
        """(d tau/d q, d tau/d qd) by the chain rule (module docstring)."""
        T, dT, ddT, v, a = self._maps(q, qd, qdd)
        tq, tv, M = pin.computeRNEADerivatives(self.model, self.data, self.q(q), v, a)
        M = np.triu(M) + np.triu(M, 1).T
        tau = pin.rnea(self.model, self.data, self.q(q), v, a)
        e = np.zeros(9)
        e[2] = 1.0                                        # d theta / d q (or qd)
        dv_dtheta = dT @ qd                               # d v / d theta at fixed qd
        da_dtheta = dT @ qdd + qd[2] * ddT @ qd
        d_dq = (np.outer(dT.T @ tau, e)
                + T.T @ (tq @ T + np.outer(tv @ dv_dtheta + M @ da_dtheta, e)))
        d_dqd = T.T @ (tv @ T + M @ (qd[2] * dT + np.outer(dT @ qd, e)))
        return d_dq, d_dqd

    def forward_dynamics_derivatives(self, q, qd, tau):
        """(d qdd/d q, d qdd/d qd, d qdd/d tau) at qdd = FD(q, qd, tau)."""
        qdd = self.forward_dynamics(q, qd, tau)
        d_dq, d_dqd = self.inverse_dynamics_derivatives(q, qd, qdd)
        Minv = np.linalg.inv(self.mass_matrix(q))
        return -Minv @ d_dq, -Minv @ d_dqd, Minv


def states(rng, N):
    """N states of the mobile manipulator: base anywhere, arm angles, brisk rates."""
    q = np.column_stack([rng.uniform(-2.0, 2.0, (N, 2)), rng.uniform(-np.pi, np.pi, (N, 7))])
    return q, rng.uniform(-1.5, 1.5, (N, 9)), rng.uniform(-3.0, 3.0, (N, 9))
