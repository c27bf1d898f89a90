"""Recordings in the formats users have: the CSV that SimulationResult.to_csv writes, and
ROS 2 bags (sqlite3 and MCAP) of sensor_msgs/JointState written with rosbags from a
simulation, joints in another order and with an extra joint; identification from each
gives the same parameters as from the arrays."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics import identification as ident

from ident_helpers import COULOMB, VISCOUS, record

pytest.importorskip("rosbags")


@pytest.fixture(scope="module")
def sim():
    robot = sd.default_robot()
    robot.dissipation = robot.dissipation.override(viscous=VISCOUS, coulomb=COULOMB)
    ex = ident.excitation(robot, duration=5, harmonics=3, maxiter=0, seed=1)
    res, t, q, tau = record(robot, ex, noise=False)
    return robot, res


def same(a, b, tol):
    return a.shape == b.shape and np.max(np.abs(a - b)) <= tol * max(np.max(np.abs(b)), 1)


def test_csv_of_a_simulation(sim, tmp_path):
    robot, res = sim
    path = tmp_path / "run.csv"
    res.to_csv(path)
    rec = ident.load_recording(path, robot.joint_names)
    assert rec.joint_names == tuple(robot.joint_names)
    # to_csv writes 10 significant digits
    for got, want in ((rec.t, res.t), (rec.q, res.q), (rec.qd, res.qd), (rec.tau, res.tau)):
        assert same(got, want, 1e-9)
    a = ident.identify(robot, rec.t, rec.q, rec.tau, rec.qd)
    b = ident.identify(robot, res.t, res.q, res.tau, res.qd)
    assert np.allclose(a.beta, b.beta, rtol=1e-5, atol=1e-6 * np.abs(b.beta).max())


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_ros2_bag_round_trip(sim, tmp_path, storage):
    robot, res = sim
    names = list(robot.joint_names)
    # another order, and a joint the model does not have (a gripper's)
    order = [5, 2, 0, 4, 1, 3]
    extra = np.zeros((res.t.size, 1))
    path = tmp_path / f"bag_{storage}"
    ident.write_bag(path, res.t, np.hstack([res.q[:, order], extra]),
                    np.hstack([res.qd[:, order], extra]), np.hstack([res.tau[:, order], extra]),
                    [names[k] for k in order] + ["gripper_joint"], storage=storage)
    rec = ident.load_recording(path, names)
    assert np.allclose(rec.t, res.t - res.t[0], atol=2e-9)     # nanosecond stamps
    assert np.array_equal(rec.q, res.q) and np.array_equal(rec.qd, res.qd)
    assert np.array_equal(rec.tau, res.tau)
    a = ident.identify(robot, rec.t, rec.q, rec.tau, rec.qd)
    b = ident.identify(robot, res.t, res.q, res.tau, res.qd)
    assert np.allclose(a.beta, b.beta, rtol=1e-6, atol=1e-9 * np.abs(b.beta).max())


def test_bags_and_csvs_name_what_is_missing(sim, tmp_path):
    robot, res = sim
    path = tmp_path / "bag"
    ident.write_bag(path, res.t[:10], res.q[:10], None, res.tau[:10], robot.joint_names)
    rec = ident.load_recording(path, robot.joint_names)
    assert rec.qd is None                       # no velocity: identify differentiates q
    with pytest.raises(ValueError, match="has no topic '/arm/joint_states'.*'/joint_states"):
        ident.load_recording(path, robot.joint_names, topic="/arm/joint_states")
    with pytest.raises(ValueError, match="no JointState naming all of the joints"):
        ident.load_recording(path, robot.joint_names[:5] + ["elbow"])
    csv = tmp_path / "a.csv"
    np.savetxt(csv, np.zeros((3, 2)), delimiter=",", header="t,q_x", comments="")
    with pytest.raises(ValueError, match="no column 'q_shoulder_pan_joint'"):
        ident.load_recording(csv, robot.joint_names)
    txt = tmp_path / "run.txt"
    txt.write_text("t\n")
    with pytest.raises(ValueError, match="give a .csv file"):
        ident.load_recording(txt, robot.joint_names)
    with pytest.raises(ValueError, match="recording '.*run_bag' not found"):
        ident.load_recording(tmp_path / "run_bag", robot.joint_names)


def test_non_uniform_times_are_resampled(sim):
    robot, res = sim
    keep = np.ones(res.t.size, bool)
    keep[1::7] = False                          # dropped messages
    r = ident.identify(robot, res.t[keep], res.q[keep], res.tau[keep], res.qd[keep])
    ref = ident.identify(robot, res.t, res.q, res.tau, res.qd)
    assert r.samples.resampled and not ref.samples.resampled
    rel = np.abs(r.beta - ref.beta) / np.maximum(ref.std, 1e-12)
    assert np.max(rel) < 1.0                    # within a standard deviation of the full run
