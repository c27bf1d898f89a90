"""Charts of a robot's configuration space: what an integrator needs to step q when q does not
live in R^nv (a floating base's unit quaternion). The robot says which chart it has
(``robot.chart``); ``sim/group.py`` integrates in it without asking what kind of robot it is.

A chart around a reference configuration q_ref gives coordinates phi (nv,) with

    q = q(q_ref, phi),   d phi/dt = C(phi) v

(Munthe-Kaas' RKMK idea: a Lie group's ODE as an ODE in R^nv, re-centred as it goes; Hairer,
Lubich & Wanner, *Geometric Numerical Integration*, 2006, Sec. IV.8). The joints' coordinates
of phi are the joint positions themselves, so on R^n the chart is q = phi, C = 1.

A Lagrangian step in the chart (the momentum form of symplectic Euler) needs more of C: at the
centre (``at_centre(q)``, made once a step) C(0) v, C(0)^-T f on a force (or a momentum) and
C(0)^T pi; C(phi)^T pi elsewhere; and the chart's part of dT/dphi at phi = 0 (T = 1/2 v^T M v
with v = C^-1 phi': what C's dependence on phi adds to ``robot.kinetic_energy_gradient``).
Each method says its formula once.
"""
import math

import numpy as np

from ..algorithms._batch import skew
from ..algorithms.floating import quaternion_matrix


class Euclidean:
    """R^n: q = phi, C = 1 (a fixed base: the joints are the coordinates)."""

    group = "R^n"
    base_names = ((), ())    # q's and v's coordinates before the joints': none

    def centre(self, q):
        """phi of q in the chart around q itself: q."""
        return q.copy()

    def far(self, phi):
        """Whether phi is far enough from the centre to re-centre the chart: never."""
        return False

    def point(self, q_ref, phi):
        """q(phi)."""
        return phi.copy()

    def rate(self, q, phi, v):
        """d phi/dt = v."""
        return v.copy()

    def at_centre(self, q):
        """C(0) = 1."""
        return IDENTITY

    def transposed(self, q, phi, pi):
        """C(phi)^T pi = pi."""
        return pi

    def gradient(self, v, h):
        """The chart's part of dT/dphi at phi = 0: none."""
        return np.zeros(v.shape[0])


class FreeFlyer:
    """SE(3) x R^n as SO(3) x R^3 x R^n, q = [x, y, z, qx, qy, qz, qw, joints], v = [v_O;
    omega; qd] in the base frame (``algorithms/floating.py``), in the coordinates

        q(phi) = [p_ref + dp, quat_ref (x) Exp(dtheta), joints],   phi = [dp; dtheta; joints]
        d(dp)/dt = R v_O,   d(dtheta)/dt = J_r(dtheta)^-1 omega,   d(joints)/dt = qd

    so C(phi) = diag(R(q), J_r(dtheta)^-1, 1). J_r: the right Jacobian of SO(3) (Chirikjian,
    *Stochastic Models, Information Theory, and Lie Groups*, vol. 2, 2011, Sec. 10.2),
    J_r^-1 = 1 + [x]/2 + (1/t^2 - (1 + cos t) / (2 t sin t)) [x]^2, x = dtheta, t = |x|.
    The pose comes out of the exponential map, so the quaternion has unit length to
    round-off; the chart is singular at |dtheta| = 2 pi, so integrators re-centre it."""

    group = "SE(3)"
    base_names = (("base_x", "base_y", "base_z", "base_qx", "base_qy", "base_qz", "base_qw"),
                  ("base_vx", "base_vy", "base_vz", "base_wx", "base_wy", "base_wz"))
    LIMIT = 1.0          # rad: ``far`` beyond this turn, well short of the singularity

    def centre(self, q):
        """phi of q in the chart around q itself: [0; 0; joints]."""
        return np.concatenate([np.zeros(6), q[7:]])

    def far(self, phi):
        """Whether the turn |dtheta| exceeds LIMIT (an adaptive run then re-centres)."""
        return bool(np.linalg.norm(phi[3:6]) > self.LIMIT)

    def point(self, q_ref, phi):
        """q(phi), the quaternion product in Python floats (one state)."""
        x, y, z = phi[3:6].tolist()
        t = math.sqrt(x * x + y * y + z * z)
        k = 0.5 - t * t / 48.0 if t < 1e-4 else math.sin(0.5 * t) / t     # sin(t/2) / t
        bx, by, bz, bw = k * x, k * y, k * z, math.cos(0.5 * t)        # Exp(dtheta) [x, y, z, w]
        ax, ay, az, aw = q_ref[3:7].tolist()
        quat = [aw * bx + bw * ax + ay * bz - az * by, aw * by + bw * ay + az * bx - ax * bz,
                aw * bz + bw * az + ax * by - ay * bx, aw * bw - ax * bx - ay * by - az * bz]
        nrm = math.sqrt(sum(c * c for c in quat))
        q = np.empty(q_ref.shape[0])
        q[:3] = q_ref[:3] + phi[:3]
        q[3:7] = [c / nrm for c in quat]
        q[7:] = phi[6:]
        return q

    def rate(self, q, phi, v):
        """d phi/dt = C(phi) v at q = q(phi)."""
        x1, x2, x3 = phi[3:6].tolist()
        t = math.sqrt(x1 * x1 + x2 * x2 + x3 * x3)
        k = 1.0 / 12.0 if t < 1e-4 else 1.0 / t**2 - (1.0 + math.cos(t)) / (2.0 * t * math.sin(t))
        u1, u2, u3, w1, w2, w3 = v[:6].tolist()
        c1, c2, c3 = x2 * w3 - x3 * w2, x3 * w1 - x1 * w3, x1 * w2 - x2 * w1         # x x w
        d1, d2, d3 = x2 * c3 - x3 * c2, x3 * c1 - x1 * c3, x1 * c2 - x2 * c1         # x x (x x w)
        x, y, z, s = q[3:7].tolist()
        out = np.empty(v.shape[0])
        out[0] = (1 - 2 * (y * y + z * z)) * u1 + 2 * (x * y - z * s) * u2 + 2 * (x * z + y * s) * u3
        out[1] = 2 * (x * y + z * s) * u1 + (1 - 2 * (x * x + z * z)) * u2 + 2 * (y * z - x * s) * u3
        out[2] = 2 * (x * z - y * s) * u1 + 2 * (y * z + x * s) * u2 + (1 - 2 * (x * x + y * y)) * u3
        out[3:6] = w1 + 0.5 * c1 + k * d1, w2 + 0.5 * c2 + k * d2, w3 + 0.5 * c3 + k * d3
        out[6:] = v[6:]
        return out

    def at_centre(self, q):
        """C(0) = diag(R, 1, 1) at q (J_r(0) = 1)."""
        return Rotated(rotation(q))

    def transposed(self, q, phi, pi):
        """C(phi)^T pi = [R(q)^T pi_lin; J_r(dtheta)^-T pi_ang; pi_joints], q = q(phi)."""
        return np.concatenate([rotation(q).T @ pi[:3],
                               np.linalg.solve(right_jacobian(phi[3:6]).T, pi[3:6]), pi[6:]])

    def gradient(self, v, h):
        """The chart's part of dT/dphi at phi = 0, h = M v: h_lin x v_O - omega x h_ang / 2
        for the turn (from R(phi) = R(q_ref) Exp(dtheta) and J_r = 1 - [dtheta]/2 + O(2)),
        nothing for the translation (T does not depend on it) and the joints."""
        out = np.zeros(v.shape[0])
        out[3:6] = np.cross(h[:3], v[:3]) - 0.5 * np.cross(v[3:6], h[3:6])
        return out


class Identity:
    """C(0) = 1: a vector, a covector and a transpose are what they act on."""

    def vector(self, v):
        return v

    def covector(self, f):
        return f

    def transposed(self, pi):
        return pi


class Rotated:
    """C(0) = diag(R, 1, 1) (a free-flyer chart at its centre, R the base's rotation)."""

    def __init__(self, R):
        self.R = R

    def vector(self, v):
        """C(0) v = [R v_O; omega; qd]."""
        return np.concatenate([self.R @ v[:3], v[3:]])

    covector = vector    # C(0)^-T f = C(0) f: R^-T = R

    def transposed(self, pi):
        """C(0)^T pi = [R^T pi_lin; pi_ang; pi_joints]."""
        return np.concatenate([self.R.T @ pi[:3], pi[3:]])


def rotation(q):
    """R (3, 3) of q's unit quaternion q[3:7] [x, y, z, w]: base axes to world axes."""
    return quaternion_matrix(q[None, 3:7])[0]


def right_jacobian(x):
    """J_r(x) of SO(3) = 1 - (1 - cos t)/t^2 [x] + (t - sin t)/t^3 [x]^2, t = |x|
    (Chirikjian 2011, Sec. 10.2): omega = J_r(dtheta) d(dtheta)/dt."""
    t = math.sqrt(float(x @ x))
    a, b = (0.5 - t * t / 24.0, 1.0 / 6.0 - t * t / 120.0) if t < 1e-4 else (
        (1.0 - math.cos(t)) / t**2, (t - math.sin(t)) / t**3)
    X = skew(x)
    return np.eye(3) - a * X + b * (X @ X)


EUCLIDEAN, FREE_FLYER, IDENTITY = Euclidean(), FreeFlyer(), Identity()
