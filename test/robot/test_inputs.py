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
        # in a batch, past the first block of lanes: the kernel reports it, the joint is named
        batch = np.zeros((40, 6))
        batch[37] = bad
        with pytest.raises(ValueError, match=rf"^{argname} has a NaN or Inf entry \(joint '{joint_name}'\)"):
            call(robot, batch, ok)


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
        with pytest.raises(ValueError, match="link 'gripper' is not a link of the model") as info:
            call(np.zeros(6), link="gripper")
        assert "wrist_3_link" in str(info.value)       # lists the known links


def test_unknown_forward_dynamics_method(robot):
    with pytest.raises(ValueError, match="'lu'"):
        robot.forward_dynamics(np.zeros(6), np.zeros(6), np.zeros(6), method="lu")


# ---------------------------------------------------------------- wrenches on links (issue 25)
def test_wrenches_on_links_are_minus_j_transpose_w():
    """tau = M a + b - sum_k J_k^T w_k, on a chain, a tree with mimic fingers and a floating
    tree; forward dynamics inverts it; the tip's wrench is the one-link case."""
    import warnings
    from pin_reference import erd
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        robots = [sd.default_robot(), sd.load_urdf(erd("panda_description/urdf/panda.urdf")),
                  sd.load_urdf(erd("solo_description/robots/solo12.urdf"), floating_base=True)]
    for robot in robots:
        rng = np.random.default_rng(1)
        q = robot.random_state(rng)[0] if not robot.is_floating else np.concatenate(
            [[0.1, 0.2, 0.3, 0.0, 0.0, 0.6, 0.8], rng.uniform(-1, 1, robot.dof)])
        v, a = rng.uniform(-1, 1, (2, robot.nv))
        leaves = [robot.model.link_names[i] for i in range(robot.model.dof)
                  if not robot.model.children[i]][:2]
        w = {link: rng.uniform(-10, 10, 6) for link in leaves}
        tau = robot.inverse_dynamics(q, v, a, wrenches=w)
        expected = robot.inverse_dynamics(q, v, a) - sum(robot.jacobian(q, k).T @ x
                                                         for k, x in w.items())
        np.testing.assert_allclose(tau, expected, rtol=1e-12, atol=1e-12)
        assert not np.allclose(tau, robot.inverse_dynamics(q, v, a))
        np.testing.assert_allclose(robot.forward_dynamics(q, v, tau, wrenches=w), a,
                                   rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(robot.bias_torques(q, v, wrenches=w),
                                   robot.inverse_dynamics(q, v, 0 * a, wrenches=w), atol=1e-10)
    ur5e = robots[0]
    q, v = ur5e.random_state(2)
    w = np.arange(1.0, 7.0)
    np.testing.assert_allclose(ur5e.inverse_dynamics(q, v, v, wrenches={ur5e.tip_link: w}),
                               ur5e.inverse_dynamics(q, v, v, wrench=w), rtol=1e-12, atol=1e-12)


def test_a_wrench_on_a_link_not_in_the_model_names_it():
    robot = sd.default_robot()
    q = np.zeros(robot.dof)
    with pytest.raises(ValueError, match="'l_foot' is not a link of the model"):
        robot.inverse_dynamics(q, q, q, wrenches={"l_foot": np.zeros(6)})
    with pytest.raises(ValueError, match=r"wrenches\['tool0'\] must be 6 finite"):
        robot.forward_dynamics(q, q, q, wrenches={"tool0": [1.0, 2.0]})
