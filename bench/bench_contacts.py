"""Contacts (issue 51): a fixed-step simulation of Solo12 standing on the ground against
MuJoCo's mj_step and Pinocchio's ADMM constraint solver from Python, and constrained
forward dynamics single calls against Pinocchio's constraintDynamics.

    python bench/bench_contacts.py [--quick] [--no-write]

Writes the section "contacts" of bench/BENCHMARKS.md. The Pinocchio models of our contacts
are the tests' (test/contacts/contact_cases.py); each constrained-dynamics row first checks
that both libraries agree (1e-9 relative) on the state it times.
"""
import argparse
import os
import re
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
TESTS = os.path.join(HERE, "..", "test")
sys.path[:0] = [HERE, TESTS, os.path.join(TESTS, "contacts")]   # the tests' Pinocchio models
import mujoco                                                   # noqa: E402
import pinocchio as pin                                         # noqa: E402
import serial_dynamics as sd                                    # noqa: E402
from serial_dynamics.contacts.stepper import GroundStepper     # noqa: E402
from _report import stamp, write_section                        # noqa: E402
from bench_speed import agree, erd_path, fmt_t, pair            # noqa: E402
from contact_cases import FEET, SOLO, Panda, Solo, constraint, pin_constrained  # noqa: E402

DT, FRICTION = 1e-3, 1.0
QJ = np.array([0, 0.8, -1.6, 0, 0.8, -1.6, 0, -0.8, 1.6, 0, -0.8, 1.6])   # standing
KP, KD = 5.0, 0.1                                               # the PD on the joints
FOOT_RADIUS = 1e-3        # m: MuJoCo's foot spheres (ours are points, radius 0)


def standing():
    """Solo12 on its four feet (base at the height that puts the lowest foot on the ground),
    the joint torques of contact inverse dynamics that hold it, and the control law."""
    robot = sd.load_urdf(erd_path(SOLO), floating_base=True)
    q0 = np.r_[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, QJ]
    q0[2] = -min(robot.forward_kinematics(q0, f)[2, 3] for f in FEET)
    feet = [sd.Contact(f) for f in FEET]
    still = np.zeros(robot.nv)
    tau, _ = robot.contact_inverse_dynamics(q0, still, still, feet, friction=FRICTION)
    return robot, q0, feet, tau[6:]


def control(tau0, qj, vj):
    """Contact inverse dynamics' torques plus a PD towards the standing posture."""
    return tau0 + KP * (QJ - qj) - KD * vj


# ------------------------------------------------------------------ ours
def ours_simulate(robot, q0, feet, tau0, steps, feedback=True):
    """Seconds per step of sd.simulate (semi-implicit Euler, ground) and the base's largest
    drift from q0 (m): the control a callable (``feedback``), else the standing torques
    alone, known in advance (no PD: no Python in the loop, the whole run one compiled call)."""
    def torque(t, q, v):
        return control(tau0, q[7:], v[6:])
    kw = dict(torque=torque if feedback else tau0, ground=sd.Ground(friction=FRICTION),
              contacts=feet, method="semi_implicit_euler", dt=DT)
    sd.simulate(robot, 20 * DT, q0, **kw)                       # warm
    t0 = time.perf_counter()
    res = sd.simulate(robot, steps * DT, q0, **kw)
    wall = (time.perf_counter() - t0) / steps
    assert feedback or "compiled loop" in res.stats.message
    return wall, float(np.max(np.abs(res.q[:, :3] - q0[:3])))


def ours_stepper(robot, q0, feet, tau0, steps):
    """Seconds per GroundStepper.step (the simulator node's step), the control in the loop."""
    stepper = GroundStepper(robot, sd.Ground(friction=FRICTION), feet, DT)
    q, v = q0.copy(), np.zeros(robot.nv)
    for _ in range(20):
        q, v = stepper.step(q, v, control(tau0, q[7:], v[6:]))
    q, v = q0.copy(), np.zeros(robot.nv)
    t0 = time.perf_counter()
    drift = 0.0
    for _ in range(steps):
        q, v = stepper.step(q, v, control(tau0, q[7:], v[6:]))
        drift = max(drift, float(np.max(np.abs(q[:3] - q0[:3]))))
    return (time.perf_counter() - t0) / steps, drift


# ------------------------------------------------------------------ MuJoCo
def mujoco_model():
    """Solo12 compiled by MuJoCo's own URDF importer from the same file: every <visual> and
    <collision> element removed (their meshes), static bodies kept (fusestatic false, so
    the feet stay bodies); then a free joint on base_link, a sphere of FOOT_RADIUS at each
    foot's origin (condim 3: a point with friction FRICTION), a floor plane, dt = 1 ms,
    elliptic friction cones (ours are exact discs), the default Newton solver and Euler
    integrator."""
    text = open(erd_path(SOLO)).read()
    text = re.sub(r"<(visual|collision)>.*?</\1>", "", text, flags=re.S)
    text = text.replace("</robot>", '<mujoco><compiler fusestatic="false" '
                        'discardvisual="true"/></mujoco></robot>')
    spec = mujoco.MjSpec.from_string(text)
    spec.body("base_link").add_freejoint()
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1],
                            friction=[FRICTION, 0, 0], condim=3)
    for f in FEET:
        spec.body(f).add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[FOOT_RADIUS, 0, 0],
                              friction=[FRICTION, 0, 0], condim=3, mass=0)
    spec.option.timestep = DT
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    return spec.compile()


def mujoco_steps(robot, q0, tau0, steps):
    """Seconds per mj_step (the control written to qfrc_applied in the loop), the base's
    drift, and the model's mass against ours."""
    m = mujoco_model()
    d = mujoco.MjData(m)
    qa = [m.joint(n).qposadr[0] for n in robot.joint_names]
    va = [m.joint(n).dofadr[0] for n in robot.joint_names]
    start = np.zeros(m.nq)
    start[:7] = [q0[0], q0[1], q0[2] + FOOT_RADIUS, 1.0, 0.0, 0.0, 0.0]   # quaternion w x y z
    start[qa] = QJ

    def run(n):
        d.qpos[:], d.qvel[:] = start, 0.0
        mujoco.mj_forward(m, d)
        drift = 0.0
        t0 = time.perf_counter()
        for _ in range(n):
            d.qfrc_applied[va] = control(tau0, d.qpos[qa], d.qvel[va])
            mujoco.mj_step(m, d)
            drift = max(drift, float(np.max(np.abs(d.qpos[:3] - start[:3]))))
        return (time.perf_counter() - t0) / n, drift
    run(20)
    wall, drift = run(steps)
    return wall, drift, float(m.body_mass.sum())


# ------------------------------------------------------------------ Pinocchio's ADMM
def pinocchio_steps(robot, q0, tau0, steps):
    """Seconds per step of the same time stepping written in Python on Pinocchio 4.1: the free
    velocity v_f = v + dt aba(q, v, tau), the four feet as PointContactConstraintModel
    (friction FRICTION, the contact frame's z the world's vertical at the standing pose,
    always active: no collision detection; ``calc`` each step), G = J M^-1 J^T (getConstraintsJacobian,
    computeMinverse), impulses by ADMMConstraintSolver on G and g = J v_f (warm-started),
    v+ = v_f + M^-1 J^T lambda, q+ = integrate(q, dt v+)."""
    s = Solo(gravity=robot.gravity)
    pm, pd = s.pm, s.pd
    q, v = s.q(q0), np.zeros(pm.nv)
    pin.framesForwardKinematics(pm, pd, q)
    cms, cds = pin.StdVec_ConstraintModel(), pin.StdVec_ConstraintData()
    for f in FEET:
        fr = pm.frames[pm.getFrameId(f)]
        R = pd.oMi[fr.parentJoint].rotation
        # the constraint's rows are joint2's velocity minus joint1's (the world's minus the
        # foot's) in this frame's axes, and its cone is about their z: the frame turned by pi
        # about x from the world's axes at q0, so z is the foot's upward speed
        placement = pin.SE3(R.T @ np.diag([1.0, -1.0, -1.0]), fr.placement.translation)
        world = pd.oMi[fr.parentJoint] * placement
        cm = pin.PointContactConstraintModel(pm, fr.parentJoint, placement, 0, world)
        cm.setFriction(FRICTION)
        cms.append(cm)
        cds.append(cms[len(cms) - 1].createData())
    m = 3 * len(FEET)
    solver = pin.ADMMConstraintSolver(m)
    settings = pin.ADMMSolverSettings()
    settings.absolute_feasibility_tol = settings.absolute_complementarity_tol = 1e-9
    settings.relative_feasibility_tol = settings.relative_complementarity_tol = 1e-9
    result = pin.ADMMSolverResult()
    joints = s.idx[6:]

    def step(q, v):
        tau = np.zeros(pm.nv)
        tau[joints] = control(tau0, q[s.iq], v[joints])
        v_f = v + DT * pin.aba(pm, pd, q, v, tau)
        pin.computeJointJacobians(pm, pd, q)
        for cm, cd in zip(cms, cds):
            cm.calc(pm, pd, cd)
        J = pin.getConstraintsJacobian(pm, pd, cms, cds)
        Minv = pin.computeMinverse(pm, pd, q)
        Minv = np.triu(Minv) + np.triu(Minv, 1).T
        MJt = Minv @ J.T
        solver.solve(pin.DelassusOperatorDense(J @ MJt), J @ v_f, cms, cds, settings, result)
        v1 = v_f + MJt @ result.retrieveConstraintImpulses()
        return pin.integrate(pm, q, DT * v1), v1

    for _ in range(20):
        q, v = step(q, v)
    q, v = s.q(q0), np.zeros(pm.nv)
    drift = 0.0
    t0 = time.perf_counter()
    for _ in range(steps):
        q, v = step(q, v)
        drift = max(drift, float(np.max(np.abs(q[:3] - q0[:3]))))
    return (time.perf_counter() - t0) / steps, drift


# ------------------------------------------------------------------ single calls
def constrained_rows(rounds):
    """constrained_forward_dynamics against constraintDynamics (initConstraintDynamics once,
    ProximalSettings(1e-12, 1e-6, 100), our defaults), one state each."""
    rows = []
    rng = np.random.default_rng(0)
    for name, case, contacts, what in [
            ("Solo12", Solo(), [sd.Contact(f) for f in FEET], "four feet, 3D"),
            ("Panda (fingers held)", Panda(), [sd.Contact("panda_hand", frame=True)],
             "hand, 6D")]:
        robot = case.robot
        q, v = case.state(rng)
        tau = rng.normal(size=robot.nv)
        a, f = robot.constrained_forward_dynamics(q, v, tau, contacts)
        a_pin, f_pin = pin_constrained(case, q, v, tau, contacts)
        agree(a, a_pin, f"{name} accelerations")
        agree(f.reshape(-1), f_pin, f"{name} forces")
        cms, cds = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
        for c in contacts:
            cms.append(constraint(case.pm, c))
            cds.append(cms[len(cms) - 1].createData())
        pin.initConstraintDynamics(case.pm, case.pd, cms, cds)
        settings = pin.ProximalSettings(1e-12, 1e-6, 100)
        pq, pv, pt = case.q(q), case.v(v), case.v(tau)
        t_ours, t_pin = pair(lambda: robot.constrained_forward_dynamics(q, v, tau, contacts),
                             lambda: pin.constraintDynamics(case.pm, case.pd, pq, pv, pt, cms,
                                                            cds, settings), 300, rounds)
        rows.append((name, what, t_ours, t_pin))
    return rows


def cpu_family():
    """The CPU's model name and family, from /proc/cpuinfo."""
    info = {}
    with open("/proc/cpuinfo") as fh:
        for line in fh:
            key, _, value = line.partition(":")
            info.setdefault(key.strip(), value.strip())
    return f"{info.get('model name', '?')}, CPU family {info.get('cpu family', '?')}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--no-write", action="store_true")
    args = ap.parse_args()
    steps, rounds, reps = (300, 5, 1) if args.quick else (1000, 20, 5)
    robot, q0, feet, tau0 = standing()
    robot.warmup(kinematics=True)
    load = os.getloadavg()[0]
    runs = []                           # each simulation `reps` times, in turn: min of each
    for _ in range(reps):
        runs.append((*ours_simulate(robot, q0, feet, tau0, steps),
                     *ours_stepper(robot, q0, feet, tau0, steps),
                     *mujoco_steps(robot, q0, tau0, steps),
                     *pinocchio_steps(robot, q0, tau0, steps),
                     *ours_simulate(robot, q0, feet, tau0, steps, feedback=False)))
    t_sim, d_sim, t_step, d_step, t_mj, d_mj, mass_mj, t_pin, d_pin, t_run, d_run = runs[0]
    t_sim, t_step, t_mj, t_pin, t_run = (min(r[i] for r in runs) for i in (0, 2, 4, 7, 9))
    single = constrained_rows(rounds)
    load = max(load, os.getloadavg()[0])
    mass = robot.model.base_mass + robot.model.mass.sum()
    out = ["## Contacts: Solo12 standing against MuJoCo and Pinocchio (`bench/bench_contacts.py`)",
           "", stamp(),
           f"One run, while the machine ({cpu_family()}) was shared with other jobs (1-minute "
           f"load average up to {load:.1f} on its 2 cores). Targets (issue 51): a step <= 1.5x MuJoCo's "
           "`mj_step` and ahead of Pinocchio's ADMM from Python; constrained forward dynamics "
           "single calls <= 1.0x `constraintDynamics`.", "",
           f"### A fixed-step simulation of Solo12 standing ({steps} steps of 1 ms)", "",
           f"Each simulation run {reps} times, in turn; the time per step is the least of "
           "the runs'.", "",
           "Solo12 (example-robot-data's URDF) on a floating base, its four feet (`FL_FOOT` .. "
           "`HR_FOOT` origins) on a ground with friction 1.0, its joints driven by contact "
           f"inverse dynamics' standing torques plus a PD ({KP:g} N m/rad, {KD:g} N m s/rad) "
           "computed in Python at every step, from rest in the standing pose. Drift: the "
           "base's largest displacement over the run.", "",
           "- **ours**: `sd.simulate(..., ground=sd.Ground(friction=1.0), contacts=feet, "
           "method='semi_implicit_euler', dt=1e-3)` (velocity-level time stepping: all contacts "
           "sticking solved at once, else projected Gauss-Seidel), each step one compiled "
           "call (`contacts/compiled_step.py`) between the calls of the control, and "
           "`GroundStepper.step` alone (the simulator node's step, the same call); a third "
           "row, not like for like, `sd.simulate` with the torques known in advance (the "
           "standing torques alone, no PD): the whole run one compiled call, no Python in "
           "the loop;",
           "- **MuJoCo** " + mujoco.__version__ + ": the same URDF compiled by MuJoCo's own "
           "URDF importer (`MjSpec.from_string`) with every `<visual>` and `<collision>` "
           "element removed (meshes dropped) and `fusestatic=\"false\"`, then a free joint on "
           f"`base_link`, a {FOOT_RADIUS * 1e3:g} mm sphere at each foot's origin (condim 3, "
           "friction 1.0), a floor plane, `timestep` 1 ms, elliptic cones, default Newton "
           f"solver and Euler integrator ({mass_mj:.4f} kg against our {mass:.4f} kg); the "
           "control written to `qfrc_applied` before each `mj_step` (its drift: the feet "
           "sinking into its soft contacts);",
           "- **Pinocchio** " + pin.__version__ + " from Python: the same time stepping "
           "written on its 4.1 API — v_f = v + dt `aba`, the feet as "
           "`PointContactConstraintModel` (friction 1.0, always active), G = J M⁻¹ Jᵀ from "
           "`getConstraintsJacobian` and `computeMinverse`, impulses by "
           "`ADMMConstraintSolver.solve` on `DelassusOperatorDense(G)` and J v_f "
           "(tolerances 1e-9), v⁺ = v_f + M⁻¹ Jᵀ λ, `integrate`.", "",
           "| simulation | per step | ours / peer | base drift |", "|---|---|---|---|",
           f"| ours: `sd.simulate` | {fmt_t(t_sim)} | — | {d_sim:.1e} m |",
           f"| ours: `GroundStepper.step` | {fmt_t(t_step)} | — | {d_step:.1e} m |",
           f"| ours: `sd.simulate`, torques known in advance (one compiled call) | "
           f"{fmt_t(t_run)} | — | {d_run:.1e} m |",
           f"| MuJoCo `mj_step` | {fmt_t(t_mj)} | {t_sim / t_mj:.1f}x (`simulate`), "
           f"{t_step / t_mj:.1f}x (stepper) | {d_mj:.1e} m |",
           f"| Pinocchio ADMM from Python | {fmt_t(t_pin)} | {t_sim / t_pin:.2f}x (`simulate`), "
           f"{t_step / t_pin:.2f}x (stepper) | {d_pin:.1e} m |", "",
           "### `constrained_forward_dynamics` against `constraintDynamics`, one state", "",
           "A random state of the tests' models (`test/contacts/contact_cases.py`: gravity "
           "tilted); Pinocchio's `initConstraintDynamics` once, then timed calls with "
           "`ProximalSettings(1e-12, 1e-6, 100)` (our defaults' numbers; its mu is absolute, "
           "ours relative); both agree to 1e-9 first. "
           "Interleaved, min of rounds.", "",
           "| robot | contacts | ours | Pinocchio | ratio |", "|---|---|---|---|---|"]
    for name, what, a, b in single:
        out.append(f"| {name} | {what} | {fmt_t(a)} | {fmt_t(b)} | {a / b:.1f} |")

    def verdict(ratio, target):
        return (f"met ({ratio:.2f}x <= {target:g}x)" if ratio <= target else
                f"**missed** ({ratio:.2f}x against {target:g}x: {ratio / target:.1f} times over)")
    step = min(t_sim, t_step)
    out += ["", "Against the targets (the faster of our two step rows):", "",
            f"- a step <= 1.5x MuJoCo's: {verdict(step / t_mj, 1.5)};",
            f"- ahead of Pinocchio's ADMM from Python: {verdict(step / t_pin, 1.0)};"]
    out += [f"- {name} constrained forward dynamics <= 1.0x `constraintDynamics`: "
            f"{verdict(a / b, 1.0)};" for name, _, a, b in single]
    out[-1] = out[-1][:-1] + "."
    out += ["", "Our step is one compiled call (`contacts/compiled_step.py`: M, b, the free "
            "velocity, the feet's kinematics, G, the sticking solve or PGS, the chart's update "
            "of q), as the peers' are one compiled call each (`mj_step`) or a few (Pinocchio's "
            "ADMM loop: `aba`, the constraints' `calc`, `computeMinverse`, the solver); the "
            "rest of a row's time is Python's: the control's call and, in `sd.simulate`, "
            "recording the step. Our `constrained_forward_dynamics` of one state is one "
            "compiled call (`contacts/compiled.py`), as `constraintDynamics` is."]
    text = "\n".join(out) + "\n"
    print(text)
    if not args.no_write:
        write_section("contacts", text)


if __name__ == "__main__":
    main()
