"""The joint types of the NumPy reference, each said once (as ``core/joint.py`` says them for
the compiled core; spatial_v2's ``jcalc``; Featherstone 2008, Sec. 4.4 and Table 4.1).

A joint moves its body about (revolute) or along (prismatic) the z axis of its joint frame:
``kind = model.kind[i]`` (``joints.py``). Spatial vectors are angular first, (omega; v) and
(n; f), so S = e_2 (revolute) or e_5 (prismatic) and S^T x is x's angular or linear z. Every
function takes a batch: vectors (N, 3) (or broadcastable), rates (N,).

The algorithms call these instead of asking the type. (``core/planar_layout.py`` packs its own
planar description of the same two types; ``noc.constraint_matrix``, a chain's constraint rows,
spells both out, as Angeles & Lee's K does.)
"""
import numpy as np

from ..joints import PRISMATIC
from ._batch import mv, rot_z

E_Z = np.array([0.0, 0.0, 1.0])


def axes(kinds):
    """The index s of S = e_s in a spatial vector, per joint: 2 (revolute) or 5 (prismatic)."""
    return np.where(np.asarray(kinds) == PRISMATIC, 5, 2)


def motion_subspaces(model):
    """S_i (n, 6) in joint frames: e_z angular (revolute), e_z linear (prismatic)."""
    return np.eye(6)[axes(model.kind)]


def transform(kind, Xtree_R, Xtree_p, q):
    """X_J(q) after Xtree: body i in its parent, R (N, 3, 3) = Xtree_R Rz(q) (revolute) or
    Xtree_R, p (N, 3) = Xtree_p (+ q Xtree_R e_z, prismatic), for q (N,)."""
    N = q.shape[0]
    if kind == PRISMATIC:
        return np.repeat(Xtree_R[None], N, axis=0), Xtree_p + q[:, None] * Xtree_R[:, 2]
    return Xtree_R @ rot_z(q), np.repeat(Xtree_p[None], N, axis=0)


def project(kind, n, f):
    """S^T (n; f): f_z (prismatic) or n_z (revolute), of (.., 3) arrays."""
    return f[..., 2] if kind == PRISMATIC else n[..., 2]


def add_rate(kind, w, v, z, x):
    """(w, v) + S x with the joint's axis z: (w + z x, v) revolute, (w, v + z x) prismatic --
    a velocity plus S qd (z = e_z in the joint frame, or the axis in world axes)."""
    if kind == PRISMATIC:
        return w, v + z * x[..., None]
    return w + z * x[..., None], v


def joint_rate(kind, omega, alpha, acc, qd, qdd):
    """Joint i's rate added to body i's (omega, alpha, classical acc), in its frame: revolute
    alpha += omega x (qd e_z) + qdd e_z, omega += qd e_z; prismatic acc += 2 omega x (qd e_z)
    + qdd e_z."""
    qd_z, qdd_z = qd[:, None] * E_Z, qdd[:, None] * E_Z
    if kind == PRISMATIC:
        return omega, alpha, acc + 2.0 * np.cross(omega, qd_z) + qdd_z
    return omega + qd_z, alpha + np.cross(omega, qd_z) + qdd_z, acc


def world_joint_rate(kind, w, dw, v, a, z, qd, qdd):
    """``joint_rate`` in world axes for the velocity and classical acceleration of a moving
    point (w, dw: angular velocity and acceleration; v, a: the point's), z the joint's axis:
    revolute dw += z qdd + (w x z) qd, w += z qd; prismatic a += z qdd + 2 (w x z) qd,
    v += z qd. Returns (w, dw, v, a)."""
    wz = np.cross(w, z) * qd[:, None]
    if kind == PRISMATIC:
        return w, dw, v + z * qd[:, None], a + z * qdd[:, None] + 2.0 * wz
    return w + z * qd[:, None], dw + z * qdd[:, None] + wz, v, a


def world_column(kind, z, r):
    """The joint's column of a point's Jacobian, (linear, angular), z its axis and r the point
    minus the joint's origin (world axes): (z x r, z) revolute, (z, 0) prismatic."""
    if kind == PRISMATIC:
        return z, np.zeros_like(z)
    return np.cross(z, r), z


def world_column_rate(kind, z, zdot, r, rdot):
    """d/dt of ``world_column``: (zdot x r + z x rdot, zdot) revolute, (zdot, 0) prismatic."""
    if kind == PRISMATIC:
        return zdot, np.zeros_like(zdot)
    return np.cross(zdot, r) + np.cross(z, rdot), zdot


# ---- derivatives (algorithms/derivatives.py): d X_J/dq and the linearized rate term
def rate_tangent(kind, dalpha, dacc, domega, qd):
    """The tangent of ``joint_rate``'s velocity product along a direction with d omega' (the
    motion carried in): revolute d alpha += d omega' x qd e_z, prismatic d acc += 2 d omega' x
    qd e_z. Returns (d alpha, d acc)."""
    qd_z = qd[:, None] * E_Z
    if kind == PRISMATIC:
        return dalpha, dacc + 2.0 * np.cross(domega, qd_z)
    return dalpha + np.cross(domega, qd_z), dacc


def cross_ez(v):
    """v x e_z = (v_y, -v_x, 0) over a stack."""
    out = np.zeros_like(v)
    out[..., 0], out[..., 1] = v[..., 1], -v[..., 0]
    return out


def ez_cross(v):
    """e_z x v = (-v_y, v_x, 0) over a stack."""
    return -cross_ez(v)


def own_turn(kind, R, p, f, n, df, dn):
    """Joint j's own d/dq_j added to the tangent (d f, d n) of its joint wrench (n; f) carried
    into the parent: g = R (e_z x f); revolute d f += g, d n += R (e_z x n) + p x g;
    prismatic d n += g."""
    g = mv(R, ez_cross(f))
    if kind == PRISMATIC:
        return df, dn + g
    return df + g, dn + mv(R, ez_cross(n)) + np.cross(p, g)


def seed_q(kind, omega, alpha_p, omega_p, acc, e_f, e_m, qd):
    """The tangents (d omega, d alpha, d acc, d e_f, d e_m) that q_j seeds at body j, from its
    motion after (omega, acc) and before (omega_p, alpha_p) its joint moves and the tip wrench
    (e_f, e_m) in its frame (algorithms/derivatives.py's docstring): revolute, each x e_z and
    d alpha = alpha' x e_z + qd (omega' x e_z) x e_z; prismatic, d acc = alpha' x e_z +
    omega' x (omega' x e_z) only."""
    if kind == PRISMATIC:
        z = np.zeros_like(omega)
        return (z, z, np.cross(alpha_p, E_Z) + np.cross(omega_p, np.cross(omega_p, E_Z)), z, z)
    return (cross_ez(omega), cross_ez(alpha_p) + qd[:, None] * cross_ez(cross_ez(omega_p)),
            cross_ez(acc), cross_ez(e_f), cross_ez(e_m))


def seed_qd(kind, omega_p):
    """The tangents that qd_j seeds at body j: revolute d omega = e_z, d alpha = omega' x e_z;
    prismatic d acc = 2 omega' x e_z."""
    z = np.zeros_like(omega_p)
    if kind == PRISMATIC:
        return (z, z, 2.0 * cross_ez(omega_p), z, z)
    return (np.broadcast_to(E_Z, omega_p.shape), cross_ez(omega_p), z, z, z)
