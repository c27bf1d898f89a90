"""Bad states and arguments of the facade's calls get a ValueError naming the argument,
the joint and what is expected (DESIGN.md, "Errors"), on both backends."""
import numpy as np
import pytest

import serial_dynamics as sd


@pytest.fixture(scope="module", params=["numba", "numpy"])
def robot(request):
    return sd.Robot(sd.default_robot().model, backend=request.param)


@pytest.mark.parametrize("call, argname", [
    (lambda r, bad, ok: r.inverse_dynamics(bad, ok, ok), "q"),
    (lambda r, bad, ok: r.inverse_dynamics(ok, bad, ok), "qd"),
    (lambda r, bad, ok: r.inverse_dynamics(ok, ok, bad), "qdd"),
    (lambda r, bad, ok: r.mass_matrix(bad), "q"),
    (lambda r, bad, ok: r.bias_torques(ok, bad), "qd"),
    (lambda r, bad, ok: r.gravity_torques(bad), "q"),
    (lambda r, bad, ok: r.coriolis_matrix(ok, bad), "qd"),
    (lambda r, bad, ok: r.forward_dynamics(ok, ok, bad), "tau"),
    (lambda r, bad, ok: r.forward_dynamics(ok, ok, bad, method="qr"), "tau"),
    (lambda r, bad, ok: r.forward_dynamics(bad, ok, ok, method="aba"), "q"),
    (lambda r, bad, ok: r.forward_kinematics(bad), "q"),
    (lambda r, bad, ok: r.jacobian(bad), "q"),
    (lambda r, bad, ok: r.kinetic_energy(ok, bad), "qd"),
    (lambda r, bad, ok: r.potential_energy(bad), "q"),
])
def test_bad_states(robot, call, argname):
    ok = np.zeros(6)
    for bad in (np.zeros(5), np.zeros(7), np.zeros((3, 5)), np.zeros((2, 3, 6)), 0.0):
        with pytest.raises(ValueError, match=rf"^{argname} has shape"):
            call(robot, bad, ok)
    for value, joint_name in ((np.nan, "shoulder_lift_joint"), (np.inf, "wrist_3_joint"),
                              (-np.inf, "shoulder_pan_joint")):
        bad = np.zeros(6)
        bad[robot.joint_names.index(joint_name)] = value
        with pytest.raises(ValueError, match=rf"^{argname} has a NaN or Inf entry \(joint '{joint_name}'\)"):
            call(robot, bad, ok)
        with pytest.raises(ValueError, match=rf"^{argname} has a NaN or Inf"):   # in a batch
            call(robot, np.vstack([np.zeros(6), bad]), ok)


def test_batch_sizes_must_agree(robot):
    with pytest.raises(ValueError, match="batch sizes differ"):
        robot.inverse_dynamics(np.zeros((3, 6)), np.zeros((4, 6)), np.zeros(6))


@pytest.mark.parametrize("wrench", [np.zeros(5), np.zeros(7), np.zeros((2, 6)), np.zeros((3, 3)), 1.0])
def test_wrong_wrench_shape(robot, wrench):
    q = np.zeros((4, 6))
    for call in (lambda: robot.inverse_dynamics(q, q, q, wrench=wrench),
                 lambda: robot.bias_torques(q, q, wrench=wrench),
                 lambda: robot.forward_dynamics(q, q, q, wrench=wrench)):
        with pytest.raises(ValueError, match="wrench has shape"):
            call()


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_nan_or_inf_wrench(robot, value):
    w = np.array([1.0, 2.0, value, 0.0, 0.0, 0.0])
    for q in (np.zeros(6), np.zeros((3, 6))):
        for call in (lambda: robot.inverse_dynamics(q, q, q, wrench=w),
                     lambda: robot.bias_torques(q, q, wrench=w),
                     lambda: robot.forward_dynamics(q, q, q, wrench=w),
                     lambda: robot.forward_dynamics(q, q, q, wrench=w, method="qr")):
            with pytest.raises(ValueError, match="wrench has a NaN or Inf entry"):
                call()


def test_unknown_link_in_kinematics(robot):
    for call in (robot.forward_kinematics, robot.jacobian):
        with pytest.raises(ValueError, match="link 'gripper' is not in the model") as info:
            call(np.zeros(6), link="gripper")
        assert "wrist_3_link" in str(info.value)       # lists the known links


def test_unknown_forward_dynamics_method(robot):
    with pytest.raises(ValueError, match="'lu'"):
        robot.forward_dynamics(np.zeros(6), np.zeros(6), np.zeros(6), method="lu")
