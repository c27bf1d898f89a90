"""trajectory.time_parameterize (TOPP-RA through toppra, trajectory/time_parameterization.py): no
sample exceeds a limit (checked with the robot's inverse dynamics on a grid ten times finer
than the solver's), the time-optimal closed forms (bang-bang; the 1/T^2 law of the
textbook's minimum-time maneuver, shared/reference section E) within the grid's error, no
slower than the textbook's maneuver on its own case, a heavier payload slower, an
infeasible path refused naming the joint and the waypoint; a path timed by its geometry, not
by how many waypoints describe it (issue 52), on the UR5e and two 7-joint arms; toppra's log
on the library's logger at DEBUG."""
import logging

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
                                         r"effort limit 20, near waypoint 0"):
        tj.time_parameterize(arm(), PICK, effort_limit=weak, grid=40)


def test_bad_paths_are_refused():
    robot = sd.default_robot()
    with pytest.raises(ValueError, match=r"path has shape \(2, 5\)"):
        tj.time_parameterize(robot, np.zeros((2, 5)))
    with pytest.raises(ValueError, match="waypoint 1: joint 'wrist_3_joint' at 9 is outside"):
        tj.time_parameterize(robot, np.array([Q0, np.r_[Q0[:5], 9.0]]))
    with pytest.raises(ValueError, match="effort_limit must be one positive number"):
        tj.time_parameterize(robot, np.array([Q0, Q1]), effort_limit=[1, 2])


# ------------------------------------------------------- the path's geometry, not its sampling
N_GRID = (2, 3, 5, 6, 11, 21, 101, 200)          # waypoints describing the same path
ACC = 10.0                                       # rad/s^2 on every joint
ISSUE_LINE = (np.zeros(6), np.array([1.2, -0.6, 0.8, 1.0, -0.9, 0.7]))   # issue 52's UR5e line
SEVEN = {"panda": ("panda_description/urdf/panda.urdf", "panda_link0", "panda_link8"),
         "xarm7": ("xarm_description/urdf/xarm7.urdf", None, None)}


@pytest.fixture(scope="module", params=["ur5e", "panda", "xarm7"])
def line(request):
    """(robot, A, B): a straight joint-space path within the joint ranges."""
    if request.param == "ur5e":
        return (sd.default_robot(),) + ISSUE_LINE
    from pin_reference import erd, load
    rel, base, tip = SEVEN[request.param]
    robot = load(erd(rel), base, tip)
    A = np.where(np.isfinite(robot.lower), 0.5 * (robot.lower + robot.upper), 0.0)
    return robot, A, A + np.where(np.arange(robot.dof) % 2, 0.8, -0.8)


def sampled_ratios(robot, w, acc):
    """Peak |qd|, |qdd|, |tau| over their limits at 4,000 samples, tau by inverse dynamics
    (less the joint friction when the robot's is on)."""
    q, qd, qdd = w.sample(np.linspace(0.0, w.duration, 4000))
    tau = robot.inverse_dynamics(q, qd, qdd)
    if robot.dissipation.enabled:
        tau = tau - robot.dissipation.torque(qd)
    return (np.max(np.abs(qd) / robot.velocity_limit), np.max(np.abs(qdd) / acc),
            np.max(np.abs(tau) / robot.effort_limit))


def test_a_path_is_timed_by_its_geometry_not_its_waypoints(line):
    """The same straight path, a path with a corner (C: most of the way on three joints,
    then the rest) and the straight path with repeated end points, each given as 2 to 200
    waypoints: every call returns a timing within the limits, time-optimal (some limit
    reached), whose duration does not depend on the number of waypoints; the corner is a
    rest (the two legs timed one after the other), the repeated points are dropped."""
    robot, A, B = line
    C = A + np.where(np.arange(robot.dof) < 3, 0.9 * (B - A), 0.0)
    paths = {"straight": lambda N: np.linspace(A, B, N),
             "corner": lambda N: np.vstack([np.linspace(A, C, N), np.linspace(C, B, N)[1:]]),
             "repeated ends": lambda N: np.vstack([A, A, np.linspace(A, B, N), B, B, B])}
    T = {}
    for kind, make in paths.items():
        for N in N_GRID:
            w = tj.time_parameterize(robot, make(N), acceleration_limit=ACC)
            ratios = sampled_ratios(robot, w, ACC)
            assert 0.99 <= max(ratios) <= 1.01, (kind, N, ratios)
            T[kind, N] = w.duration
        durations = [T[kind, N] for N in N_GRID if N >= 5]
        assert max(durations) <= 1.01 * min(durations), (kind, durations)
    for N in N_GRID:
        assert T["straight", N] == pytest.approx(T["straight", 2], rel=1e-9)
        assert T["repeated ends", N] == pytest.approx(T["straight", N], rel=1e-9)
    legs = sum(tj.time_parameterize(robot, [P, Q], acceleration_limit=ACC).duration
               for P, Q in ((A, C), (C, B)))
    assert T["corner", 11] == pytest.approx(legs, rel=1e-2)     # grid shared by the two legs
    w = tj.time_parameterize(robot, paths["corner"](6), acceleration_limit=ACC)
    at = np.argmin(np.max(np.abs(w.q - C), axis=1))
    assert np.max(np.abs(w.q[at] - C)) < 1e-12 and not np.any(w.qd[at])     # at rest there


def test_the_issue_line_times_as_its_two_ends():
    """Issue 52's line on the UR5e at its URDF limits: 0.457 s whatever the waypoints."""
    robot = sd.default_robot()
    T = [tj.time_parameterize(robot, np.linspace(*ISSUE_LINE, N)).duration for N in N_GRID]
    assert T[0] == pytest.approx(0.457, abs=1e-3)
    assert max(T) - min(T) <= 1e-9 * T[0], T


def test_a_densely_sampled_curve_converges():
    """A quarter circle in joint space given by 21 to 400 waypoints (turns below the
    corner angle: a spline through them): the durations agree within 0.5 %."""
    robot = sd.default_robot()
    e1, e2 = np.array([1.0, 0, 0.5, 0, 0, 0]), np.array([0, 1.0, 0, 0.5, 0.3, 0])
    T = []
    for N in (21, 51, 101, 200, 400):
        th = np.linspace(0.0, np.pi / 2, N)
        w = tj.time_parameterize(robot, np.outer(np.cos(th), e1) + np.outer(np.sin(th), e2),
                                 acceleration_limit=ACC)
        assert max(sampled_ratios(robot, w, ACC)) <= 1.01
        T.append(w.duration)
    assert max(T) <= 1.005 * min(T), T


def test_toppra_prints_nothing_and_logs_at_debug(capfd, caplog):
    """The 101-waypoint line made TOPP-RA print dozens of warnings; now nothing is printed
    at the default log level, and toppra's records (its own warnings too) reach the
    library's logger at DEBUG."""
    robot = sd.default_robot()
    path = np.linspace(*ISSUE_LINE, 101)
    tj.time_parameterize(robot, path)
    toppra_log = logging.getLogger("toppra")
    toppra_log.warning("The controllable set at step [1 / 2] can't be computed")   # as toppra
    out, err = capfd.readouterr()
    assert out == "" and err == ""
    seen = []                       # what a handler on the root logger receives
    keep = logging.Handler()
    keep.emit = seen.append
    logging.getLogger().addHandler(keep)
    try:
        with caplog.at_level(logging.DEBUG):
            tj.time_parameterize(robot, path)
            toppra_log.warning("The path is not controllable, or is badly conditioned")
    finally:
        logging.getLogger().removeHandler(keep)
    ours = [r for r in seen if r.name == "serial_dynamics.trajectory.time_parameterization"]
    assert ours and all(r.levelno == logging.DEBUG for r in ours)
    assert any("badly conditioned" in r.getMessage() for r in ours)
    assert not any(r.name.startswith("toppra") for r in seen)


def test_a_zero_limit_holds_a_joint_still_or_names_it():
    robot = sd.default_robot()
    still = np.array([Q0, np.r_[Q0[0], Q1[1:]]])          # the base joint holds still
    free = tj.time_parameterize(robot, still)
    held = tj.time_parameterize(robot, still, velocity_limit=[0.0] + [np.pi] * 5,
                                acceleration_limit=[0.0] + [np.inf] * 5)
    assert held.duration == pytest.approx(free.duration, rel=1e-12)
    assert not np.any(held.qd[:, 0])
    moving = np.array([Q0, Q0 + [0, 0.5, 0, 0, 0, 0], Q0 + [0.3, 0.5, 0, 0, 0, 0]])
    with pytest.raises(ValueError, match="infeasible path: the velocity limit of joint "
                                         "'shoulder_pan_joint' is 0 but the path moves it "
                                         "between waypoints 1 and 2"):
        tj.time_parameterize(robot, moving, velocity_limit=[0.0] + [np.pi] * 5)


def test_a_path_that_never_moves_is_one_point_at_rest():
    w = tj.time_parameterize(sd.default_robot(), np.array([Q0, Q0, Q0]))
    assert w.duration == 0.0 and w.q.tolist() == [Q0.tolist()] and not np.any(w.qd)
