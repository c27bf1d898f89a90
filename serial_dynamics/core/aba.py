"""Forward dynamics, compiled: the articulated-body algorithm (ABA), O(n), in joint frames.

The same algorithm, frames and symbols as ``algorithms/aba.py`` (Featherstone 2008,
Table 7.1); spatial vectors angular first, S = e_z (index 2 revolute, 5 prismatic):

    pass 1 (outward, ``velocities``; ``minus_tip_wrench``)
                      v_i = Xup_i v_l + S_i qd_i         c_i = v_i x S_i qd_i
                      IA_i = I_i                          pA_i = v_i x* I_i v_i - f_ext_i
    pass 2 (inward, ``articulated_inertias``)
                      U_i = IA_i S_i   D_i = S_i^T U_i    u_i = tau_i - S_i^T pA_i
                      Ia = IA_i - U_i U_i^T / D_i         pa = pA_i + Ia c_i + U_i u_i / D_i
                      IA_l += Xup_i^T Ia Xup_i            pA_l += Xup_i^T pa
    pass 3 (outward, ``accelerations``)
                      a'_i = Xup_i a_l + c_i              qdd_i = (u_i - U_i^T a'_i) / D_i
                      a_i = a'_i + S_i qdd_i              with a_base = (0, -g)

on the parent array l = lambda(i) (``P[i, PARENT]``; i - 1 in a chain), so one kernel serves
chains and trees, as Featherstone writes it (Table 7.1 is for trees). On a tree each body's
velocity (pass 1), then its acceleration (pass 3), is kept in ``va`` for its children; a
chain carries its parent's in registers, and its parent's rows are known to be others than
its own. One source, four kernels: ``aba_core`` (a chain) and ``tree_aba_core`` (a tree,
with ``va`` from its caller; run on a chain it gives the same bits, ~20 % slower, measured
2026-11-28), and their ``floating_`` twins for a floating base's virtual chain or tree
(``P[n, ROOT]`` = 6), whose first six bodies are one free-flyer root joint: FDfb
(Featherstone 2008, Table 9.6): the root body starts pass 1 with v = (omega; v_O), pass 2
ends in its 6 x 6 articulated inertia, IA_0 a_0 = f_0 - pA_0 gives its acceleration, pass 3
starts from it; the six virtual joints' rates are returned with the velocity products that
the caller removes (core/floating.py).

The armature adds to D_i = S_i^T IA_i S_i + I_a,i (as it adds to M_ii); with the DAMPING flag,
D_i += damping_i: (M + diag(damping)) qdd = tau - b. A base with known motion (flag BASE)
starts pass 1 with v_{-1} = (omega_0, 0) and pass 3 with a_{-1} = (alpha_0, acc_0 - g): the
spatial acceleration of a base origin at rest is its classical one.
Ia and pa overwrite IA_i and pA_i once U_i, D_i, u_i are taken from them. A batch runs
these steps in SIMD lanes (``aba_lanes.py``).
"""

from . import flags as F
from .joint import add_rate, axis, joint_transforms, velocity_product
from .layout import ARM, G, KIND, PARENT, TIPP, TIPPATH, W_ACC, W_ALPHA, W_OMEGA
from numba import njit

from .signatures import D2, D3, In1, Out1, Pm, f8, i8, internal
from .cholesky import cholesky_factor, cholesky_solve_factored
from .rnea import inertia
from .spatial import finite, to_child, to_parent

@internal
def rot_block(R, i, X, a0, b0, Y):
    """Y = R_i X_blk R_i^T for the 3x3 block of the 6x6 X at rows a0.., columns b0..: column
    c of T = X_blk R_i^T, then column c of R_i T (each sum from 0.0, in k's order)."""
    for c in range(3):
        t0, t1, t2 = 0.0, 0.0, 0.0
        for m in range(3):
            r = R[i, c, m]
            t0 += X[a0, b0 + m] * r
            t1 += X[a0 + 1, b0 + m] * r
            t2 += X[a0 + 2, b0 + m] * r
        for a in range(3):
            s = 0.0
            s += R[i, a, 0] * t0
            s += R[i, a, 1] * t1
            s += R[i, a, 2] * t2
            Y[a, c] = s

@njit(cache=True, inline="always")
def body_inertia(I10, I6):
    """IA_i = I_i = [[I_O, [h]x], [[h]x^T, m 1]] into I6 (Featherstone 2008, eq. 2.63), from
    the body's inertial parameters I10 (``rnea.inertia``)."""
    m, hx, hy, hz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz = I10
    I6[0, 0], I6[0, 1], I6[0, 2] = Ixx, Ixy, Ixz
    I6[1, 0], I6[1, 1], I6[1, 2] = Ixy, Iyy, Iyz
    I6[2, 0], I6[2, 1], I6[2, 2] = Ixz, Iyz, Izz
    I6[0, 3], I6[0, 4], I6[0, 5] = 0.0, -hz, hy
    I6[1, 3], I6[1, 4], I6[1, 5] = hz, 0.0, -hx
    I6[2, 3], I6[2, 4], I6[2, 5] = -hy, hx, 0.0
    for a in range(3):
        for b in range(3):
            I6[3 + a, b] = I6[b, 3 + a]
            I6[3 + a, 3 + b] = m if a == b else 0.0


@njit(cache=True, inline="always")
def bias_force(I10, wx, wy, wz, ux, uy, uz):
    """pA = v x* (I v) of a body moving with (omega; v_O) = (w*; u*), 6 numbers: momentum
    L = I_O omega + h x v_O, Pm = m v_O + omega x h; (omega, v_O) x* (L, Pm) = (omega x L +
    v_O x Pm, omega x Pm) (Featherstone 2008, eq. 2.68)."""
    m, hx, hy, hz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz = I10
    Lx = Ixx * wx + Ixy * wy + Ixz * wz + hy * uz - hz * uy
    Ly = Ixy * wx + Iyy * wy + Iyz * wz + hz * ux - hx * uz
    Lz = Ixz * wx + Iyz * wy + Izz * wz + hx * uy - hy * ux
    Px = m * ux + wy * hz - wz * hy
    Py = m * uy + wz * hx - wx * hz
    Pz = m * uz + wx * hy - wy * hx
    return (wy * Lz - wz * Ly + uy * Pz - uz * Py, wz * Lx - wx * Lz + uz * Px - ux * Pz,
            wx * Ly - wy * Lx + ux * Py - uy * Px, wy * Pz - wz * Py, wz * Px - wx * Pz,
            wx * Py - wy * Px)


@njit(cache=True, inline="always")
def rigid_body(P, i, I6, pA, wx, wy, wz, ux, uy, uz):
    """Pass 1's start of body i moving with (omega; v_O) = (w*; u*): IA_i = I_i into I6 and
    pA_i = v x* I_i v into pA[i]."""
    I10 = inertia(P, i)
    body_inertia(I10, I6)
    pA[i, 0], pA[i, 1], pA[i, 2], pA[i, 3], pA[i, 4], pA[i, 5] = bias_force(
        I10, wx, wy, wz, ux, uy, uz)


# IA_l += Xup_i^T Ia Xup_i (Featherstone 2008, eq. 7.23), with Ia = [[A1, B1], [B1^T, C1]]
# rotated by R_i (``rot_block``), then shifted by p_i:
#     A' = A1 - B1 [p]x + [p]x B1^T - [p]x C1 [p]x,  B' = B1 + [p]x C1,  C' = C1.
@njit(cache=True, inline="always")
def block(Y):
    """A 3 x 3 block as nine numbers, row-major."""
    return Y[0, 0], Y[0, 1], Y[0, 2], Y[1, 0], Y[1, 1], Y[1, 2], Y[2, 0], Y[2, 1], Y[2, 2]


@njit(cache=True, inline="always")
def cross_block(px, py, pz, C):
    """[p]x C1, nine numbers (C1 and the result row-major)."""
    C00, C01, C02, C10, C11, C12, C20, C21, C22 = C
    return (py * C20 - pz * C10, py * C21 - pz * C11, py * C22 - pz * C12,
            pz * C00 - px * C20, pz * C01 - px * C21, pz * C02 - px * C22,
            px * C10 - py * C00, px * C11 - py * C01, px * C12 - py * C02)


@njit(cache=True, inline="always")
def add_lower_right(T, r0, b, C):
    """C' = C1 into rows 3.. and columns 3.. of the 6 x 6 whose entry (a, c) is T[r0 + 6a + c,
    b] (its upper triangle, mirrored)."""
    C00, C01, C02, C11, C12, C22 = C[0], C[1], C[2], C[4], C[5], C[8]
    T[r0 + 21, b] += C00
    T[r0 + 22, b] += C01
    T[r0 + 23, b] += C02
    T[r0 + 27, b] += C01
    T[r0 + 28, b] += C11
    T[r0 + 29, b] += C12
    T[r0 + 33, b] += C02
    T[r0 + 34, b] += C12
    T[r0 + 35, b] += C22


@njit(cache=True, inline="always")
def add_off_diagonal(T, r0, b, B, Q):
    """B' = B1 + [p]x C1 (Q) into rows 0.., columns 3.., and its transpose."""
    B00, B01, B02, B10, B11, B12, B20, B21, B22 = B
    q00, q01, q02, q10, q11, q12, q20, q21, q22 = Q
    b00, b01, b02 = B00 + q00, B01 + q01, B02 + q02
    b10, b11, b12 = B10 + q10, B11 + q11, B12 + q12
    b20, b21, b22 = B20 + q20, B21 + q21, B22 + q22
    T[r0 + 3, b] += b00
    T[r0 + 4, b] += b01
    T[r0 + 5, b] += b02
    T[r0 + 9, b] += b10
    T[r0 + 10, b] += b11
    T[r0 + 11, b] += b12
    T[r0 + 15, b] += b20
    T[r0 + 16, b] += b21
    T[r0 + 17, b] += b22
    T[r0 + 18, b] += b00
    T[r0 + 24, b] += b01
    T[r0 + 30, b] += b02
    T[r0 + 19, b] += b10
    T[r0 + 25, b] += b11
    T[r0 + 31, b] += b12
    T[r0 + 20, b] += b20
    T[r0 + 26, b] += b21
    T[r0 + 32, b] += b22


@njit(cache=True, inline="always")
def add_upper_left(T, r0, b, px, py, pz, A, B, Q):
    """A' = A1 - B1 [p]x + [p]x B1^T - [p]x C1 [p]x (B1, Q = [p]x C1 row-major) into rows
    0.., columns 0.. (its upper triangle, mirrored)."""
    B00, B01, B02, B10, B11, B12, B20, B21, B22 = B
    q00, q01, q02, q10, q11, q12, q20, q21, q22 = Q
    # E = B1 [p]x  (column k of [p]x is e_k x ... : ([p]x)_{:,0} = (0, pz, -py), etc.)
    e00, e01, e02 = B01 * pz - B02 * py, B02 * px - B00 * pz, B00 * py - B01 * px
    e10, e11, e12 = B11 * pz - B12 * py, B12 * px - B10 * pz, B10 * py - B11 * px
    e20, e21, e22 = B21 * pz - B22 * py, B22 * px - B20 * pz, B20 * py - B21 * px
    # F = [p]x C1 [p]x = Q [p]x  (symmetric)
    f00, f01, f02 = q01 * pz - q02 * py, q02 * px - q00 * pz, q00 * py - q01 * px
    f11, f12 = q12 * px - q10 * pz, q10 * py - q11 * px
    f22 = q20 * py - q21 * px
    # A' = A1 - E - E^T - F
    T[r0, b] += A[0] - 2.0 * e00 - f00
    T[r0 + 7, b] += A[4] - 2.0 * e11 - f11
    T[r0 + 14, b] += A[8] - 2.0 * e22 - f22
    t01 = A[1] - e01 - e10 - f01
    t02 = A[2] - e02 - e20 - f02
    t12 = A[5] - e12 - e21 - f12
    T[r0 + 1, b] += t01
    T[r0 + 6, b] += t01
    T[r0 + 2, b] += t02
    T[r0 + 12, b] += t02
    T[r0 + 8, b] += t12
    T[r0 + 13, b] += t12


@njit(cache=True, inline="always")
def inertia_to_parent(R, p, i, I6, Y, T, r0):
    """IA_l += Xup_i^T Ia Xup_i (the comment above), Ia = I6, IA_l the 6 x 6 whose entry
    (a, c) is T[r0 + 6a + c, 0]. Y (3, 3) scratch."""
    px, py, pz = p[i, 0], p[i, 1], p[i, 2]
    rot_block(R, i, I6, 3, 3, Y)                        # C1
    C = block(Y)
    add_lower_right(T, r0, 0, C)
    Q = cross_block(px, py, pz, C)
    rot_block(R, i, I6, 0, 3, Y)                        # B1
    B = block(Y)
    add_off_diagonal(T, r0, 0, B, Q)
    rot_block(R, i, I6, 0, 0, Y)                        # A1
    add_upper_left(T, r0, 0, px, py, pz, block(Y), B, Q)


@njit(cache=True, inline="always")
def articulated_bodies(P, sc, R, p, IA, pA, U, c, Du, Y, va, q, qd, tau, w, damping, flags,
                       out, tree, nb):
    """qdd into ``out``. Returns 0.0, or NaN if an input has a NaN/Inf entry. ``tree`` and
    ``nb``, constants of the caller (aba_core, tree_aba_core and their floating_ twins): read
    lambda(i) (else i - 1); 6: a floating base's virtual chain or tree, whose first six
    bodies are one free-flyer root joint (FDfb). The module docstring's three passes:"""
    n = out.shape[0]
    chk = joint_transforms(P, sc, R, p, q, n, nb)
    chk += velocities(P, R, p, IA, pA, c, va, qd, tau, w, flags, n, tree, nb)        # pass 1
    if (flags & F.WRENCH) != 0:
        chk += minus_tip_wrench(P, R, pA, w, n, tree, nb)
    articulated_inertias(P, R, p, IA, pA, U, c, Du, Y, tau, damping, flags, n, tree, nb)  # 2
    return chk + accelerations(P, R, p, IA, pA, U, c, Du, va, qd, tau, w, flags, out,
                               n, tree, nb)                                           # 3


@njit(cache=True, inline="always")
def velocities(P, R, p, IA, pA, c, va, qd, tau, w, flags, n, tree, nb):
    """Pass 1, outward: each body's twist, its velocity product c and its bias force pA
    (IA_i = I_i). Returns the inputs' check (0.0 or NaN)."""
    use_qd = (flags & F.QD) != 0
    chk = 0.0
    vx = vy = vz = ux = uy = uz = 0.0    # (omega; v_O) of the parent: the base's at first
    if (flags & F.BASE) != 0:            # a moving base: v_base = (omega_0, 0)
        vx, vy, vz = w[W_OMEGA], w[W_OMEGA + 1], w[W_OMEGA + 2]
        chk += finite(vx) + finite(vy) + finite(vz)
    bx, by, bz = vx, vy, vz
    if nb > 0:                           # FDfb (Featherstone 2008, Table 9.6): the root body
        k = nb - 1                       # moves with v = (omega; v_O) = (qd[3:6]; qd[:3])
        for i in range(nb):
            chk += finite(qd[i] if use_qd else 0.0) + finite(tau[i])
        vx, vy, vz = (qd[3], qd[4], qd[5]) if use_qd else (0.0, 0.0, 0.0)
        ux, uy, uz = (qd[0], qd[1], qd[2]) if use_qd else (0.0, 0.0, 0.0)
        if tree:
            va[k, 0], va[k, 1], va[k, 2], va[k, 3], va[k, 4], va[k, 5] = vx, vy, vz, ux, uy, uz
        rigid_body(P, k, IA[k], pA, vx, vy, vz, ux, uy, uz)
    for i in range(nb, n):
        dq = qd[i] if use_qd else 0.0
        chk += finite(dq) + finite(tau[i])
        if tree:                         # the parent's (a chain's: the previous step's)
            l = int(P[i, PARENT])
            vx, vy, vz, ux, uy, uz = (bx, by, bz, 0.0, 0.0, 0.0) if l < 0 else (
                va[l, 0], va[l, 1], va[l, 2], va[l, 3], va[l, 4], va[l, 5])
        px, py, pz = p[i, 0], p[i, 1], p[i, 2]
        # v_i = Xup_i v_{i-1}: omega = R^T omega, v_O = R^T (v_O + omega x p)
        sx, sy, sz = ux - (py * vz - pz * vy), uy - (pz * vx - px * vz), uz - (px * vy - py * vx)
        wx, wy, wz = to_child(R, i, vx, vy, vz)
        ux, uy, uz = to_child(R, i, sx, sy, sz)
        kind = P[i, KIND]
        c[i, 0], c[i, 1], c[i, 2], c[i, 3], c[i, 4], c[i, 5] = velocity_product(kind, wx, wy, ux, uy, dq)
        wz, uz = add_rate(kind, wz, uz, dq)          # c = v x (S qd), then v += S qd
        vx, vy, vz = wx, wy, wz
        if tree:
            va[i, 0], va[i, 1], va[i, 2], va[i, 3], va[i, 4], va[i, 5] = wx, wy, wz, ux, uy, uz
        rigid_body(P, i, IA[i], pA, wx, wy, wz, ux, uy, uz)   # pA = v x* I v
    return chk


@njit(cache=True, inline="always")
def minus_tip_wrench(P, R, pA, w, n, tree, nb):
    """pA_{n-1} -= the tip wrench (world axes, about the tip point), rotated along the
    tip's path into the last body's frame. Returns its check (0.0 or NaN)."""
    fx, fy, fz, mx, my, mz = w[0], w[1], w[2], w[3], w[4], w[5]
    chk = finite(fx) + finite(fy) + finite(fz) + finite(mx) + finite(my) + finite(mz)
    for i in range(nb, n):               # base -> last body, along its path
        if not tree or P[i, TIPPATH] != 0.0:
            fx, fy, fz = to_child(R, i, fx, fy, fz)
            mx, my, mz = to_child(R, i, mx, my, mz)
    tpx, tpy, tpz = P[n, TIPP], P[n, TIPP + 1], P[n, TIPP + 2]
    k = n - 1
    pA[k, 0] -= mx + tpy * fz - tpz * fy
    pA[k, 1] -= my + tpz * fx - tpx * fz
    pA[k, 2] -= mz + tpx * fy - tpy * fx
    pA[k, 3] -= fx
    pA[k, 4] -= fy
    pA[k, 5] -= fz
    return chk


@njit(cache=True, inline="always")
def articulated_inertias(P, R, p, IA, pA, U, c, Du, Y, tau, damping, flags, n, tree, nb):
    """Pass 2, inward: U, D, u of each joint, then its articulated inertia Ia and bias
    force pa (over IA_i, pA_i) carried into the parent's."""
    IA36 = IA.reshape((36 * n, 1))       # IA_l's entry (a, c) is IA36[36 l + 6 a + c, 0]
    for i in range(n - 1, nb - 1, -1):
        I6 = IA[i]
        s = axis(P[i, KIND])                                # S = e_s
        D = I6[s, s] + P[i, ARM]                            # D = S^T IA S + I_a (+ damping)
        if (flags & F.DAMPING) != 0:
            D += damping[i]
        u = tau[i] - pA[i, s]                               # u = tau - S^T pA
        for a in range(6):
            U[i, a] = I6[a, s]                              # U = IA S
        Du[i, 0], Du[i, 1] = D, u
        if not tree:                     # a chain: i - 1, down to body 0
            if i == 0:
                break
            l = i - 1
        else:
            l = int(P[i, PARENT])
            if l < 0:
                continue
        # Ia = IA - U U^T / D;  pa = pA + Ia c + U u / D  (both in place)
        for a in range(6):
            Ua = U[i, a] / D
            acc = pA[i, a] + Ua * u
            for b in range(6):
                I6[a, b] = I6[a, b] - Ua * U[i, b]
                acc += I6[a, b] * c[i, b]
            pA[i, a] = acc
        inertia_to_parent(R, p, i, I6, Y, IA36, 36 * l)     # IA_l += Xup_i^T Ia Xup_i
        # pA_l += Xup_i^T pa
        nx, ny, nz, fx, fy, fz = to_parent(R, p, i, pA[i, 0], pA[i, 1], pA[i, 2],
                                           pA[i, 3], pA[i, 4], pA[i, 5])
        pA[l, 0] += nx
        pA[l, 1] += ny
        pA[l, 2] += nz
        pA[l, 3] += fx
        pA[l, 4] += fy
        pA[l, 5] += fz


@njit(cache=True, inline="always")
def accelerations(P, R, p, IA, pA, U, c, Du, va, qd, tau, w, flags, out, n, tree, nb):
    """Pass 3, outward: qdd (into ``out``) and each body's acceleration, from the base's
    (0, -g), or (alpha_0, acc_0 - g) on a moving base, or the free-flyer root's
    IA_0 a_0 = f_0 - pA_0. Returns the base motion's check (0.0 or NaN)."""
    chk = 0.0
    ax = ay = az = 0.0
    lx, ly, lz = -P[n, G], -P[n, G + 1], -P[n, G + 2]
    if (flags & F.BASE) != 0:
        ax, ay, az = w[W_ALPHA], w[W_ALPHA + 1], w[W_ALPHA + 2]
        lx, ly, lz = w[W_ACC] - P[n, G], w[W_ACC + 1] - P[n, G + 1], w[W_ACC + 2] - P[n, G + 2]
        chk += finite(ax) + finite(ay) + finite(az) + finite(lx) + finite(ly) + finite(lz)
    b0, b1, b2, b3, b4, b5 = ax, ay, az, lx, ly, lz
    if nb > 0:                           # the root: IA_0 a_0 = tau_0 - pA_0 (the base's [f; n]
        k = nb - 1                       # as a spatial force (n; f)), a_0 in the frame where
        x = U[k]                         # the world accelerates by the base acceleration b
        x[0], x[1], x[2] = tau[3] - pA[k, 0], tau[4] - pA[k, 1], tau[5] - pA[k, 2]
        x[3], x[4], x[5] = tau[0] - pA[k, 3], tau[1] - pA[k, 4], tau[2] - pA[k, 5]
        cholesky_factor(IA[k])
        cholesky_solve_factored(IA[k], x)
        ax, ay, az, lx, ly, lz = x[0], x[1], x[2], x[3], x[4], x[5]
        if tree:
            va[k, 0], va[k, 1], va[k, 2], va[k, 3], va[k, 4], va[k, 5] = ax, ay, az, lx, ly, lz
        # the six virtual joints' rates: a_0 - b = (alpha; a_O - omega x v_O) for the
        # caller's a = dv/dt plus the velocity products (core/floating.py's _products)
        use_qd = (flags & F.QD) != 0
        wx, wy, wz = (qd[3], qd[4], qd[5]) if use_qd else (0.0, 0.0, 0.0)
        vx, vy, vz = (qd[0], qd[1], qd[2]) if use_qd else (0.0, 0.0, 0.0)
        out[0] = (lx - b3) + (wy * vz - wz * vy)
        out[1] = (ly - b4) + (wz * vx - wx * vz)
        out[2] = (lz - b5) + (wx * vy - wy * vx)
        out[3] = (ax - b0) - wy * wz
        out[4] = (ay - b1) + wx * wz
        out[5] = (az - b2) - wx * wy
    for i in range(nb, n):
        if tree:                         # the parent's acceleration (va: pass 3's now)
            l = int(P[i, PARENT])
            ax, ay, az, lx, ly, lz = (b0, b1, b2, b3, b4, b5) if l < 0 else (
                va[l, 0], va[l, 1], va[l, 2], va[l, 3], va[l, 4], va[l, 5])
        px, py, pz = p[i, 0], p[i, 1], p[i, 2]
        # a'_i = Xup_i a_{i-1} + c_i
        sx, sy, sz = lx - (py * az - pz * ay), ly - (pz * ax - px * az), lz - (px * ay - py * ax)
        ax, ay, az = to_child(R, i, ax, ay, az)
        lx, ly, lz = to_child(R, i, sx, sy, sz)
        ax, ay, az = ax + c[i, 0], ay + c[i, 1], az + c[i, 2]
        lx, ly, lz = lx + c[i, 3], ly + c[i, 4], lz + c[i, 5]
        # qdd_i = (u_i - U_i^T a'_i) / D_i;  a_i = a'_i + S_i qdd_i
        Ua = U[i, 0] * ax + U[i, 1] * ay + U[i, 2] * az + U[i, 3] * lx + U[i, 4] * ly + U[i, 5] * lz
        qdd = (Du[i, 1] - Ua) / Du[i, 0]
        out[i] = qdd
        az, lz = add_rate(P[i, KIND], az, lz, qdd)
        if tree:
            va[i, 0], va[i, 1], va[i, 2], va[i, 3], va[i, 4], va[i, 5] = ax, ay, az, lx, ly, lz
    return chk


_CHAIN = f8(Pm, D2, D3, D2, D3, D2, D2, D2, D2, D2, In1, In1, In1, In1, In1, i8, Out1)
_TREE = f8(Pm, D2, D3, D2, D3, D2, D2, D2, D2, D2, D2, In1, In1, In1, In1, In1, i8, Out1)
_SOLVE = ("cholesky_factor", "cholesky_solve_factored")


@internal(_CHAIN)
def aba_core(P, sc, R, p, IA, pA, U, c, Du, Y, q, qd, tau, w, damping, flags, out):
    """A chain's articulated bodies (lambda(i) = i - 1; no ``va``: Y stands in, unread)."""
    return articulated_bodies(P, sc, R, p, IA, pA, U, c, Du, Y, Y, q, qd, tau, w, damping,
                              flags, out, False, 0)


@internal(_CHAIN, calls=_SOLVE)
def floating_aba_core(P, sc, R, p, IA, pA, U, c, Du, Y, q, qd, tau, w, damping, flags, out):
    """``aba_core`` on a floating base's virtual chain: FDfb."""
    return articulated_bodies(P, sc, R, p, IA, pA, U, c, Du, Y, Y, q, qd, tau, w, damping,
                              flags, out, False, 6)


@internal(_TREE)
def tree_aba_core(P, sc, R, p, IA, pA, U, c, Du, Y, va, q, qd, tau, w, damping, flags, out):
    """A tree's articulated bodies (on lambda(i), ``P[i, PARENT]``); va (n, 6) scratch."""
    return articulated_bodies(P, sc, R, p, IA, pA, U, c, Du, Y, va, q, qd, tau, w, damping,
                              flags, out, True, 0)


@internal(_TREE, calls=_SOLVE)
def floating_tree_aba_core(P, sc, R, p, IA, pA, U, c, Du, Y, va, q, qd, tau, w, damping, flags,
                           out):
    """``tree_aba_core`` on a floating base's virtual tree: FDfb."""
    return articulated_bodies(P, sc, R, p, IA, pA, U, c, Du, Y, va, q, qd, tau, w, damping,
                              flags, out, True, 6)
