"""trajectory.time_parameterize (TOPP-RA through toppra, algorithms/time_parameterization.py): no
sample exceeds a limit (checked with the robot's inverse dynamics on a grid ten times finer
than the solver's), the time-optimal closed forms (bang-bang; the 1/T^2 law of the
textbook's minimum-time maneuver, shared/reference section E) within the grid's error, no
slower than the textbook's maneuver on its own case, a heavier payload slower, an
infeasible path refused naming the joint and the waypoint."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics import trajectory as tj

pytest.importorskip("toppra")

Q0 = np.array([0.0, -1.5, 1.0, -1.0, 0.5, 0.0])
Q1 = Q0 + np.array([1.5, 0.8, -1.2, 0.7, -0.9, 2.0])
PICK = np.array([w for _, w in tj.UR5E_PICK_AND_PLACE])
PICK = PICK[np.r_[True, np.any(np.diff(PICK, axis=0) != 0, axis=1)]]     # dwells dropped
EFFORT = np.array([60.0, 90.0, 45.0, 12.0, 12.0, 12.0])                  # below the UR5e's


def arm(payload=0.0):
    robot = sd.default_robot()
    robot.dissipation = robot.dissipation.override(viscous=[2.0] * 6, coulomb=[3.0] * 6)
    return robot.with_payload(payload, (0, 0, 0.05)) if payload else robot


def test_no_sample_exceeds_a_limit():
    robot = arm(2.0)
    w = tj.time_parameterize(robot, PICK, acceleration_limit=20.0, effort_limit=EFFORT,
                             grid=100)
    # at rest at both ends, through every waypoint
    assert np.all(w.qd[[0, -1]] == 0)
    for p in PICK:
        assert np.min(np.max(np.abs(w.q - p), axis=1)) < 1e-12
    t = np.linspace(0, w.duration, 10 * len(w.t))
    q, qd, qdd = w.sample(t)
    tau = robot.inverse_dynamics(q, qd, qdd) - robot.dissipation.torque(qd)
    ratios = [np.max(np.abs(qd) / robot.velocity_limit), np.max(np.abs(qdd) / 20.0),
              np.max(np.abs(tau) / EFFORT)]
    assert max(ratios) <= 1.0 + 1e-9, ratios
    assert max(ratios) >= 0.99                  # time-optimal: some limit is reached
    assert np.max(np.abs(tau) / EFFORT) >= 0.95  # the effort limits bind on this path


def test_bang_bang_closed_form():
    """Only the base joint moves, no gravity: its inertia is constant and no velocity term
    acts on it, so the fastest motion over D under |tau| <= tau_max is full torque half way
    and full braking after: T = 2 sqrt(D M11 / tau_max)."""
    robot = sd.default_robot(gravity=(0, 0, 0))
    D, tau_max = 1.2, 20.0
    path = np.array([Q0, Q0 + [D, 0, 0, 0, 0, 0]])
    w = tj.time_parameterize(robot, path, velocity_limit=np.inf,
                             effort_limit=[tau_max] + [1e6] * 5, grid=400, dissipation=False)
    T = 2 * np.sqrt(D * robot.mass_matrix(Q0)[0, 0] / tau_max)
    assert w.duration == pytest.approx(T, rel=5e-3)    # grid 400: within 0.5 %
    assert w.duration >= T * (1 - 1e-9)                 # never faster than the optimum


def test_the_textbook_maneuver():
    """Section E on the UR5e without gravity, effort limits only: the best timing of the
    straight line is no slower than the best scaling of the cycloidal law (it is free to
    choose the law), and it follows the 1/T^2 law: four times the torque, half the time."""
    robot = sd.default_robot(gravity=(0, 0, 0))
    book = tj.minimum_time(robot, Q0, Q1, "cycloidal", gravity=False, dissipation=False,
                           velocity=False)
    kw = dict(velocity_limit=np.inf, dissipation=False, grid=200)
    w = tj.time_parameterize(robot, np.array([Q0, Q1]), **kw)
    assert w.duration <= book.T
    assert w.duration >= 0.6 * book.T        # bang-bang against the cycloid: about 0.8
    w4 = tj.time_parameterize(robot, np.array([Q0, Q1]), effort_limit=4 * robot.effort_limit, **kw)
    assert w4.duration == pytest.approx(w.duration / 2, rel=1e-6)


def test_a_heavier_payload_is_slower():
    light = tj.time_parameterize(arm(), PICK, effort_limit=EFFORT, grid=60)
    heavy = tj.time_parameterize(arm(3.0), PICK, effort_limit=EFFORT, grid=60)
    assert heavy.duration > 1.05 * light.duration


def test_an_infeasible_path_is_refused_naming_the_joint_and_the_waypoint():
    weak = EFFORT.copy()
    weak[1] = 20.0                      # the shoulder cannot hold the arm out at waypoint 0
    with pytest.raises(ValueError, match=r"infeasible path: holding joint 'shoulder_lift_joint' "
                                         r"against gravity and friction takes .* above its "
                                         r"effort limit 20, at waypoint 0"):
        tj.time_parameterize(arm(), PICK, effort_limit=weak, grid=40)


def test_bad_paths_are_refused():
    robot = sd.default_robot()
    with pytest.raises(ValueError, match=r"path has shape \(2, 5\)"):
        tj.time_parameterize(robot, np.zeros((2, 5)))
    with pytest.raises(ValueError, match="path waypoints 1 and 2 are the same"):
        tj.time_parameterize(robot, np.array([Q0, Q1, Q1]))
    with pytest.raises(ValueError, match="waypoint 1: joint 'wrist_3_joint' at 9 is outside"):
        tj.time_parameterize(robot, np.array([Q0, np.r_[Q0[:5], 9.0]]))
    with pytest.raises(ValueError, match="effort_limit must be one positive number"):
        tj.time_parameterize(robot, np.array([Q0, Q1]), effort_limit=[1, 2])
