"""A starved controller holds a pushed arm (issue 20 item 3), deterministically: the test's
clock drives both the plant and the controller, so no machine load can change the outcome
(issue 26 item 5; the same scenario with real nodes on a loaded core is the benchmark
bench/bench_controller_load.py).

The xArm7 of example-robot-data at q = 0 (its first and third axes line up), the gains of
docs/ros.md's example (kp 900, kd 60), the simulator node's plant (FixedStepIntegrator,
semi-implicit Euler at 1 ms, the URDF's dissipation), the controller node's laws
(control.torque, control.pd_gains) at 500 Hz on the state of that instant, starved: it
sends nothing for 30 ms in every 100 ms (the plant holds the last command, as the
simulator does), and the tip pushed with 17 N along y for 0.2 s. Asserted, in every
mode: computed_torque and pd_gravity keep the joint speeds bounded and bring the arm to
rest near q = 0 (within the friction band); gravity_compensation (which holds nothing)
does not feed the motion (its kinetic energy does not grow after the push).
"""
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics import control
from serial_dynamics.sim.fixed_step import FixedStepIntegrator

from pin_reference import erd

DT, PERIOD = 1e-3, 2          # plant step (s); the controller's period in plant steps
KP, KD, PUSH, PUSH_TIME = 900.0, 60.0, 17.0, 0.2
STARVED = 30                  # ms without a command in every 100 ms


@pytest.fixture(scope="module")
def xarm7():
    try:
        path = erd("xarm_description/urdf/xarm7.urdf")
    except Exception as exc:   # noqa: BLE001 -- example-robot-data missing
        pytest.skip(str(exc))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sd.load_urdf(path, "link_base", "link7")


def run(robot, mode, seconds=2.0, push_at=0.5):
    """(t, q, qd) of the starved loop; the push starts at ``push_at`` s."""
    plant = FixedStepIntegrator(robot, "semi_implicit_euler", DT, dissipation=True)
    n = robot.dof
    q, qd = np.zeros(n), np.zeros(n)
    tau = robot.gravity_torques(q)          # the arm held at rest before the test starts
    kp, kd = np.full(n, KP), np.full(n, KD)
    push = np.array([0.0, PUSH, 0.0, 0.0, 0.0, 0.0])
    Q, QD = [q], [qd]
    for k in range(int(round(seconds / DT))):
        if k % PERIOD == 0 and k % 100 >= STARVED:          # the controller runs
            if mode == "pd_gravity":
                gp, gd = control.pd_gains(robot, q, kp, kd)
            else:
                gp, gd = kp, kd
            tau = control.torque(robot, mode, q, qd, -q, -qd, np.zeros(n), gp, gd)
        t = k * DT
        w = push if push_at <= t < push_at + PUSH_TIME else None
        q, qd = plant.step(q, qd, tau, w, t=t)
        Q.append(q)
        QD.append(qd)
    return np.arange(len(Q)) * DT, np.array(Q), np.array(QD)


@pytest.mark.parametrize("mode", control.MODES)
def test_a_starved_controller_holds_a_pushed_arm(xarm7, mode):
    t, q, qd = run(xarm7, mode)
    speed = np.max(np.abs(qd), axis=1)
    after = t >= 0.5 + PUSH_TIME
    assert np.max(speed[t < 0.5]) < 1e-6 or mode == "gravity_compensation"   # held before
    assert np.max(speed[after]) > 1e-3, f"{mode}: the push did not move the arm"
    if mode == "gravity_compensation":     # nothing holds the arm: no energy fed in
        ke = xarm7.kinetic_energy(q, qd)
        assert ke[-1] <= 1.2 * ke[after][0], (ke[after][0], ke[-1])
    else:
        assert np.max(speed) < 5.0, f"{mode}: joint speeds up to {np.max(speed):.3g} rad/s"
        # at rest near q = 0, within the friction band (Coulomb friction 1 N m over the
        # default stiffness)
        assert speed[-1] < 0.3 and np.max(np.abs(q[-1])) < 0.3, (speed[-1], q[-1])
