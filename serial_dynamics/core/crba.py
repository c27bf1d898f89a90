"""Mass matrix, compiled: the composite-rigid-body algorithm in joint frames.

The same algorithm and frames as ``algorithms/crba.py`` (Featherstone 2008, Table 6.2):
the composite inertia of bodies i..n-1 about body i's origin, IC_i = I_i + Xup_{i+1}^T
IC_{i+1} Xup_{i+1}; F = IC_i S_i, carried to the base with F = Xup_j^T F; M_ji = S_j^T F.
In a chain the composite is carried in registers from the tip to the base as its ten
inertial parameters (m, h = m c, I_O), not as a 6x6 matrix. The armature (reflected
rotor inertia) adds to the diagonal after the pass: M_ii += I_a,i.
"""
from numba import njit, types

from .data import new_kin
from .status import BAD_LENGTH, status
from .signatures import D2, D3, Out2, Pm, internal
from .joint import armature_diagonal, joint_momentum, joint_transforms, project
from .layout import H, IO, KIND, MASS
from .rnea import inertia
from .spatial import rotation, to_parent


@njit(cache=True, inline="always")
def root_block(M, m, hx, hy, hz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz):
    """M[:6, :6], the block of a free-flyer root, v = [v_O, omega] (base frame): the composite
    inertia of the whole robot (m, h, I_O), [m 1, -[h]x; [h]x, I_O] (Featherstone 2008,
    Sec. 9.2): f = m v_O + omega x h, n = h x v_O + I_O omega."""
    for r in range(6):
        for c in range(6):
            M[r, c] = 0.0
    M[0, 0] = M[1, 1] = M[2, 2] = m
    M[0, 4] = M[4, 0] = hz
    M[0, 5] = M[5, 0] = -hy
    M[1, 3] = M[3, 1] = -hz
    M[1, 5] = M[5, 1] = hx
    M[2, 3] = M[3, 2] = hy
    M[2, 4] = M[4, 2] = -hx
    M[3, 3], M[4, 4], M[5, 5] = Ixx, Iyy, Izz
    M[3, 4] = M[4, 3] = Ixy
    M[3, 5] = M[5, 3] = Ixz
    M[4, 5] = M[5, 4] = Iyz


@njit(cache=True, inline="always")
def composite_bodies(P, R, p, M, nb):
    """M into ``M`` (n, n); R, p hold the joint transforms (``joint_transforms``). ``nb``, a
    constant of the caller: 0 (``crba_core``), or 6: a floating base's virtual chain, its
    first six bodies one free-flyer root joint (``floating_crba_core``): each joint's F
    carried into the base frame is its column of M's root rows, the composite of the whole
    robot M's root block (Featherstone 2008, Sec. 9.2). The armature is added after the pass
    (here, not in the callers: a statement after this inlined loop cost a call 2-3 %)."""
    n = M.shape[0]
    k = n - 1
    m, hx, hy, hz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz = inertia(P, k)
    for i in range(n - 1, nb - 1, -1):
        # F = IC_i S_i: the momentum of composite i.. moving with a unit joint rate
        nx, ny, nz, fx, fy, fz, M[i, i] = joint_momentum(P[i, KIND], m, hx, hy, Ixz, Iyz, Izz)
        j = i
        while j > (nb if nb > 0 else 1):    # carry F into the parent frame: F = Xup_j^T F
            nx, ny, nz, fx, fy, fz = to_parent(R, p, j, nx, ny, nz, fx, fy, fz)
            j -= 1
            M[j, i] = project(P[j, KIND], nz, fz)         # M_ji = S_j^T F
            M[i, j] = M[j, i]
        if nb > 0:                  # into the base frame: M_root,i = F (v = [v_O, omega])
            nx, ny, nz, fx, fy, fz = to_parent(R, p, nb, nx, ny, nz, fx, fy, fz)
            M[0, i], M[1, i], M[2, i], M[3, i], M[4, i], M[5, i] = fx, fy, fz, nx, ny, nz
            M[i, 0], M[i, 1], M[i, 2], M[i, 3], M[i, 4], M[i, 5] = fx, fy, fz, nx, ny, nz
        elif i > 0:
            if j == 1:              # last step, into body 0: only the z rows of Xup_1^T F
                gx = R[1, 0, 0] * fx + R[1, 0, 1] * fy + R[1, 0, 2] * fz
                gy = R[1, 1, 0] * fx + R[1, 1, 1] * fy + R[1, 1, 2] * fz
                M[0, i] = project(P[0, KIND], R[1, 2, 0] * nx + R[1, 2, 1] * ny + R[1, 2, 2] * nz
                                  + p[1, 0] * gy - p[1, 1] * gx,
                                  R[1, 2, 0] * fx + R[1, 2, 1] * fy + R[1, 2, 2] * fz)
                M[i, 0] = M[0, i]
            # composite i-1 = body i-1 + composite i carried into frame i-1
            if i == 1:              # of composite 0 only S_0^T IC_0 S_0 is needed: its I_zz or m
                r6, r7, r8 = R[1, 2, 0], R[1, 2, 1], R[1, 2, 2]
                px, py = p[1, 0], p[1, 1]
                gx = R[1, 0, 0] * hx + R[1, 0, 1] * hy + R[1, 0, 2] * hz
                gy = R[1, 1, 0] * hx + R[1, 1, 1] * hy + R[1, 1, 2] * hz
                t6, t7, t8 = r6 * Ixx + r7 * Ixy + r8 * Ixz, r6 * Ixy + r7 * Iyy + r8 * Iyz, r6 * Ixz + r7 * Iyz + r8 * Izz
                d = 2.0 * (gx * px + gy * py) + m * (px * px + py * py)
                M[0, 0] = project(P[0, KIND], P[0, IO + 2] + t6 * r6 + t7 * r7 + t8 * r8 + d,
                                  P[0, MASS] + m)
                break
        if i > 0:
            k = i - 1
            m, hx, hy, hz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz = add_in_parent(
                P[k, MASS], P[k, H], P[k, H + 1], P[k, H + 2], P[k, IO], P[k, IO + 1],
                P[k, IO + 2], P[k, IO + 3], P[k, IO + 4], P[k, IO + 5], rotation(R, i),
                p[i, 0], p[i, 1], p[i, 2], m, hx, hy, hz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz)
    if nb > 0:                      # composite nb-1: the whole robot, in the base frame
        root_block(M, m, hx, hy, hz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz)
    armature_diagonal(P, M, nb)         # M_ii += I_a,i, after the pass


def crba_core(P, R, p, M):
    """M into ``M`` (n, n) on a fixed base (``composite_bodies``)."""
    composite_bodies(P, R, p, M, 0)


def floating_crba_core(P, R, p, M):
    """M into ``M`` (n, n) of a floating base's virtual chain (``composite_bodies``)."""
    composite_bodies(P, R, p, M, 6)


@njit(cache=True, inline="always")
def add_in_parent(bm, bhx, bhy, bhz, bxx, byy, bzz, bxy, bxz, byz, r, px, py, pz,
                  m, hx, hy, hz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz):
    """(bm, bh, bI) + a composite body (m, h = m c, I_O about its origin, in body i's frame)
    carried into the parent's frame (R_i = r, origin p): the ten parameters of the sum.
    h_R = R h, I_R = R I_O R^T (T = R I_O, then T R^T); parallel axes to the parent origin
    (Featherstone 2008, eq. 2.63):
    I' = I_R + (2 h_R.p + m p.p) 1 - (h_R p^T + p h_R^T + m p p^T),  h' = h_R + m p."""
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = r
    gx, gy, gz = r0 * hx + r1 * hy + r2 * hz, r3 * hx + r4 * hy + r5 * hz, r6 * hx + r7 * hy + r8 * hz
    t0, t1, t2 = r0 * Ixx + r1 * Ixy + r2 * Ixz, r0 * Ixy + r1 * Iyy + r2 * Iyz, r0 * Ixz + r1 * Iyz + r2 * Izz
    t3, t4, t5 = r3 * Ixx + r4 * Ixy + r5 * Ixz, r3 * Ixy + r4 * Iyy + r5 * Iyz, r3 * Ixz + r4 * Iyz + r5 * Izz
    t6, t7, t8 = r6 * Ixx + r7 * Ixy + r8 * Ixz, r6 * Ixy + r7 * Iyy + r8 * Iyz, r6 * Ixz + r7 * Iyz + r8 * Izz
    Jxx, Jyy, Jzz = t0 * r0 + t1 * r1 + t2 * r2, t3 * r3 + t4 * r4 + t5 * r5, t6 * r6 + t7 * r7 + t8 * r8
    Jxy, Jxz, Jyz = t0 * r3 + t1 * r4 + t2 * r5, t0 * r6 + t1 * r7 + t2 * r8, t3 * r6 + t4 * r7 + t5 * r8
    d = 2.0 * (gx * px + gy * py + gz * pz) + m * (px * px + py * py + pz * pz)
    return (bm + m, bhx + gx + m * px, bhy + gy + m * py, bhz + gz + m * pz,
            bxx + Jxx + d - 2.0 * gx * px - m * px * px,
            byy + Jyy + d - 2.0 * gy * py - m * py * py,
            bzz + Jzz + d - 2.0 * gz * pz - m * pz * pz,
            bxy + Jxy - gx * py - px * gy - m * px * py,
            bxz + Jxz - gx * pz - px * gz - m * px * pz,
            byz + Jyz - gy * pz - py * gz - m * py * pz)


crba_inline = njit(cache=True, inline="always")(crba_core)   # into the single-state entry
crba_core = internal(types.void(Pm, D3, D2, Out2))(crba_core)   # called by the others
floating_crba_inline = njit(cache=True, inline="always")(floating_crba_core)
floating_crba_core = internal(types.void(Pm, D3, D2, Out2))(floating_crba_core)


# ------------------------------------------------------------------ entry points
def crba(P, q, out):
    """Mass matrix of one configuration into ``out`` (n, n). Returns OK, NOT_FINITE or BAD_LENGTH."""
    n = P.shape[0] - 1
    if q.shape[0] != n or out.shape[0] != n or out.shape[1] != n:
        return BAD_LENGTH
    d = new_kin(n)
    chk = joint_transforms(P, d.sc, d.R, d.p, q, n)
    crba_inline(P, d.R, d.p, out)
    return status(chk)

