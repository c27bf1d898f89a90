"""Forward dynamics of a batch by articulated bodies, compiled: B samples of a chain or a
tree at a time in SIMD lanes (``aba.articulated_bodies``' three passes, lane by lane;
Featherstone 2008, Table 7.1).

Every quantity of ``aba.py`` is stored with the sample index (lane) last, shape (rows, B),
and each step is a loop over the lanes (``rnea_lanes.py`` says why the lane count is read
at run time). Each lane does ``aba_core``'s (``tree_aba_core``'s) operations in its order,
through the same inline steps: pass 1 ``joint.velocity_product``, ``aba.body_inertia``,
``aba.bias_force``; pass 2 the Ia and pa updates, then Xup^T Ia Xup by ``aba.rot_block``'s
sums and ``aba.add_lower_right``, ``add_off_diagonal``, ``add_upper_left``; pass 3 the
accelerations; so a sample's qdd is bitwise the same alone or in any batch
(test/core/test_kernels.py, test_tree_kernels.py, test_reproducibility.py,
test/robot/test_floating.py). A fixed base (or a moving one, flag BASE), with a tip wrench
or without, and a floating base's virtual chain or tree with its six coordinates as one
free-flyer root (FDfb, ``nb`` = 6: the root's 6 x 6 system solved by
``forward_lanes.cholesky_lanes``, ``cholesky_factor``'s operations); a model whose 36 n rows
of articulated inertias do not fit the block's stack (``aba_lanes_fit``) runs one state at
a time (``forward.batch``, ``tree.tree_fd_batch``).
"""
from numba import njit

from . import flags as F
from .aba import (add_lower_right, add_off_diagonal, add_upper_left, bias_force, body_inertia,
                  cross_block)
from .data import LANE_STACK_DOUBLES, stack_empty
from .forward_lanes import cholesky_lanes
from .joint import add_rate, axis, lane_transforms, velocity_product
from .layout import ARM, G, KIND, LANES, PARENT, TIPP, TIPPATH, W_ACC, W_ALL, W_ALPHA, W_OMEGA
from .rnea import inertia
from .rnea_lanes import gather, scatter
from .signatures import In2, Out2, Pm, i8, internal
from .spatial import force_to_parent, rotate_t
from .status import NOT_FINITE, OK


@njit(cache=True, inline="always")
def aba_lanes_fit(n, L):
    """Whether a block of L lanes may hold the 6 x 6 articulated inertias of n bodies."""
    return 36 * n * L <= LANE_STACK_DOUBLES


@njit(cache=True, inline="always")
def rotation_lane(RB, i, b):
    """Lane b's R_i (RB rows 9i..), as ``spatial.rotation``'s nine numbers."""
    ri = 9 * i
    return (RB[ri, b], RB[ri + 1, b], RB[ri + 2, b], RB[ri + 3, b], RB[ri + 4, b],
            RB[ri + 5, b], RB[ri + 6, b], RB[ri + 7, b], RB[ri + 8, b])


@njit(cache=True, inline="always")
def rot_block_lanes(RB, i, IB, x0, YB, y0, nl):
    """YB rows y0 + 3a + c = R_i X R_i^T in every lane, X the 3 x 3 block of IB whose entry
    (k, m) is row x0 + 6k + m (``aba.rot_block``'s sums in its order)."""
    ri = 9 * i
    for c in range(3):
        for b in range(nl):
            t0, t1, t2 = 0.0, 0.0, 0.0
            for m in range(3):
                r = RB[ri + 3 * c + m, b]
                t0 += IB[x0 + m, b] * r
                t1 += IB[x0 + 6 + m, b] * r
                t2 += IB[x0 + 12 + m, b] * r
            for a in range(3):
                s = 0.0
                s += RB[ri + 3 * a, b] * t0
                s += RB[ri + 3 * a + 1, b] * t1
                s += RB[ri + 3 * a + 2, b] * t2
                YB[y0 + 3 * a + c, b] = s


@njit(cache=True, inline="always")
def parent_motion(P, VA, VB, i, b):
    """Lane b's motion of body i's parent lambda(i) (VA rows 6 lambda(i)..), or of the base (VB)."""
    l = int(P[i, PARENT])
    if l < 0:
        return VB[0, b], VB[1, b], VB[2, b], VB[3, b], VB[4, b], VB[5, b]
    k = 6 * l
    return VA[k, b], VA[k + 1, b], VA[k + 2, b], VA[k + 3, b], VA[k + 4, b], VA[k + 5, b]


@njit(cache=True, inline="always")
def spatial_inertia_lanes(I10, I6, IB, i, nl):
    """IA_i = I_i (``aba.body_inertia``, via the 6 x 6 scratch I6) into IB's rows 36i..,
    the same in every lane."""
    body_inertia(I10, I6)
    for a in range(6):
        for c in range(6):
            x = I6[a, c]
            for b in range(nl):
                IB[36 * i + 6 * a + c, b] = x


@njit(cache=True, inline="always")
def velocity_pass(P, QV, WB, RB, PB, VB, VA, CB, IB, AB, flags, nl, small, nb):
    """Pass 1, outward: the joint transforms into RB, PB; v_i into VA, c_i into CB (rows 6i..),
    IA_i = I_i into IB (rows 36i + 6a + c), pA_i = v_i x* I_i v_i into AB (rows 6i..), less
    the tip wrench on the last body (flag WRENCH); with nb = 6 the free-flyer root body
    nb - 1 first, moving with v = (qd[3:6]; qd[:3])."""
    n = P.shape[0] - 1
    use_base = (flags & F.BASE) != 0
    for k in range(6):                   # the base's (omega; v_O): 0, or (omega_0; 0)
        for b in range(nl):
            VB[k, b] = WB[W_OMEGA + k, b] if use_base and k < 3 else 0.0
    I6 = stack_empty((6, 6))
    if nb > 0:                           # FDfb (Featherstone 2008, Table 9.6): the root body
        k = nb - 1
        I10 = inertia(P, k)
        ck = 6 * k
        for b in range(nl):
            vx, vy, vz = QV[n + 3, b], QV[n + 4, b], QV[n + 5, b]
            ux, uy, uz = QV[n, b], QV[n + 1, b], QV[n + 2, b]
            VA[ck, b], VA[ck + 1, b], VA[ck + 2, b], VA[ck + 3, b], VA[ck + 4, b], VA[ck + 5, b] = (
                vx, vy, vz, ux, uy, uz)
            (AB[ck, b], AB[ck + 1, b], AB[ck + 2, b], AB[ck + 3, b], AB[ck + 4, b],
             AB[ck + 5, b]) = bias_force(I10, vx, vy, vz, ux, uy, uz)
        spatial_inertia_lanes(I10, I6, IB, k, nl)
    for i in range(nb, n):
        kind = P[i, KIND]                # the same in every lane: selects, not branches
        lane_transforms(P, i, QV, RB, PB, nl, small)
        I10 = inertia(P, i)
        ci = 6 * i
        for b in range(nl):
            r = rotation_lane(RB, i, b)
            px, py, pz = PB[3 * i, b], PB[3 * i + 1, b], PB[3 * i + 2, b]
            vx, vy, vz, ux, uy, uz = parent_motion(P, VA, VB, i, b)
            dq = QV[n + i, b]
            # v_i = Xup_i v_l: omega = R^T omega, v_O = R^T (v_O + omega x p)
            sx, sy, sz = ux - (py * vz - pz * vy), uy - (pz * vx - px * vz), uz - (px * vy - py * vx)
            wx, wy, wz = rotate_t(r, vx, vy, vz)
            ux, uy, uz = rotate_t(r, sx, sy, sz)
            (CB[ci, b], CB[ci + 1, b], CB[ci + 2, b], CB[ci + 3, b], CB[ci + 4, b],
             CB[ci + 5, b]) = velocity_product(kind, wx, wy, ux, uy, dq)
            wz, uz = add_rate(kind, wz, uz, dq)          # c = v x (S qd), then v += S qd
            VA[ci, b], VA[ci + 1, b], VA[ci + 2, b], VA[ci + 3, b], VA[ci + 4, b], VA[ci + 5, b] = (
                wx, wy, wz, ux, uy, uz)
            (AB[ci, b], AB[ci + 1, b], AB[ci + 2, b], AB[ci + 3, b], AB[ci + 4, b],
             AB[ci + 5, b]) = bias_force(I10, wx, wy, wz, ux, uy, uz)
        spatial_inertia_lanes(I10, I6, IB, i, nl)
    if (flags & F.WRENCH) != 0:          # pA_{n-1} -= the tip wrench, about the last origin
        tpx, tpy, tpz = P[n, TIPP], P[n, TIPP + 1], P[n, TIPP + 2]
        k = 6 * (n - 1)
        for b in range(nl):
            fx, fy, fz, mx, my, mz = WB[0, b], WB[1, b], WB[2, b], WB[3, b], WB[4, b], WB[5, b]
            for i in range(nb, n):       # base -> last body, along its path
                if P[i, TIPPATH] != 0.0:
                    r = rotation_lane(RB, i, b)
                    fx, fy, fz = rotate_t(r, fx, fy, fz)
                    mx, my, mz = rotate_t(r, mx, my, mz)
            AB[k, b] -= mx + tpy * fz - tpz * fy
            AB[k + 1, b] -= my + tpz * fx - tpx * fz
            AB[k + 2, b] -= mz + tpx * fy - tpy * fx
            AB[k + 3, b] -= fx
            AB[k + 4, b] -= fy
            AB[k + 5, b] -= fz


@njit(cache=True, inline="always")
def inertia_pass(P, QV, RB, PB, CB, IB, AB, UB, DB, YB, SB, nl, nb):
    """Pass 2, inward: U_i = IA_i S_i, D_i = S_i^T U_i + I_a,i, u_i = tau_i - S_i^T pA_i
    into UB, DB; then Ia = IA_i - U_i U_i^T / D_i, pa = pA_i + Ia c_i + U_i u_i / D_i in
    place, and IA_l += Xup_i^T Ia Xup_i, pA_l += Xup_i^T pa (l = lambda(i)). SB (2, B) scratch."""
    n = P.shape[0] - 1
    for i in range(n - 1, nb - 1, -1):
        s = axis(P[i, KIND])             # S = e_s
        arm = P[i, ARM]
        x0, ci = 36 * i, 6 * i
        for b in range(nl):
            DB[2 * i, b] = IB[x0 + 7 * s, b] + arm                # D = S^T IA S + I_a
            DB[2 * i + 1, b] = QV[2 * n + i, b] - AB[ci + s, b]   # u = tau - S^T pA
        for a in range(6):
            for b in range(nl):
                UB[ci + a, b] = IB[x0 + 6 * a + s, b]             # U = IA S
        l = int(P[i, PARENT])
        if l < 0:
            continue
        # Ia = IA - U U^T / D;  pa = pA + Ia c + U u / D  (both in place)
        for a in range(6):
            for b in range(nl):
                Ua = UB[ci + a, b] / DB[2 * i, b]
                SB[0, b] = Ua
                SB[1, b] = AB[ci + a, b] + Ua * DB[2 * i + 1, b]
            for c in range(6):
                for b in range(nl):
                    x = IB[x0 + 6 * a + c, b] - SB[0, b] * UB[ci + c, b]
                    IB[x0 + 6 * a + c, b] = x
                    SB[1, b] += x * CB[ci + c, b]
            for b in range(nl):
                AB[ci + a, b] = SB[1, b]
        inertia_to_parent_lanes(RB, PB, IB, YB, i, l, nl)         # IA_l += Xup^T Ia Xup
        for b in range(nl):                                       # pA_l += Xup^T pa
            nx, ny, nz, fx, fy, fz = force_to_parent(
                rotation_lane(RB, i, b), PB[3 * i, b], PB[3 * i + 1, b], PB[3 * i + 2, b],
                AB[ci, b], AB[ci + 1, b], AB[ci + 2, b], AB[ci + 3, b], AB[ci + 4, b],
                AB[ci + 5, b])
            k = 6 * l
            AB[k, b] += nx
            AB[k + 1, b] += ny
            AB[k + 2, b] += nz
            AB[k + 3, b] += fx
            AB[k + 4, b] += fy
            AB[k + 5, b] += fz


@njit(cache=True, inline="always")
def inertia_to_parent_lanes(RB, PB, IB, YB, i, l, nl):
    """``aba.inertia_to_parent`` in every lane: IB's block of body l += Xup_i^T Ia Xup_i,
    Ia IB's block of body i; the rotated blocks C1, B1, A1 in YB's rows 0, 9, 18."""
    x0, pi = 36 * i, 3 * i
    rot_block_lanes(RB, i, IB, x0 + 21, YB, 0, nl)       # C1 (rows 3.., columns 3..)
    rot_block_lanes(RB, i, IB, x0 + 3, YB, 9, nl)        # B1 (rows 0.., columns 3..)
    rot_block_lanes(RB, i, IB, x0, YB, 18, nl)           # A1
    for b in range(nl):
        px, py, pz = PB[pi, b], PB[pi + 1, b], PB[pi + 2, b]
        C = (YB[0, b], YB[1, b], YB[2, b], YB[3, b], YB[4, b], YB[5, b], YB[6, b], YB[7, b],
             YB[8, b])
        add_lower_right(IB, 36 * l, b, C)
        Q = cross_block(px, py, pz, C)
        B = (YB[9, b], YB[10, b], YB[11, b], YB[12, b], YB[13, b], YB[14, b], YB[15, b],
             YB[16, b], YB[17, b])
        add_off_diagonal(IB, 36 * l, b, B, Q)
        A = (YB[18, b], YB[19, b], YB[20, b], YB[21, b], YB[22, b], YB[23, b], YB[24, b],
             YB[25, b], YB[26, b])
        add_upper_left(IB, 36 * l, b, px, py, pz, A, B, Q)


@njit(cache=True, inline="always")
def acceleration_pass(P, QV, WB, RB, PB, VB, VA, CB, IB, AB, UB, DB, MB, XB, SB, TB, flags, nl, nb):
    """Pass 3, outward: a'_i = Xup_i a_l + c_i, qdd_i = (u_i - U_i^T a'_i) / D_i into TB,
    a_i = a'_i + S_i qdd_i into VA; the base's a = (0, -g), moving: (alpha_0, acc_0 - g).
    With nb = 6 first the root's IA_0 a_0 = tau_0 - pA_0 (``aba.articulated_bodies``' FDfb
    step: its lower triangle into MB transposed, as ``forward_lanes.cholesky_lanes`` reads
    it, XB the right-hand side, SB scratch)."""
    n = P.shape[0] - 1
    use_base = (flags & F.BASE) != 0
    for b in range(nl):
        ax = ay = az = 0.0
        lx, ly, lz = -P[n, G], -P[n, G + 1], -P[n, G + 2]
        if use_base:
            ax, ay, az = WB[W_ALPHA, b], WB[W_ALPHA + 1, b], WB[W_ALPHA + 2, b]
            lx, ly, lz = (WB[W_ACC, b] - P[n, G], WB[W_ACC + 1, b] - P[n, G + 1],
                          WB[W_ACC + 2, b] - P[n, G + 2])
        VB[0, b], VB[1, b], VB[2, b], VB[3, b], VB[4, b], VB[5, b] = ax, ay, az, lx, ly, lz
    if nb > 0:                           # the root: IA_0 a_0 = tau_0 - pA_0 (the base's [f; n]
        k = nb - 1                       # as a spatial force (n; f))
        x0, ck = 36 * k, 6 * k
        for j in range(6):
            for i in range(j, 6):
                for b in range(nl):
                    MB[6 * j + i, b] = IB[x0 + 6 * i + j, b]
        for j in range(6):               # x = tau_0 - pA_0, tau_0 = [f; n] read as (n; f)
            t = 2 * n + (j + 3) % 6
            for b in range(nl):
                XB[j, b] = QV[t, b] - AB[ck + j, b]
        cholesky_lanes(6, MB, XB, SB, nl)
        for b in range(nl):
            ax, ay, az, lx, ly, lz = XB[0, b], XB[1, b], XB[2, b], XB[3, b], XB[4, b], XB[5, b]
            VA[ck, b], VA[ck + 1, b], VA[ck + 2, b], VA[ck + 3, b], VA[ck + 4, b], VA[ck + 5, b] = (
                ax, ay, az, lx, ly, lz)
            # the six virtual joints' rates: a_0 - b = (alpha; a_O - omega x v_O) (aba.py)
            wx, wy, wz = QV[n + 3, b], QV[n + 4, b], QV[n + 5, b]
            vx, vy, vz = QV[n, b], QV[n + 1, b], QV[n + 2, b]
            TB[0, b] = (lx - VB[3, b]) + (wy * vz - wz * vy)
            TB[1, b] = (ly - VB[4, b]) + (wz * vx - wx * vz)
            TB[2, b] = (lz - VB[5, b]) + (wx * vy - wy * vx)
            TB[3, b] = (ax - VB[0, b]) - wy * wz
            TB[4, b] = (ay - VB[1, b]) + wx * wz
            TB[5, b] = (az - VB[2, b]) - wx * wy
    for i in range(nb, n):
        kind = P[i, KIND]
        ci = 6 * i
        for b in range(nl):
            r = rotation_lane(RB, i, b)
            px, py, pz = PB[3 * i, b], PB[3 * i + 1, b], PB[3 * i + 2, b]
            ax, ay, az, lx, ly, lz = parent_motion(P, VA, VB, i, b)
            # a'_i = Xup_i a_l + c_i
            sx, sy, sz = lx - (py * az - pz * ay), ly - (pz * ax - px * az), lz - (px * ay - py * ax)
            ax, ay, az = rotate_t(r, ax, ay, az)
            lx, ly, lz = rotate_t(r, sx, sy, sz)
            ax, ay, az = ax + CB[ci, b], ay + CB[ci + 1, b], az + CB[ci + 2, b]
            lx, ly, lz = lx + CB[ci + 3, b], ly + CB[ci + 4, b], lz + CB[ci + 5, b]
            # qdd_i = (u_i - U_i^T a'_i) / D_i;  a_i = a'_i + S_i qdd_i
            Ua = (UB[ci, b] * ax + UB[ci + 1, b] * ay + UB[ci + 2, b] * az + UB[ci + 3, b] * lx
                  + UB[ci + 4, b] * ly + UB[ci + 5, b] * lz)
            qdd = (DB[2 * i + 1, b] - Ua) / DB[2 * i, b]
            TB[i, b] = qdd
            az, lz = add_rate(kind, az, lz, qdd)
            VA[ci, b], VA[ci + 1, b], VA[ci + 2, b], VA[ci + 3, b], VA[ci + 4, b], VA[ci + 5, b] = (
                ax, ay, az, lx, ly, lz)


@njit(cache=True, inline="always")
def lanes_block(P, q, qd, tau, w, flags, out, k0, nb):
    """qdd of the samples k0 .. k0 + B - 1 of the batch (fewer at its end) into the same rows
    of ``out`` by articulated bodies (flags QD, WRENCH, BASE); ``nb``: 0, or 6 for a floating
    base's virtual chain or tree (FDfb). Returns 1 if one of them has a NaN/Inf input, else
    0. The lanes' scratch, on this function's stack (~78 n rows of B): QV q, qd, tau (and
    the small-angle mask), WB w, RB, PB the joint transforms, VB the base's motion, VA each
    body's, CB c, IB IA, AB pA, UB U, DB (D, u), YB, MB, XB, SB scratch, TB qdd."""
    n = P.shape[0] - 1
    L = int(P[n, LANES])                 # lanes (= B), read at run time on purpose
    nl = min(L, out.shape[0] - k0)
    QV, WB = stack_empty((3 * n + 1, L)), stack_empty((W_ALL, L))
    RB, PB, VB = stack_empty((9 * n, L)), stack_empty((3 * n, L)), stack_empty((6, L))
    VA = stack_empty((6 * n, L))
    CB, IB, AB = stack_empty((6 * n, L)), stack_empty((36 * n, L)), stack_empty((6 * n, L))
    UB, DB, TB = stack_empty((6 * n, L)), stack_empty((2 * n, L)), stack_empty((n, L))
    YB, SB = stack_empty((27, L)), stack_empty((2, L))
    MB, XB = stack_empty((36, L)), stack_empty((6, L))
    flags &= F.QD | F.WRENCH | F.BASE
    small, fin = gather(P, q, qd, tau, w, flags | F.QDD, QV, WB, k0, nl)   # tau as qdd's rows
    velocity_pass(P, QV, WB, RB, PB, VB, VA, CB, IB, AB, flags, nl, small, nb)
    inertia_pass(P, QV, RB, PB, CB, IB, AB, UB, DB, YB, SB, nl, nb)
    acceleration_pass(P, QV, WB, RB, PB, VB, VA, CB, IB, AB, UB, DB, MB, XB, SB, TB, flags, nl, nb)
    scatter(TB, out, k0, nl)
    return OK if fin else NOT_FINITE


@internal(i8(Pm, In2, In2, In2, In2, i8, Out2, i8))
def aba_block(P, q, qd, tau, w, flags, out, k0):
    """``lanes_block`` on a fixed base (``aba.aba_core``, ``tree_aba_core`` in every lane)."""
    return lanes_block(P, q, qd, tau, w, flags, out, k0, 0)


@internal(i8(Pm, In2, In2, In2, In2, i8, Out2, i8))
def floating_aba_block(P, q, qd, tau, w, flags, out, k0):
    """``lanes_block`` with a free-flyer root (``floating_aba_core``, ``floating_tree_aba_core``)."""
    return lanes_block(P, q, qd, tau, w, flags, out, k0, 6)
