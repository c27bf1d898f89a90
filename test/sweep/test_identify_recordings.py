"""sweep.identify_recordings: a folder of recordings, one row each with its validation
error; a recording that cannot be identified is its row's error."""
import numpy as np

import serial_dynamics as sd
from serial_dynamics import sweep


def write_recording(path, robot, seed, noise):
    """10 s of a multi-sine motion at 200 Hz; torques by inverse dynamics plus the robot's
    friction, and white noise of ``noise`` N m."""
    rng = np.random.default_rng(seed)
    t = np.arange(2000) / 200.0
    w = 2 * np.pi * np.array([0.1, 0.23, 0.37])
    a, phase = rng.uniform(0.2, 0.5, (3, robot.dof)), rng.uniform(0, 2 * np.pi, (3, robot.dof))
    arg = w[None, :, None] * t[:, None, None] + phase[None]            # (N, 3, n)
    q = np.sum(a * np.sin(arg), axis=1)
    qd = np.sum(a * w[:, None] * np.cos(arg), axis=1)
    qdd = -np.sum(a * (w**2)[:, None] * np.sin(arg), axis=1)
    tau = robot.inverse_dynamics(q, qd, qdd) + robot.dissipation_torques(qd)
    tau += noise * rng.standard_normal(tau.shape)
    names = robot.joint_names
    head = ",".join(["t"] + [f"{p}_{j}" for p in ("q", "qd", "tau") for j in names])
    np.savetxt(path, np.column_stack([t, q, qd, tau]), delimiter=",", header=head, comments="")


def test_one_row_per_recording_with_its_validation_error(tmp_path):
    robot = sd.default_robot()
    arm = sd.Robot(robot.model, robot.dissipation.override(viscous=0.5, coulomb=1.0))
    write_recording(tmp_path / "arm_a.csv", arm, 1, 0.0)
    write_recording(tmp_path / "arm_b.csv", arm, 2, 0.5)
    (tmp_path / "arm_c.csv").write_text("t,q_shoulder_pan_joint\n0,0\n")
    (tmp_path / "notes.txt").write_text("not a recording")
    table = sweep.identify_recordings(robot, tmp_path, client="serial")
    assert [p.rsplit("/", 1)[1] for p in table["recording"]] == ["arm_a.csv", "arm_b.csv",
                                                                 "arm_c.csv"]
    a, b, c = (table.iloc[k] for k in range(3))
    assert a["error"] == "" and b["error"] == ""
    assert a["samples"] == 2000 and a["validation_error"] < 1e-3      # noiseless: the model
    assert a["validation_error"] < b["validation_error"] < 0.2         # noise: worse, still good
    assert 0.05 < b["validation_rms_wrist_3_joint"] < 0.5   # the 0.5 N m noise, low-passed
    assert c["error"].startswith("ValueError:") and "has no column" in c["error"]
