"""Simulations with the real-arm terms keep their energy balance: armature, a payload and
a rolling base (whose motion does work on the arm, counted in work_external)."""
import numpy as np
import pytest

import serial_dynamics as sd

Q0 = np.array([0.3, -1.0, 1.2, -0.5, 0.7, 0.1])


def arm():
    robot = sd.load_urdf(sd.builtin_path("ur5e"),
                         armature={"shoulder_pan_joint": 0.3, "wrist_3_joint": 0.02})
    return robot.with_payload(2.0, com=(0.0, 0.02, 0.05), inertia=(0.01, 0.012, 0.008, 0, 0, 0))


def roll(t):
    """A deck rolling +-0.2 rad/s about x and heaving (base frame)."""
    return sd.BaseMotion((0.2 * np.cos(t), 0.0, 0.0), (-0.2 * np.sin(t), 0.0, 0.0),
                         (0.0, 0.3 * np.sin(2 * t), 0.5 * np.cos(2 * t)))


@pytest.mark.parametrize("method, kw, tol", [
    ("DOP853", dict(rtol=1e-10, atol=1e-12), 1e-9),
    ("rk4", dict(dt=1e-3), 1e-6),
    ("implicit_midpoint", dict(dt=1e-3), 1e-3),
])
def test_energy_balance_with_armature_payload_and_a_rolling_base(method, kw, tol):
    robot = arm()
    res = sd.simulate(robot, 1.5, Q0, None, method=method, base_motion=roll, dissipation=False, **kw)
    assert res.relative_energy_error() < tol
    # the base's motion did work on the arm: without counting it the balance would fail
    assert np.max(np.abs(res.work_external)) > 10 * np.max(np.abs(res.energy_balance_error))
    # and a base at rest gives a different motion (the term is not ignored)
    still = sd.simulate(robot, 1.5, Q0, None, method=method, dissipation=False, **kw)
    assert np.abs(still.q[-1] - res.q[-1]).max() > 1e-3


def test_a_constant_base_motion_and_the_friction_modes():
    robot = arm()
    deck = sd.BaseMotion((0.1, -0.05, 0.0), (0.0, 0.0, 0.0), (0.2, 0.0, 0.0))
    res = sd.simulate(robot, 0.5, Q0, None, method="semi_implicit_euler", dt=1e-4,
                      base_motion=deck, dissipation=sd.Dissipation.none(robot.joint_names)
                      .override(coulomb={"elbow_joint": 1.0}, viscous={"wrist_1_joint": 0.5}))
    assert np.all(np.isfinite(res.q)) and res.relative_energy_error() < 1e-2
    with pytest.raises(TypeError, match="BaseMotion"):
        sd.simulate(robot, 0.1, Q0, base_motion=(0.1, 0, 0), method="rk4")
