"""Simulation of trees (issue 25): the energy balance of a passive fixed tree over 10 s,
the momentum of a floating humanoid in zero gravity, and every fixed-step method."""
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from pin_reference import erd


def load(rel, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        return sd.load_urdf(erd(rel), **kw)


def test_a_passive_tree_keeps_its_energy_for_10_s():
    robot = load("solo_description/robots/solo12.urdf")
    robot.dissipation = robot.dissipation.override(viscous=0.0, coulomb=0.0)
    res = sd.simulate(robot, 10.0, robot.random_state(0)[0], np.zeros(robot.dof),
                      method="DOP853", rtol=1e-10, atol=1e-10)
    E = res.energy
    assert np.max(np.abs(E - E[0])) < 1e-8 * max(1.0, np.ptp(res.kinetic))
    assert np.ptp(res.kinetic) > 0.1                # it did swing


def test_a_floating_humanoid_keeps_its_momentum_in_zero_gravity():
    """29 joints driven by sinusoidal torques, a spinning base: the centroidal momentum
    (linear and angular, world axes) stays constant to 1e-9 relative."""
    robot = load("simple_humanoid_description/urdf/simple_humanoid.urdf", floating_base=True,
                 gravity=(0.0, 0.0, 0.0))
    q = robot.neutral()
    q[7:] = robot.random_state(1)[0][7:]
    v = np.zeros(robot.nv)
    v[:6] = [0.1, 0.0, 0.2, 0.3, -0.2, 0.5]
    res = sd.simulate(robot, 0.3, q, v, method="DOP853", rtol=1e-11, atol=1e-11,
                      torque=lambda t, q, v: 0.5 * np.sin(3 * t) * np.ones(robot.dof))
    h = np.array([robot.centroidal_momentum(x, y) for x, y in zip(res.q, res.qd)])
    assert np.max(np.abs(h - h[0])) <= 1e-9 * np.max(np.abs(h[0]))
    assert np.ptp(res.q[:, 7:]) > 0.01              # the joints moved


@pytest.mark.parametrize("method", ["semi_implicit_euler", "rk4", "implicit_midpoint",
                                    "symplectic_euler"])
def test_every_fixed_step_method_runs_a_tree(method):
    """0.3 s at 1 ms from rest under gravity: each method stays within 20 mJ of the energy it
    started with (no dissipation) and within 0.1 rad of DOP853's end state (the first-order
    methods at 1 ms on Solo12's light, fast-swinging legs: 0.06 rad, measured)."""
    robot = load("solo_description/robots/solo12.urdf")
    robot.dissipation = robot.dissipation.override(viscous=0.0, coulomb=0.0)
    q0 = 0.3 * robot.random_state(0)[0]
    res = sd.simulate(robot, 0.3, q0, np.zeros(robot.dof), method=method, dt=1e-3)
    ref = sd.simulate(robot, 0.3, q0, np.zeros(robot.dof), method="DOP853", rtol=1e-10,
                      atol=1e-10)
    assert abs(res.energy[-1] - res.energy[0]) < 0.02
    assert np.max(np.abs(res.q[-1] - ref.q[-1])) < 0.1


def test_wrenches_on_links_in_a_simulation():
    """A constant wrench on two feet of the fixed quadruped equals the torque J^T w given
    directly (same run); a callable wrench is evaluated at each state; a bad link is named."""
    robot = load("solo_description/robots/solo12.urdf")
    q0 = 0.3 * robot.random_state(2)[0]
    feet = {"FL_FOOT": np.array([0.0, 0.0, 2.0, 0.0, 0.0, 0.0]),
            "HR_FOOT": np.array([1.0, 0.0, 0.0, 0.0, 0.1, 0.0])}
    a = sd.simulate(robot, 0.1, q0, method="rk4", dt=1e-3, wrenches=feet)
    b = sd.simulate(robot, 0.1, q0, method="rk4", dt=1e-3, torque=lambda t, q, qd: sum(
        robot.jacobian(q, k).T @ w for k, w in feet.items()))
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-12)
    c = sd.simulate(robot, 0.1, q0, method="rk4", dt=1e-3,
                    wrenches={k: (lambda t, q, qd, w=w: w) for k, w in feet.items()})
    np.testing.assert_allclose(c.q, a.q, rtol=0, atol=1e-12)
    assert np.max(np.abs(a.q[-1] - sd.simulate(robot, 0.1, q0, method="rk4", dt=1e-3).q[-1])) > 1e-3
    with pytest.raises(ValueError, match="'nose' is not a link of the model"):
        sd.simulate(robot, 0.1, q0, method="rk4", wrenches={"nose": np.zeros(6)})


def test_wrenches_on_a_chain_take_the_general_loop():
    """semi-implicit Euler on a chain runs a compiled loop that knows no link wrenches: with
    wrenches= it must not be taken (the wrench changes the motion)."""
    robot = sd.default_robot()
    w = {"wrist_1_link": np.array([0.0, 0.0, -30.0, 0.0, 0.0, 0.0])}
    a = sd.simulate(robot, 0.05, method="semi_implicit_euler", dt=1e-3, wrenches=w)
    b = sd.simulate(robot, 0.05, method="semi_implicit_euler", dt=1e-3,
                    torque=lambda t, q, qd: robot.jacobian(q, "wrist_1_link").T @ w["wrist_1_link"])
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-12)
    assert np.max(np.abs(a.q[-1] - sd.simulate(robot, 0.05, method="semi_implicit_euler",
                                               dt=1e-3).q[-1])) > 1e-6


@pytest.mark.parametrize("method", ["DOP853", "rk4"])
def test_wrenches_on_a_floating_quadruped_change_its_momentum_by_their_impulse(method):
    """Zero gravity, no friction. A constant force F (world axes) on one foot: the linear
    momentum grows by F T; a pure moment m(t) on another: the linear momentum stays and the
    angular momentum about the center of mass grows by its integral. The energy balance
    (the base's share of J^T w counted as external work) closes."""
    robot = load("solo_description/robots/solo12.urdf", floating_base=True,
                 gravity=(0.0, 0.0, 0.0))
    q0, v0 = robot.random_state(3, speed=0.5)
    T, F = 0.3, np.array([3.0, -2.0, 1.0, 0.0, 0.0, 0.0])
    kw = dict(method=method, dissipation=False)
    kw.update(dict(rtol=1e-11, atol=1e-11) if method == "DOP853" else dict(dt=1e-3))
    tol = 1e-9 if method == "DOP853" else 1e-7
    pushed = sd.simulate(robot, T, q0, v0, wrenches={"FL_FOOT": F}, **kw)
    h = [robot.centroidal_momentum(pushed.q[k], pushed.qd[k]) for k in (0, -1)]
    np.testing.assert_allclose(h[1][:3] - h[0][:3], F[:3] * T, rtol=0, atol=tol * 10)
    assert abs(pushed.relative_energy_error()) < tol
    twisted = sd.simulate(robot, T, q0, v0, wrenches={     # (small: the foot is light)
        "HR_FOOT": lambda t, q, v: np.array([0.0, 0.0, 0.0, 0.05, 0.0, 0.1 * np.cos(2 * t)])},
        **kw)
    h = [robot.centroidal_momentum(twisted.q[k], twisted.qd[k]) for k in (0, -1)]
    np.testing.assert_allclose(h[1] - h[0], [0, 0, 0, 0.05 * T, 0, 0.1 * np.sin(2 * T) / 2],
                               rtol=0, atol=tol * 10)
    assert abs(twisted.relative_energy_error()) < tol
