"""A free-floating base: speed against Pinocchio's free-flyer, and the simulator's momentum
and energy drift against cost on the satellite scene.

    python bench/bench_floating.py [--quick] [--no-write]

Writes the section "floating" of bench/BENCHMARKS.md. Every row first checks that both
libraries agree (1e-9 relative) on the state it times.
"""
import argparse
import os
import sys
import time
import warnings

import numpy as np
import pinocchio as pin

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import serial_dynamics as sd                                   # noqa: E402
from serial_dynamics.builtin.synthetic import chain_urdf, satellite_urdf  # noqa: E402
from _report import stamp, write_section                        # noqa: E402
from bench_speed import agree, erd_path, fmt_t, pair            # noqa: E402

N_BATCH = 10_000


class PinFree:
    """Pinocchio's model of our chain on a JointModelFreeFlyer root (the joints off the
    chain locked at zero); our (q, v) in its layout (continuous joints: cos, sin)."""

    def __init__(self, robot, path=None, xml=None):
        root = pin.JointModelFreeFlyer()
        full = (pin.buildModelFromUrdf(path, root) if xml is None else
                pin.buildModelFromXML(xml, root))
        keep = set(robot.joint_names) | {"root_joint"}
        lock = [full.getJointId(n) for n in full.names[1:] if n not in keep]
        self.model = pin.buildReducedModel(full, lock, pin.neutral(full)) if lock else full
        self.model.gravity.linear[:] = robot.gravity
        self.data = self.model.createData()
        jid = [self.model.getJointId(n) for n in robot.joint_names]
        self.iq = [(self.model.idx_qs[j], self.model.nqs[j]) for j in jid]
        self.iv = np.r_[0:6, [self.model.idx_vs[j] for j in jid]]

    def q(self, Q):
        Q = np.atleast_2d(Q)
        out = np.tile(pin.neutral(self.model), (Q.shape[0], 1))
        out[:, :7] = Q[:, :7]
        for k, (i, nq) in enumerate(self.iq):
            if nq == 2:
                out[:, i], out[:, i + 1] = np.cos(Q[:, 7 + k]), np.sin(Q[:, 7 + k])
            else:
                out[:, i] = Q[:, 7 + k]
        return out

    def v(self, X):
        X = np.atleast_2d(X)
        out = np.zeros((X.shape[0], self.model.nv))
        out[:, self.iv] = X
        return out


def robots():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        ur = sd.load_urdf(sd.builtin_path("ur5e"), floating_base=True)
        panda_path = erd_path("panda_description/urdf/panda.urdf")
        panda = sd.load_urdf(panda_path, "panda_link0", "panda_link8", floating_base=True)
    return [("UR5e", ur, PinFree(ur, sd.builtin_path("ur5e"))),
            ("Panda", panda, PinFree(panda, panda_path))]


def single_rows(name, robot, pm, rounds):
    rng = np.random.default_rng(0)
    q, v = robot.random_state(rng, speed=2.0)
    a = rng.normal(size=robot.nv)
    tau_j = rng.normal(size=robot.dof)
    m, d, iv = pm.model, pm.data, pm.iv
    pq, pv, pa = pm.q(q)[0], pm.v(v)[0], pm.v(a)[0]
    pt = pm.v(np.r_[np.zeros(6), tau_j])[0]
    agree(robot.inverse_dynamics(q, v, a), pin.rnea(m, d, pq, pv, pa)[iv], "rnea")
    Mp = pin.crba(m, d, pq)
    agree(robot.mass_matrix(q), (np.triu(Mp) + np.triu(Mp, 1).T)[np.ix_(iv, iv)], "crba")
    for method in ("aba", "cholesky"):
        agree(robot.forward_dynamics(q, v, tau_j, method=method), pin.aba(m, d, pq, pv, pt)[iv],
              "aba")
    rows = []
    for label, ours, peer, peer_name in [
        ("inverse dynamics", lambda: robot.inverse_dynamics(q, v, a),
         lambda: pin.rnea(m, d, pq, pv, pa), "pinocchio.rnea"),
        ("mass matrix", lambda: robot.mass_matrix(q),
         lambda: pin.crba(m, d, pq), "pinocchio.crba (upper triangle)"),
        ("forward dynamics (ABA, FDfb)", lambda: robot.forward_dynamics(q, v, tau_j, method="aba"),
         lambda: pin.aba(m, d, pq, pv, pt), "pinocchio.aba"),
        ("forward dynamics (Cholesky)",
         lambda: robot.forward_dynamics(q, v, tau_j, method="cholesky"),
         lambda: pin.aba(m, d, pq, pv, pt), "pinocchio.aba"),
    ]:
        t_ours, t_pin = pair(ours, peer, 2000, rounds)
        rows.append((name, f"{label}, one state", t_ours, t_pin, peer_name))
    return rows


def batch_rows(name, robot, pm, rounds):
    rng = np.random.default_rng(1)
    Q, V = robot.random_state(rng, batch=N_BATCH, speed=2.0)
    A = rng.normal(size=V.shape)
    TJ = rng.normal(size=(N_BATCH, robot.dof))
    m, d, iv = pm.model, pm.data, pm.iv
    PQ, PV, PA = pm.q(Q), pm.v(V), pm.v(A)
    PT = pm.v(np.c_[np.zeros((N_BATCH, 6)), TJ])
    agree(robot.inverse_dynamics(Q[:50], V[:50], A[:50]),
          np.array([pin.rnea(m, d, PQ[k], PV[k], PA[k]) for k in range(50)])[:, iv], "rnea")
    agree(robot.forward_dynamics(Q[:50], V[:50], TJ[:50]),
          np.array([pin.aba(m, d, PQ[k], PV[k], PT[k]) for k in range(50)])[:, iv], "aba")
    rows = []
    for label, ours, loop, peer_name in [
        ("inverse dynamics", lambda: robot.inverse_dynamics(Q, V, A),
         lambda: [pin.rnea(m, d, PQ[k], PV[k], PA[k]) for k in range(N_BATCH)], "pinocchio.rnea"),
        ("mass matrix", lambda: robot.mass_matrix(Q),
         lambda: [pin.crba(m, d, PQ[k]) for k in range(N_BATCH)], "pinocchio.crba"),
        ("forward dynamics", lambda: robot.forward_dynamics(Q, V, TJ),
         lambda: [pin.aba(m, d, PQ[k], PV[k], PT[k]) for k in range(N_BATCH)], "pinocchio.aba"),
    ]:
        t_ours, t_pin = pair(ours, loop, 1, rounds)
        rows.append((name, f"{label}, {N_BATCH:,} states (per state)", t_ours / N_BATCH,
                     t_pin / N_BATCH, f"{peer_name} in a Python loop"))
    return rows


def crossover(rounds):
    """Single-call forward dynamics of a floating chain of n joints, ABA against Cholesky."""
    rows = []
    for n in (6, 12, 18, 24, 30, 40):
        body = ('<link name="base_link"><inertial><mass value="10"/><inertia ixx="0.2" '
                'iyy="0.2" izz="0.2" ixy="0" ixz="0" iyz="0"/></inertial></link>')
        robot = sd.load_urdf(chain_urdf(n).replace('<link name="base_link"/>', body),
                             floating_base=True)
        q, v = robot.random_state(2)
        tau = np.random.default_rng(3).normal(size=robot.dof)
        ta, tc = pair(lambda: robot.forward_dynamics(q, v, tau, method="aba"),
                      lambda: robot.forward_dynamics(q, v, tau, method="cholesky"), 500, rounds)
        rows.append((n, ta, tc))
    return rows


def satellite_drift(quick):
    """Momentum and energy drift against cost: the satellite in zero gravity, its joints
    driven by a PD sweep (0.8 rad at 0.5 rad/s), 10 s, every method."""
    robot = sd.load_urdf(satellite_urdf(), gravity=(0, 0, 0))
    D = np.diag(robot.mass_matrix(robot.neutral()))[6:]

    def torque(t, q, v):
        return 4.0 * D * (0.8 * np.sin(0.5 * t + np.arange(robot.dof)) - q[7:]) - 2.8 * D * v[6:]
    v0 = np.r_[0.01, 0.0, -0.02, 0.01, -0.02, 0.015, np.full(robot.dof, 0.1)]
    runs = [("DOP853", dict(rtol=1e-12, atol=1e-12)), ("DOP853", dict(rtol=1e-9, atol=1e-9)),
            ("DOP853", {}), ("RK45", {}), ("Radau", {}), ("BDF", {}), ("LSODA", {}),
            ("rk4", dict(dt=1e-2)), ("rk4", dict(dt=1e-3)),
            ("semi_implicit_euler", dict(dt=1e-3)), ("semi_implicit_euler", dict(dt=1e-4))]
    if quick:
        runs = runs[:3] + runs[7:9]
    rows = []
    for method, kw in runs:
        t0 = time.perf_counter()
        res = sd.simulate(robot, 10.0, robot.neutral(), v0, torque=torque, method=method,
                          dissipation=False, **kw)
        wall = time.perf_counter() - t0
        h = robot.centroidal_momentum(res.q, res.qd)
        drift = np.max(np.abs(h - h[0])) / np.max(np.abs(h[0]))
        quat = np.max(np.abs(np.linalg.norm(res.q[:, 3:7], axis=1) - 1.0))
        setting = ", ".join(f"{k} = {v:g}" for k, v in kw.items()) or "defaults (1e-6, 1e-9)"
        rows.append((method, setting, drift, res.relative_energy_error(), quat,
                     res.stats.dynamics_states, wall))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    rounds = 5 if args.quick else 20
    single, batch = [], []
    for name, robot, pm in robots():
        robot.warmup()
        single += single_rows(name, robot, pm, rounds)
        batch += batch_rows(name, robot, pm, max(3, rounds // 5))
    cross = crossover(rounds)
    drift = satellite_drift(args.quick)
    out = ["## A free-floating base (`bench/bench_floating.py`)", "", stamp(),
           "Our `FloatingRobot` (compiled: `core/floating.py`'s conversions to the instantaneous "
           "chain, whose kernels take the base's six coordinates as one free-flyer root joint) against Pinocchio's `JointModelFreeFlyer` root, same states, "
           "in the same run (interleaved, min of rounds); both agree to 1e-9 on each timed "
           "state. Targets (issue 19): single calls no slower than Pinocchio from Python "
           "(ratio <= 1), batches <= 0.3x its Python loop.", "",
           "| robot | call | ours | Pinocchio | ratio | peer call |", "|---|---|---|---|---|---|"]
    for name, label, a, b, peer in single + batch:
        out.append(f"| {name} | {label} | {fmt_t(a)} | {fmt_t(b)} | {a / b:.2f} | {peer} |")
    out += ["", "### Forward dynamics of a floating chain: articulated bodies against Cholesky",
            "", "Single calls, `chain_urdf(n)` on a floating base of 10 kg (n joints + 6).", "",
            "| joints | ABA (FDfb) | Cholesky of M | ABA / Cholesky |", "|---|---|---|---|"]
    for n, ta, tc in cross:
        out.append(f"| {n} | {fmt_t(ta)} | {fmt_t(tc)} | {ta / tc:.2f} |")
    out += ["", "### Satellite scene: momentum and energy drift against cost",
            "", "`satellite_urdf()` (a 400 kg, 1.5 m cube with a 7-joint, 26 kg arm), zero "
            "gravity, the joints driven by a PD sweep, 10 s. Momentum drift: max |h(t) - h(0)| "
            "/ max |h(0)| of the centroidal momentum (exactly conserved); energy: the balance "
            "E(t) - E(0) - W_act relative to the energy scale; quaternion: max | |quat| - 1 |.",
            "", "| method | setting | momentum drift | energy balance | quaternion | dynamics "
            "evaluations | wall time |", "|---|---|---|---|---|---|---|"]
    for method, setting, dr, en, qu, states, wall in drift:
        out.append(f"| {method} | {setting} | {dr:.1e} | {en:.1e} | {qu:.0e} | {states:,} | "
                   f"{wall:.2f} s |")
    text = "\n".join(out) + "\n"
    print(text)
    if not args.no_write:
        write_section("floating", text)


if __name__ == "__main__":
    main()
