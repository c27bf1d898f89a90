"""Contacts with the ground one step at a time (contacts/stepper.py), as the simulator node
steps them: without the servo the steps are sd.simulate's (bit for bit, forces too); with
the joint servo, each step meets its equation of motion M a + b = tau + delta + tau_s +
sum_k J_k^T f_k with the servo torque it reports, which is the PD at the step's end
(Kp (q* - q1) + Kd (qd* - v1)): the servo is implicit with the contacts in one step, on a
floating base (Solo12 dropped onto its feet) and on a fixed one (a UR5e's tool pressed onto
a table); the session reports the forces of the step that reached its state, zeros after
~/reset; a bad set is refused with its name."""
import numpy as np
import pytest

from contact_cases import FEET, SOLO
from pin_reference import erd

import serial_dynamics as sd
from serial_dynamics.contacts.stepper import GroundSession, GroundStepper
from serial_dynamics.sim.servo import servo

DT = 1e-3
LEGS = np.array([0.0, 0.8, -1.6, 0.0, 0.8, -1.6, 0.0, -0.8, 1.6, 0.0, -0.8, 1.6])


@pytest.fixture(scope="module")
def solo():
    return sd.load_urdf(erd(SOLO), floating_base=True)


def dropped(robot, height=0.02):
    """Solo12's base pose with the feet of LEGS ``height`` above the ground."""
    q = np.r_[np.zeros(6), 1.0, LEGS]
    q[2] = height - min(robot.forward_kinematics(q, f)[2, 3] for f in FEET)
    return q[:7]


def test_without_the_servo_the_steps_are_simulates(solo):
    feet = [sd.Contact(f) for f in FEET]
    base = dropped(solo)
    tau = 0.3 * np.sin(np.arange(12.0))                     # some constant joint torques
    res = sd.simulate(solo, 0.15, np.r_[base, LEGS], torque=tau, ground=sd.Ground(friction=0.8),
                      contacts=feet, method="semi_implicit_euler", dt=DT)
    s = GroundSession(solo, LEGS, base_pose=base, ground=sd.Ground(friction=0.8),
                      contacts=feet, dt=DT)
    s.command(np.arange(12), tau)
    for k in range(150):
        s.step()
        np.testing.assert_array_equal(s.q, res.q[k + 1])
        np.testing.assert_array_equal(s.qd, res.qd[k + 1])
        np.testing.assert_array_equal(s.contact_forces()[1], res.contact_forces[k])
    assert res.contact_active[-1].all()                      # it has landed


def equation_of_motion(robot, stepper, q, v, q1, v1, tau):
    """max |M a + b - tau - delta - tau_s - sum J_P^T f| / max(1, |rhs|), a = (v1 - v) / dt."""
    nb = robot.nv - robot.dof
    rhs = np.r_[np.zeros(nb), tau + stepper.servo_torque
                + stepper.eq.delta(v[nb:], smooth=stepper.eq.coulomb_on)]
    for c, f in zip(stepper.contacts, stepper.forces):
        X, J = robot.forward_kinematics(q, c.link), robot.jacobian(q, c.link)
        r = X[:3, :3] @ np.array(c.point)
        rhs += (J[:3] - np.cross(r, J[3:].T).T).T @ f            # J_P = J_v - [r]x J_w
    lhs = robot.mass_matrix(q) @ (v1 - v) / stepper.dt + robot.bias_torques(q, v)
    return np.max(np.abs(lhs - rhs)) / max(1.0, np.max(np.abs(rhs)))


def run_with_servo(robot, q, stepper, tau, targets, steps):
    """``steps`` steps with the servo to ``targets``; the worst equation-of-motion residual,
    the worst servo torque error, and whether the contacts pushed."""
    n, nqb, nb = robot.dof, robot.nq - robot.dof, robot.nv - robot.dof
    kp, kd = np.full(n, 400.0), np.full(n, 5.0)
    s = servo(kp, kd, targets, np.zeros(n))
    v = np.zeros(robot.nv)
    worst = worst_servo = 0.0
    pushed = False
    for _ in range(steps):
        q1, v1 = stepper.step(q, v, tau, servo=s)
        worst = max(worst, equation_of_motion(robot, stepper, q, v, q1, v1, tau))
        pd = kp * (targets - q1[nqb:]) + kd * (0.0 - v1[nb:])  # the PD at the step's end
        worst_servo = max(worst_servo, np.max(np.abs(stepper.servo_torque - pd)))
        pushed |= stepper.active.any()
        q, v = q1, v1
    return worst, worst_servo, pushed


def test_the_servo_is_implicit_with_the_contacts_on_a_floating_base(solo):
    stepper = GroundStepper(solo, sd.Ground(), [sd.Contact(f) for f in FEET], DT)
    worst, worst_servo, pushed = run_with_servo(solo, np.r_[dropped(solo), LEGS], stepper,
                                                np.zeros(12), LEGS, 300)
    assert pushed and worst < 1e-9 and worst_servo < 1e-9


def test_the_servo_is_implicit_with_the_contacts_on_a_fixed_base():
    """The UR5e's servo presses a point 5 cm past its tool into a table 2 cm below it."""
    arm = sd.load_urdf(sd.builtin_path("ur5e"))
    q0 = np.array([0.0, -1.0, 1.2, -0.3, -1.57, 0.0])
    tip = sd.Contact("tool0", point=(0.0, 0.0, 0.05))
    X = arm.forward_kinematics(q0, "tool0")
    table = (X[:3, 3] + X[:3, :3] @ np.array(tip.point))[2] - 0.02
    stepper = GroundStepper(arm, sd.Ground(height=table, friction=0.5), [tip], DT)
    worst, worst_servo, pushed = run_with_servo(arm, q0, stepper, arm.gravity_torques(q0),
                                                q0 + np.array([0, 0.1, 0.1, 0, 0, 0]), 300)
    assert pushed and worst < 1e-9 and worst_servo < 1e-9


def test_the_session_reports_its_last_steps_forces_and_refuses_a_bad_set(solo):
    s = GroundSession(solo, LEGS, base_pose=dropped(solo, 0.0), ground=sd.Ground(),
                      contacts=[sd.Contact(f) for f in FEET])
    s.command(np.arange(12), np.zeros(12), LEGS)
    for _ in range(5):
        s.step()
    k, forces, active = s.contact_forces()
    assert k == 5 and active.all() and forces[:, 2].min() > 0
    assert ("contacts touching", "4 of 4") in s.report()
    s.reset()
    k, forces, active = s.contact_forces()
    assert not forces.any() and not active.any()
    with pytest.raises(ValueError, match=r"contacts\[1\] \(FL_FOOT\) is a frame contact"):
        GroundSession(solo, LEGS, ground=sd.Ground(),
                      contacts=[sd.Contact("FR_FOOT"), sd.Contact("FL_FOOT", frame=True)])
    with pytest.raises(ValueError, match="contacts\\[0\\]: link 'HOOF' is not a link"):
        GroundStepper(solo, sd.Ground(), [sd.Contact("HOOF")])
