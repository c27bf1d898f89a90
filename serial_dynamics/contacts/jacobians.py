"""The contacts' constraint rows at one state, from the facade's public kinematics: each
link's pose ``forward_kinematics``, Jacobian ``jacobian`` and bias acceleration
``jacobian_dot_qd`` (rows [linear; angular] of its frame origin, world axes on a floating
base, base axes on a fixed one), moved to the contact point.

Rows (``Rows``), world axes at the contact point P (Pinocchio's LOCAL_WORLD_ALIGNED):

- a point contact: the velocity of link's point P, minus that of ``other_link``'s anchor
  point; the constraint is on their classical accelerations (Pinocchio's CONTACT_3D);
- a frame contact: link's twist at P minus ``other_link``'s twist at P; the constraint is on
  the time derivative of that relative twist in link's frame (Pinocchio's CONTACT_6D:
  spatial accelerations, plus the cross term of the two bodies' motion).

``drift`` is the rows' acceleration at zero joint acceleration (J-dot v), ``velocity`` J v
and ``error`` the position error Baumgarte's term reads (zero where nothing anchors it).

Contacts with the environment whose position error is not read (``positions=False``) take
a faster path on the compiled backend: each contact point as a frame of its body, so the
kinematics kernels give its rows and bias acceleration directly (``world_rows``).
"""
from __future__ import annotations

import weakref
from typing import NamedTuple

import numpy as np
from scipy.spatial.transform import Rotation

from ..core import K, OK
from ..algorithms.kinematics import frame_of


class Rows(NamedTuple):
    J: np.ndarray          # (m, nv) the stacked contact Jacobian
    drift: np.ndarray      # (m,) J-dot v: the rows' acceleration at zero acceleration
    velocity: np.ndarray   # (m,) J v
    error: np.ndarray      # (m,) the position error (Baumgarte), zeros where not anchored


class _Link(NamedTuple):
    o: np.ndarray          # origin (3,)
    R: np.ndarray          # axes (3, 3)
    J: np.ndarray          # (6, nv)
    a: np.ndarray          # classical acceleration of the origin at zero a (3,)
    alpha: np.ndarray      # angular acceleration at zero a (3,)
    v: np.ndarray          # origin velocity (3,)
    w: np.ndarray          # angular velocity (3,)


def _link(robot, q, v, link, cache):
    """The kinematics of ``link`` at (q, v), world axes (None: the world itself)."""
    if link is None:
        return None
    if link not in cache:
        X = robot.forward_kinematics(q, link)
        J = robot.jacobian(q, link)
        A = robot.jacobian_dot_qd(q, v, link)
        cache[link] = _Link(X[:3, 3], X[:3, :3], J, A[:3], A[3:], J[:3] @ v, J[3:] @ v)
    return cache[link]


def _x(a):
    """[a]x, the cross-product matrix: [a]x b = a x b (np.cross costs ten times more here)."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def point_rows(J, r):
    """Linear rows of the body point at r (world axes) from the origin of the link whose
    Jacobian is J: v_o + w x r = J_v - [r]x J_w."""
    return J[:3] - _x(r) @ J[3:]



def _classical(L, r):
    """Classical acceleration bias of the body point at r: a_o + alpha x r + w x (w x r)."""
    wx = _x(L.w)
    return L.a + _x(L.alpha) @ r + wx @ (wx @ r)


def _spatial(L, r):
    """Spatial acceleration bias of the body at the point r from the origin, [linear;
    angular]: [a_o + alpha x r - w x v_o; alpha] (Featherstone 2008, Sec. 2.11)."""
    return np.concatenate([L.a + _x(L.alpha) @ r - _x(L.w) @ L.v, L.alpha])


def se3_log(R, p):
    """log6 of the pose (R, p): [rho; phi] with exp([rho; phi]^) = (R, p) (Eade, 'Lie groups
    for 2D and 3D transformations', the SE(3) logarithm: rho = V(phi)^-1 p)."""
    phi = Rotation.from_matrix(R).as_rotvec()
    t = np.linalg.norm(phi)
    # V^-1 = 1 - [phi]x / 2 + c [phi]x^2, c = (1 - t sin t / (2 (1 - cos t))) / t^2
    c = 1 / 12 + t * t / 720 if t < 1e-4 else (1 - t * np.sin(t) / (2 * (1 - np.cos(t)))) / t**2
    P = _x(phi)
    rho = p - 0.5 * P @ p + c * P @ (P @ p)
    return np.concatenate([rho, phi])


def _frame_error(c, L1, P, L2):
    """R1 log6(c2^-1 c1), world axes: Pinocchio's -log6(c1Mc2) rotated by c1's axes."""
    if c.other_link is None and c.anchor is None:
        return np.zeros(6)
    A = np.array(c.anchor) if c.anchor is not None else np.eye(4)
    R2, p2 = (A[:3, :3], A[:3, 3]) if L2 is None else (L2.R @ A[:3, :3], L2.o + L2.R @ A[:3, 3])
    e = se3_log(R2.T @ L1.R, R2.T @ (P - p2))
    return np.concatenate([L1.R @ e[:3], L1.R @ e[3:]])


_POINT_FRAMES = weakref.WeakKeyDictionary()     # robot -> {(link, point): (body, F)}


def point_frames(robot, contacts):
    """[(body, F)]: each contact's point as a frame of its body for the compiled kinematics
    kernels (``algorithms.kinematics.frame_of``'s placement [R, p] with p moved by R point, the
    link's axes kept), or None where those kernels do not answer (the NumPy backend, mimic
    joints: their Jacobians are reduced on the facade)."""
    if robot.packed_model is None or robot.model.has_mimic_joints:
        return None
    known = _POINT_FRAMES.setdefault(robot, {})
    out = []
    for c in contacts:
        key = (c.link, c.point)
        if key not in known:
            body, R, p = frame_of(robot.model, c.link)     # the link in its body's joint frame
            known[key] = (body, np.concatenate((R.ravel(), p + R @ np.asarray(c.point))))
        out.append(known[key])
    return out


def world_rows(robot, q, v, contacts, frames):
    """``Rows`` of contacts with the environment (no ``other_link``, no position error read)
    from the compiled kernels at each contact point's frame (``point_frames``): the point's
    Jacobian and classical bias acceleration come out of the kernel as a frame origin's."""
    nv, P = len(v), robot.packed_model
    m = sum(c.size for c in contacts)
    J, drift, zero = np.empty((m, nv)), np.empty(m), np.zeros(nv)
    Jc, A = np.empty((6, nv)), np.empty((1, 6))
    i = 0
    for c, (body, F) in zip(contacts, frames):
        if (K.frame_jacobian_one(P, q, body, F, Jc) != OK
                or K.frame_acceleration(P, q[None], v[None], zero[None], body, F, A) != OK):
            raise RuntimeError("a kinematics kernel refused validated states")
        if not c.frame:                                         # the point's classical a
            J[i:i + 3], drift[i:i + 3] = Jc[:3], A[0, :3]
            i += 3
            continue
        # a frame: the spatial acceleration at P, a_P - w x v_P (Featherstone 2008, Sec. 2.11)
        vP, w = Jc[:3] @ v, Jc[3:] @ v
        J[i:i + 6], drift[i:i + 3], drift[i + 3:i + 6] = Jc, A[0, :3] - _x(w) @ vP, A[0, 3:]
        i += 6
    return Rows(J, drift, J @ v, np.zeros(m))


def contact_rows(robot, q, v, contacts, positions=True):
    """``Rows`` of ``contacts`` (checked) at one state (q, v); ``positions=False``: the
    caller reads no position error (zeros where the compiled kernels answer)."""
    if not positions and all(c.other_link is None for c in contacts):
        frames = point_frames(robot, contacts)
        if frames is not None:
            return world_rows(robot, q, v, contacts, frames)
    cache, J, drift, error = {}, [], [], []
    nv = len(v)
    for c in contacts:
        L1 = _link(robot, q, v, c.link, cache)
        L2 = _link(robot, q, v, c.other_link, cache)
        r1 = L1.R @ np.asarray(c.point)
        P = L1.o + r1                                           # the contact point, world
        Jp = point_rows(L1.J, r1)
        if not c.frame:                                         # p1'' - p2'' (classical)
            anchor = np.zeros(3) if c.anchor is None and L2 is not None else c.anchor
            if L2 is None:
                J.append(Jp)
                drift.append(_classical(L1, r1))
                error.append(np.zeros(3) if anchor is None else P - np.asarray(anchor))
                continue
            r2 = L2.R @ np.asarray(anchor)
            J.append(Jp - point_rows(L2.J, r2))
            drift.append(_classical(L1, r1) - _classical(L2, r2))
            error.append(P - (L2.o + r2))
            continue
        # a frame: twists at P, V_i = [v_i(P); w_i], and spatial accelerations at P
        rows, acc = np.vstack([Jp, L1.J[3:]]), _spatial(L1, r1)
        if L2 is not None:
            r2 = P - L2.o
            rows = rows - np.vstack([point_rows(L2.J, r2), L2.J[3:]])
            v1, v2 = L1.v + _x(L1.w) @ r1, L2.v + _x(L2.w) @ r2
            # d/dt of the relative twist in link's frame: A1 - A2 + V1 x V2 (motion cross
            # product, [w1 x v2 + v1 x w2; w1 x w2]; Featherstone 2008, Sec. 2.9)
            acc = acc - _spatial(L2, r2) + np.concatenate([_x(L1.w) @ v2 - _x(L2.w) @ v1,
                                                           _x(L1.w) @ L2.w])
        J.append(rows)
        drift.append(acc)
        error.append(_frame_error(c, L1, P, L2))
    J = np.vstack(J) if J else np.zeros((0, nv))
    return Rows(J, np.concatenate(drift), J @ v, np.concatenate(error))
