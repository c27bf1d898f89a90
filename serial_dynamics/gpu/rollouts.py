"""``sweep.monte_carlo(..., device="cuda")``: every case of a Monte-Carlo study as one CUDA
thread, the whole closed loop on the card.

A thread holds its case's plant (the packed model ``P`` with the case's masses scaled and
its payload on, ``plants``) and runs, at each step k of the fixed step dt, what the CPU
runs through ``simulate`` and ``control.torque`` (``sweep/robustness.Study``):

    tau_k = ID_nominal(q, qd, qdd_d + Kp e + Kd edot) - delta_nominal(qd_d)   (computed torque)
            g_nominal(q) - delta_nominal(qd_d)                               (gravity comp.)
    u_k   = clip(tau_k, -tau_max, tau_max)                                   (the drive)
    qdd   = M_plant(q)^-1 (u_k - beta qd - b_plant(q, qd))                   (plant, Cholesky)
    qd1   = qd + dt qdd,  q1 = q + dt qd1                                    (semi-implicit Euler)

with the nominal and the plant's dynamics on the same joint transforms (one kinematic
pass a step: the plant differs in its inertias only), the state check of
``Equations.check_state`` after each step and the energy guard of ``EnergyGuard`` at its
check points (T = 1/2 qd^T M qd, V = -g . sum (m_i o_i + R_i h_i), the actuators' work
dt u . qd1 a step). The tracking error's sums and maxima are kept as the loop goes; the
host turns them into the rows ``Study.__call__`` returns, the messages of a diverged run
by ``sim/equations``' own ``state_error`` and ``energy_error``.

The steps are the device functions of ``gpu/rnea.py`` and ``gpu/crba.py`` (the compiled
core's own steps); the loop itself is written here because a CUDA thread cannot call the
CPU's ``FixedStepIntegrator`` (Python objects, NumPy's allocations). What the card does
not run yet, refused by name: Coulomb friction (the stick-slip active set of
``Equations.modes``), the pd_gravity law (its gains need an eigenvalue per step), mimic
joints and a floating base.

Agreement: the same operations in the same order as the CPU, but the card contracts
a * b + c into one fused multiply-add where the CPU rounds twice, so the last bits differ
and grow along a run; the outcomes agree with the CPU's to about 1e-12 relative on a
stable loop (test/gpu/test_rollouts.py asserts 1e-9). Run after run on one card the bits
are the same: one thread computes one case, in a fixed order.
"""
from __future__ import annotations

import math
import sys
from functools import lru_cache

import numpy as np
import pandas as pd
from numba import float64

from ..core import layout
from ..core.layout import G, H, IO, MASS, WIDTH
from ..model.model import inertia_in_joint_frames
from ..sim.equations import (PRISMATIC_BOUND, Equations, energy_error, energy_scale_static,
                             state_error)
from .crba import crba_pass
from .rnea import base_acc, passes
from .runtime import cuda, free_bytes, launch, require_card
from .steps import cholesky_factor, cholesky_solve_factored

LAWS = ("computed_torque", "gravity_compensation")
CHUNK = 1 << 16             # cases a launch (progress between launches)
# out[s, :]: the case's scalars
PEAK, SATURATED, LOST_ROW, FAIL, FAIL_STEP, FAIL_JOINT, FAIL_VALUE, FAIL_EXCESS, FAIL_SCALE = range(9)
OUTS = 9
FAIL_CODES = (None, "nan_q", "nan_qd", "speed", "position", "energy")


@lru_cache(maxsize=None)
def kernel(n, chain, law, check_every):
    """The rollout kernel for n bodies, one of ``LAWS``, the energy checked every
    ``check_every`` steps."""
    transforms, newton_euler = passes(n, chain)
    crba = crba_pass(n, chain)
    ns, rows_p = (1 if chain else n), n + 1
    computed_torque = law == "computed_torque"

    @cuda.jit(device=True)
    def energy(P, parent, R, p, Rw, ow, M, qd):
        """T + V at the state whose transforms are R, p and mass matrix M (as
        ``Robot.kinetic_energy`` and ``algorithms.energy.potential_energy``)."""
        T = 0.0
        for i in range(n):
            s = 0.0
            for j in range(n):
                s += M[i, j] * qd[j]
            T += qd[i] * s
        V = 0.0
        for i in range(n):           # world pose: R0_i = R0_pa R_i, o_i = o_pa + R0_pa p_i
            pa = i - 1 if chain else parent[i]
            for r in range(3):
                if pa < 0:
                    ow[i, r] = p[i, r]
                    for c in range(3):
                        Rw[i, 3 * r + c] = R[i, 3 * r + c]
                else:
                    ow[i, r] = ow[pa, r] + (Rw[pa, 3 * r] * p[i, 0] + Rw[pa, 3 * r + 1] * p[i, 1]
                                            + Rw[pa, 3 * r + 2] * p[i, 2])
                    for c in range(3):
                        Rw[i, 3 * r + c] = (Rw[pa, 3 * r] * R[i, c] + Rw[pa, 3 * r + 1] * R[i, 3 + c]
                                            + Rw[pa, 3 * r + 2] * R[i, 6 + c])
            for r in range(3):       # V = -g . (m_i o_i + R0_i h_i)
                mc = P[i, MASS] * ow[i, r] + (Rw[i, 3 * r] * P[i, H] + Rw[i, 3 * r + 1] * P[i, H + 1]
                                              + Rw[i, 3 * r + 2] * P[i, H + 2])
                V -= P[n, G + r] * mc
        return 0.5 * T + V

    @cuda.jit
    def rollout(Pn, parent, Pc, beta, Q0, QD_REF, QDD_REF, Q_REF, FF, kp, kd, limit, bound,
                prismatic, static, dt, nsteps, E2, EMAX, OUT):
        s = cuda.grid(1)
        if s >= Q0.shape[0]:
            return
        P = cuda.local.array((rows_p, WIDTH), float64)      # this case's plant
        for i in range(rows_p):
            for c in range(WIDTH):
                P[i, c] = Pc[s, i, c]
        q, qd = cuda.local.array(n, float64), cuda.local.array(n, float64)
        a, tau = cuda.local.array(n, float64), cuda.local.array(n, float64)
        u, b = cuda.local.array(n, float64), cuda.local.array(n, float64)
        zero = cuda.local.array(n, float64)
        R, p = cuda.local.array((n, 9), float64), cuda.local.array((n, 3), float64)
        f, st = cuda.local.array((n, 6), float64), cuda.local.array((ns, 9), float64)
        c10, M = cuda.local.array((n, 10), float64), cuda.local.array((n, n), float64)
        Rw, ow = cuda.local.array((n, 9), float64), cuda.local.array((n, 3), float64)
        e2, emax = cuda.local.array(n, float64), cuda.local.array(n, float64)
        for i in range(n):
            q[i], qd[i], zero[i], e2[i], emax[i] = Q0[s, i], 0.0, 0.0, 0.0, 0.0
        for j in range(OUTS):
            OUT[s, j] = 0.0
        lost, lost_row, peak, saturated = static[s, 1], -1, 0.0, 0
        gx, gy, gz = base_acc(Pn, n)
        transforms(P, q, R, p)
        crba(P, parent, R, p, c10, M)
        E0 = energy(P, parent, R, p, Rw, ow, M, qd)          # T0 = 0: the start is at rest
        W, wmax = 0.0, 0.0
        for k in range(nsteps + 1):
            # the tracking error of row k (the state before step k)
            far = False
            for i in range(n):
                e = abs(Q_REF[k, i] - q[i])
                e2[i] += e * e
                emax[i] = max(emax[i], e)
                far = far or e > lost
            if far and lost_row < 0:
                lost_row = k
            # the controller on the nominal model at the sample k (control.torque)
            transforms(P, q, R, p)
            if computed_torque:
                for i in range(n):
                    a[i] = QDD_REF[k, i] + kp[i] * (Q_REF[k, i] - q[i]) + kd[i] * (QD_REF[k, i] - qd[i])
                newton_euler(Pn, parent, R, p, f, st, qd, a, tau, gx, gy, gz)
            else:
                newton_euler(Pn, parent, R, p, f, st, zero, zero, tau, gx, gy, gz)
            hit = False
            for i in range(n):
                tau[i] -= FF[k, i]
                r = abs(tau[i]) / limit[i]
                peak = max(peak, r)
                hit = hit or r > 1.0
                u[i] = min(max(tau[i], -limit[i]), limit[i])
            if hit:
                saturated += 1
            if k == nsteps:                      # the run is over: its sums out
                for i in range(n):
                    E2[s, i], EMAX[s, i] = e2[i], emax[i]
                OUT[s, PEAK], OUT[s, SATURATED], OUT[s, LOST_ROW] = peak, saturated, lost_row
                return
            # the plant: qdd = M^-1 (u - beta qd - b), M = L L^T
            newton_euler(P, parent, R, p, f, st, qd, zero, b, gx, gy, gz)
            crba(P, parent, R, p, c10, M)
            for i in range(n):
                a[i] = (u[i] + (-beta[s, i] * qd[i])) - b[i]
            cholesky_factor(M)
            cholesky_solve_factored(M, a)
            w = 0.0
            for i in range(n):
                qd[i] += dt * a[i]
                q[i] += dt * qd[i]
                w += u[i] * qd[i]
            W += dt * w
            # Equations.check_state at t = (k + 1) dt
            code, j, worst = 0, 0, 0.0
            for i in range(n):
                if code == 0 and not (math.isfinite(q[i]) and math.isfinite(qd[i])):
                    code, j = (1 if not math.isfinite(q[i]) else 2), i
            if code == 0:
                for i in range(n):
                    x = abs(qd[i]) / bound[i]
                    if abs(qd[i]) > bound[i] and x > worst:
                        code, j, worst = 3, i, x
            if code == 0:
                for i in range(n):
                    x = prismatic[i] * abs(q[i])
                    if x > PRISMATIC_BOUND and x > worst:
                        code, j, worst = 4, i, x
            if code != 0:
                OUT[s, FAIL], OUT[s, FAIL_STEP], OUT[s, FAIL_JOINT] = code, k + 1, j
                OUT[s, FAIL_VALUE] = q[j] if code == 1 or code == 4 else qd[j]
                return
            # EnergyGuard at its check points and at the end
            if (k + 1) % check_every == 0 or k + 1 == nsteps:
                transforms(P, q, R, p)
                crba(P, parent, R, p, c10, M)
                wmax = max(wmax, abs(W))
                excess = energy(P, parent, R, p, Rw, ow, M, qd) - E0 - W
                scale = static[s, 0] + wmax + 1e-9
                if excess > 0.5 * scale:
                    j, fastest = 0, -1.0
                    for i in range(n):
                        if abs(qd[i]) > fastest:
                            j, fastest = i, abs(qd[i])
                    OUT[s, FAIL], OUT[s, FAIL_STEP], OUT[s, FAIL_JOINT] = 5, k + 1, j
                    OUT[s, FAIL_VALUE], OUT[s, FAIL_EXCESS], OUT[s, FAIL_SCALE] = qd[j], excess, scale
                    return

    return rollout


def refuse(study):
    """A NotImplementedError naming what of ``study`` the card does not run yet; else the
    nominal robot's ``Equations``."""
    robot, eq = study.nominal, None
    why = None
    if robot.is_floating:
        why = "a free-floating base"
    elif robot.model.has_mimic_joints:
        why = "mimic joints"
    elif study.law not in LAWS:
        why = f"the law {study.law!r} (its gains need an eigenvalue a step)"
    elif (eq := Equations(robot, True)).coulomb_on:
        why = "Coulomb friction (the stick-slip active set)"
    if why:
        raise NotImplementedError(
            f"sweep.monte_carlo(device='cuda'): {why} is not on the card yet; run the study "
            "with device='cpu' (Dask)")
    return eq


def plants(study, table):
    """(Pc, beta, q0, static): every case's packed plant (cases, n+1, WIDTH), viscous
    friction (cases, n), start (cases, n) and [energy scale, lost] (cases, 2), from the
    draws as ``Study.plant`` builds them (masses and inertias scaled per body, then the
    payload lumped into the tip body: m + m_p, h + m_p c, I_O + m_p (|c|^2 1 - c c^T),
    c the payload's center in the tip body's joint frame)."""
    robot, model = study.nominal, study.nominal.model
    n, N = robot.dof, len(table)
    s = np.stack([table[f"mass_scale_{link}"].to_numpy(float) for link in model.link_names], 1)
    mp = table["payload"].to_numpy(float)
    P0 = layout.pack(model)
    Pc = np.repeat(P0[None], N, axis=0)
    Pc[:, :n, MASS:IO + 6] *= s[:, :, None]
    tip, Rt, pt = model.frames[robot.tip_link]
    c_link = Rt @ np.asarray(study.payload_com, float) + pt   # in the tip body's link frame
    _, _, h1, I1 = inertia_in_joint_frames(model.A[tip], 1.0, c_link, np.zeros((3, 3)))
    Pc[:, tip, MASS] += mp
    Pc[:, tip, H:H + 3] += mp[:, None] * h1
    Pc[:, tip, IO:IO + 6] += mp[:, None] * np.array([I1[0, 0], I1[1, 1], I1[2, 2], I1[0, 1],
                                                     I1[0, 2], I1[1, 2]])
    mass = s * model.mass
    com = np.repeat(np.asarray(model.com, float)[None], N, axis=0)
    m_tip = mass[:, tip] + mp
    com[:, tip] = (mass[:, tip, None] * com[:, tip] + mp[:, None] * c_link) / np.where(
        m_tip > 0, m_tip, 1.0)[:, None]
    mass[:, tip] = m_tip
    static = np.stack([energy_scale_static(robot, mass, com), np.full(N, study.lost)], 1)
    beta = np.outer(table["friction_scale"].to_numpy(float), robot.dissipation.viscous) \
        if robot.dissipation.enabled else np.zeros((N, n))
    q0 = study.reference[0][0] + np.stack(
        [table[f"offset_{j}"].to_numpy(float) for j in robot.joint_names], 1)
    return Pc, np.ascontiguousarray(beta), q0, static


def run_study(study, table, progress=True):
    """The outcomes of ``study`` (a ``sweep.robustness.Study``) for the cases of ``table``,
    a DataFrame in case order with the columns of ``Study.__call__``'s rows, computed on
    the card."""
    robot, dt = study.nominal, study.dt
    eq = refuse(study)
    require_card()
    n, N = robot.dof, len(table)
    nsteps = len(study.t) - 1
    check_every = max(1, min(200, nsteps // 50))            # as run_fixed
    q_d, qd_d, qdd_d = (np.ascontiguousarray(x) for x in study.reference)
    limit = np.asarray(robot.effort_limit, float)
    shared = [cuda.to_device(x) for x in (
        layout.pack(robot.model), np.asarray(robot.model.parent, np.int64))]
    refs = [cuda.to_device(x) for x in (qd_d, qdd_d, q_d, np.ascontiguousarray(study.friction))]
    consts = [cuda.to_device(np.ascontiguousarray(x, float)) for x in (
        study.kp, study.kd, limit, eq.speed_bound, eq.prismatic.astype(float))]
    k = kernel(n, robot.model.is_chain, study.law, check_every)
    per_case = 8 * ((n + 1) * WIDTH + 5 * n + OUTS + 2)
    chunk = int(max(1, min(CHUNK, free_bytes() // (2 * per_case))))
    e2, emax, out = np.empty((N, n)), np.empty((N, n)), np.empty((N, OUTS))
    for a in range(0, N, chunk):
        z = min(N, a + chunk)
        Pc, beta, q0, static = plants(study, table.iloc[a:z])
        dev = [cuda.to_device(x) for x in (Pc, beta, q0)]
        E2, EMAX, OUT = (cuda.device_array((z - a, w)) for w in (n, n, OUTS))
        launch(k, z - a, shared[0], shared[1], dev[0], dev[1], dev[2], *refs, *consts,
               cuda.to_device(static), dt, nsteps, E2, EMAX, OUT)
        e2[a:z], emax[a:z], out[a:z] = E2.copy_to_host(), EMAX.copy_to_host(), OUT.copy_to_host()
        if progress and N > chunk:
            print(f"sweep (cuda): {z}/{N} cases", file=sys.stderr)
    return outcomes(study, eq.speed_bound, e2, emax, out)


def outcomes(study, bound, e2, emax, out):
    """The DataFrame of ``Study.__call__``'s rows (in ``sweep.run``'s column order: as
    they first appear) from the kernel's sums and scalars; ``bound`` the joints' speed
    bound (``Equations.speed_bound``)."""
    names = study.nominal.joint_names
    N, count, code = len(out), len(study.t), out[:, FAIL].astype(int)
    ran = code == 0
    e2, emax = np.where(ran[:, None], e2, 0.0), np.where(ran[:, None], emax, 0.0)  # unwritten
    cols = {"rms_error": np.sqrt(e2.sum(1) / (count * len(names))), "max_error": emax.max(1)}
    for j, name in enumerate(names):
        cols[f"rms_{name}"], cols[f"max_{name}"] = np.sqrt(e2[:, j] / count), emax[:, j]
    cols["peak_torque_ratio"] = out[:, PEAK]
    cols["saturation_time"] = out[:, SATURATED] * study.dt
    cols = {k: np.where(ran, v, np.nan) for k, v in cols.items()}
    far = ran & (cols["max_error"] > study.lost)
    at = np.where(far, study.t[np.maximum(out[:, LOST_ROW], 0).astype(int)], np.nan)
    reason = np.where(far, f"|e| > {study.lost:g}", "").astype(object)
    for s in np.flatnonzero(~ran):     # the simulator's verdict, in its own words
        t, j = out[s, FAIL_STEP] * study.dt, int(out[s, FAIL_JOINT])
        if FAIL_CODES[code[s]] == "energy":
            exc = energy_error(t, out[s, FAIL_EXCESS], out[s, FAIL_SCALE], names[j],
                               out[s, FAIL_VALUE], "semi_implicit_euler", study.dt)
        else:
            exc = state_error(t, names[j], FAIL_CODES[code[s]], out[s, FAIL_VALUE], bound[j],
                              "semi_implicit_euler", study.dt)
        at[s], reason[s] = exc.t, str(exc)
    verdict = {"diverged": far | ~ran, "diverged_at": at, "reason": reason}
    table = pd.DataFrame({**verdict, **cols} if N and not ran[0] else {**cols, **verdict})
    return table if ran.any() else table[list(verdict)]
