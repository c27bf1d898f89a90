"""Payload estimation (identification/payload.py) closing the loop: a UR5e with friction
carrying a known payload, simulated along an excitation trajectory (computed torque with PD
feedback, stick-slip friction, 1 kHz), recorded with encoder quantization and torque noise
(ident_helpers: 1 N m on the big joints, 0.2 N m on the wrists), estimated from the arm's
nominal URDF (its friction unknown): the payload is recovered within four standard
deviations and the stated absolute bounds; a real body even where the data cannot see it;
too little excitation refused with the reason. No payload (Solo12's legs swinging with zero
torques; a 7-joint arm's recording without one) is reported as none, with no center of
mass, where a 1.7 kg one on the same arm is found."""
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics import identification as ident

from ident_helpers import COULOMB, TORQUE_NOISE, VISCOUS, record

PAYLOAD = dict(mass=2.0, com=(0.01, -0.02, 0.06), inertia=(0.012, 0.010, 0.008, 0.001, -0.0015,
                                                            0.0005))


def arm_with_friction():
    robot = sd.default_robot()
    robot.dissipation = robot.dissipation.override(
        viscous=dict(zip(robot.joint_names, VISCOUS)), coulomb=dict(zip(robot.joint_names, COULOMB)))
    return robot


@pytest.fixture(scope="module")
def run():
    robot = sd.default_robot()                    # what the estimator is told: no friction
    truth = arm_with_friction().with_payload(**PAYLOAD)
    ex = ident.excitation(robot, duration=6, harmonics=3, maxiter=0, seed=0)
    _, t, q, tau = record(truth, ex, seed=1)
    return dict(robot=robot, truth=truth, ex=ex, data=(t, q, tau),
                est=ident.estimate_payload(robot, t, q, tau))


def test_the_payload_is_recovered(run):
    est = run["est"]
    assert est.link == "tool0" and not est.constrained and est.condition_number < 10
    err = np.r_[est.mass - PAYLOAD["mass"], est.com - PAYLOAD["com"],
                est.inertia - PAYLOAD["inertia"]]
    std = np.r_[est.mass_std, est.com_std, est.inertia_std]
    assert np.all(np.abs(err) <= 4 * std), (err, std)
    # the bounds this recording gives (6 s): mass 0.5 %, com 1 mm, inertia 3e-3 kg m^2
    assert abs(err[0]) <= 0.005 * PAYLOAD["mass"]
    assert np.max(np.abs(err[1:4])) <= 1e-3
    assert np.max(np.abs(err[4:])) <= 3e-3
    # the friction fitted along: within 5 % of the truth
    np.testing.assert_allclose(est.friction["viscous"], VISCOUS, rtol=0.05)
    np.testing.assert_allclose(est.friction["coulomb"], COULOMB, rtol=0.05)
    # the torques left over are the noise
    assert np.all(est.residual_rms <= 1.3 * TORQUE_NOISE)


def test_the_estimate_is_what_with_payload_takes(run):
    est, robot, truth = run["est"], run["robot"], run["truth"]
    held = robot.with_payload(est.mass, est.com, est.inertia)
    assert held.payload.link == "tool0"
    t, q, qd, qdd = run["ex"].sample(0.05)
    err = held.inverse_dynamics(q, qd, qdd) - truth.inverse_dynamics(q, qd, qdd)
    assert np.max(np.abs(err)) <= 0.05          # N m, against 15 N m from the payload
    assert np.max(np.abs(robot.inverse_dynamics(q, qd, qdd) - truth.inverse_dynamics(q, qd, qdd))) > 10
    # the payload already attached to the robot is ignored: the estimate replaces it
    again = ident.estimate_payload(robot.with_payload(5.0), *run["data"])
    np.testing.assert_allclose(again.parameters, est.parameters, rtol=1e-9)


def test_another_links_frame_gives_the_same_body(run):
    """On wrist_3_link (tool0's parent; tool0 is turned and offset in it) the estimate is
    the same body in that link's frame."""
    est, robot = run["est"], run["robot"]
    other = ident.estimate_payload(robot, *run["data"], link="wrist_3_link")
    a, b = est.attach(robot), other.attach(robot)
    assert b.payload.link == "wrist_3_link"
    t, q, qd, qdd = run["ex"].sample(0.1)
    np.testing.assert_allclose(a.inverse_dynamics(q, qd, qdd), b.inverse_dynamics(q, qd, qdd),
                               atol=1e-8)
    assert not np.allclose(other.com, est.com, atol=1e-3)     # a different frame indeed


def test_a_payload_the_data_cannot_resolve_is_still_a_real_body(run):
    """0.3 kg with an inertia of 1e-4 kg m^2: under the noise, least squares gives no real
    body; the physically consistent fit does, with the mass still right."""
    truth = arm_with_friction().with_payload(0.3, (0.0, 0.0, 0.02), (1e-4, 1e-4, 1e-4, 0, 0, 0))
    _, t, q, tau = record(truth, run["ex"], seed=1)
    est = ident.estimate_payload(run["robot"], t, q, tau)
    assert est.constrained
    sd.Robot(run["robot"].model).with_payload(est.mass, est.com, est.inertia)   # validates
    assert abs(est.mass - 0.3) <= 0.01
    assert "physically consistent fit" in est.summary()


def test_too_little_excitation_is_refused_with_the_reason(run):
    robot, truth = run["robot"], run["truth"]
    t = np.arange(0, 4, 1e-3)
    q = np.tile([0.0, -1.2, 1.2, -1.5, -1.5, 0.0], (t.size, 1))
    rng = np.random.default_rng(0)
    for j, reason in ((0, r"does not tell the payload's \[.*\] on 'tool0' apart \(condition "
                          r"number .* above 1e\+04\)"),
                      (5, r"does not see the payload's \['Ixx', 'Ixy', 'Iyy'\] on 'tool0' "
                          r"\(their regressor columns are zero\)")):
        qj = q.copy()
        qj[:, j] += 0.5 * np.sin(np.pi * t)
        qd, qdd = 0.5 * np.pi * np.cos(np.pi * t), -0.5 * np.pi ** 2 * np.sin(np.pi * t)
        QD, QDD = np.zeros_like(q), np.zeros_like(q)
        QD[:, j], QDD[:, j] = qd, qdd
        tau = truth.inverse_dynamics(qj, QD, QDD) + rng.standard_normal(q.shape) * TORQUE_NOISE
        with pytest.raises(ValueError, match="too little excitation: the recording " + reason
                           + r".*do not move.*excitation trajectory"):
            ident.estimate_payload(robot, t, qj, tau)


def test_bad_input_is_refused():
    robot = sd.default_robot()
    t = np.arange(10) * 0.01
    with pytest.raises(ValueError, match="link 'nowhere' is not a link of the model"):
        ident.estimate_payload(robot, t, np.zeros((10, 6)), np.zeros((10, 6)), link="nowhere")
    with pytest.raises(ValueError, match="link 'base_link' does not move: it is the base"):
        ident.estimate_payload(robot, t, np.zeros((10, 6)), np.zeros((10, 6)), link="base_link")
    with pytest.raises(ValueError, match=r"tau has shape \(10, 5\)"):
        ident.estimate_payload(robot, t, np.zeros((10, 6)), np.zeros((10, 5)))
    with pytest.raises(ValueError, match="3 samples are too few"):
        ident.estimate_payload(robot, t[:3], np.zeros((3, 6)), np.zeros((3, 6)))
    floating = sd.load_urdf(sd.builtin_path("ur5e"), floating_base=True)
    with pytest.raises(NotImplementedError, match="floating base"):
        ident.estimate_payload(floating, t, np.zeros((10, 13)), np.zeros((10, 12)))


# ----------------------------------------------------------------- no payload
def robot_from_erd(rel, *args):
    """A robot of example-robot-data's wheel (its path as the Pinocchio tests find it)."""
    erd = pytest.importorskip("pin_reference").erd
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        return sd.load_urdf(erd(rel), *args)


def test_no_payload_where_there_is_none():
    """Solo12 on a fixed base, its legs swinging freely under gravity with zero torques:
    nothing on any leg. The fitted mass (negative: the filter softens the recorded motion)
    is within three standard deviations of zero; no center of mass or inertia is given."""
    solo = robot_from_erd("solo_description/robots/solo12.urdf")
    q0 = np.tile([0.3, 0.9, -1.6], 4) + np.linspace(0.0, 0.2, 12)
    run = sd.simulate(solo, 4.0, q0, np.zeros(12), method="rk4", dt=1e-3)
    for link in (None, "FR_FOOT", "HL_LOWER_LEG"):
        est = ident.estimate_payload(solo, run.t, run.q, np.zeros_like(run.q), link=link)
        assert not est.detected and est.mass <= 3 * est.mass_std, (est.mass, est.mass_std)
        assert est.com is None and est.inertia is None
        assert est.com_std is None and est.inertia_std is None
        assert est.summary().startswith(f"no payload detected on {est.link!r} (mass ")
        assert "not above 3 standard deviations" in est.summary()
        assert est.attach(solo.with_payload(1.0)).payload is None      # none held
    # the same motion exactly (its velocities and accelerations, unfiltered): a mass of
    # round-off, its standard deviation of round-off too
    qdd = solo.forward_dynamics(run.q, run.qd, np.zeros_like(run.q))
    est = ident.estimate_payload(solo, run.t, run.q, np.zeros_like(run.q), run.qd, qdd,
                                 cutoff=np.inf)
    assert not est.detected and abs(est.mass) < 1e-12 and est.com is None


@pytest.fixture(scope="module")
def panda():
    robot = robot_from_erd("panda_description/urdf/panda.urdf", "panda_link0", "panda_link8")
    ex = ident.excitation(robot, duration=6, harmonics=3, maxiter=0, seed=0)
    return robot, ex.sample(0.002)


def test_a_payload_on_a_seven_joint_arm_and_none(panda):
    """The Panda (7 joints) along an excitation, 0.2 N m of torque noise: 1.7 kg at the
    flange found within 0.02 kg; the same recording without it, none."""
    robot, (t, q, qd, qdd) = panda
    noise = np.random.default_rng(1).normal(0.0, 0.2, q.shape)
    com = (0.0, 0.01, 0.05)
    truth = robot.with_payload(1.7, com, (0.004, 0.005, 0.003, 0.0, 0.0, 0.0))
    est = ident.estimate_payload(robot, t, q, truth.inverse_dynamics(q, qd, qdd) + noise)
    assert est.detected and abs(est.mass - 1.7) <= 0.02
    np.testing.assert_allclose(est.com, com, atol=2e-3)
    none = ident.estimate_payload(robot, t, q, robot.inverse_dynamics(q, qd, qdd) + noise)
    assert not none.detected and none.mass <= 3 * none.mass_std and none.com is None
    assert np.all(np.isfinite(none.friction["viscous"]))       # the friction still fitted
    # efforts of the wrong sign: a mass far below zero, and the summary says what it means
    flipped = ident.estimate_payload(robot, t, q, -truth.inverse_dynamics(q, qd, qdd) + noise)
    assert not flipped.detected and flipped.mass < -3 * flipped.mass_std
    assert "negative beyond them: the torques are not the model's" in flipped.summary()


def test_a_mass_under_a_millionth_of_the_arm_is_none(panda):
    """Exact data (unfiltered): least squares resolves 1e-9 kg far above its standard
    deviation, but a millionth of the arm's mass (16.8 kg: 1.7e-5 kg) is under what any
    URDF states its masses to, so it is no payload; 1e-3 kg is one, to the digit."""
    robot, (t, q, qd, qdd) = panda
    floor = 1e-6 * np.sum(robot.model.mass)
    for mass, found in ((1e-9, False), (1e-3, True)):
        tau = robot.with_payload(mass, (0.0, 0.0, 0.05)).inverse_dynamics(q, qd, qdd)
        est = ident.estimate_payload(robot, t, q, tau, qd, qdd, cutoff=np.inf)
        assert est.detected == found and abs(est.mass - mass) < 1e-6 * mass, (mass, est.mass)
        assert est.mass > 3 * est.mass_std
        if not found:
            assert est.mass < floor and "under 1e-06 of the arm's own mass" in est.summary()
