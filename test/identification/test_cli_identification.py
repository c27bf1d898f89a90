"""serial-dynamics excite and identify, as a user runs them: an excitation CSV, a recording
of the 'true' arm following it (CSV and ROS 2 bag), the identified URDF loaded back, the
summary table, the plot, and one-line errors."""
import subprocess
import sys

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics import identification as ident
from serial_dynamics.cli import main

from ident_helpers import perturbed_truth, record


def test_excite_writes_a_trajectory_at_rest_at_both_ends(tmp_path, capsys):
    out = tmp_path / "traj.csv"
    assert main(["excite", "--duration", "4", "--harmonics", "2", "--maxiter", "1",
                 "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "condition number" in text and "iteration   1" in text and f"wrote {out}" in text
    head = out.read_text().splitlines()[0].split(",")
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    assert head[0] == "t" and head[1] == "q_shoulder_pan_joint" and len(head) == 19
    assert table.shape == (401, 19) and table[-1, 0] == 4.0
    qd = table[:, 7:13]
    assert np.max(np.abs(qd[[0, -1]])) < 1e-9 and np.max(np.abs(qd)) > 0.1


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    nominal, truth = perturbed_truth(d / "truth.urdf")
    ex = ident.excitation(nominal, duration=6, harmonics=3, maxiter=0, seed=0)
    res, t, q, tau = record(truth, ex, seed=4)
    res.q[:], res.tau[:] = q, tau                 # the sensor's view: quantized, noisy
    res.to_csv(d / "run.csv")
    ident.write_bag(d / "run_bag", t, q, None, tau, nominal.joint_names, storage="mcap")
    return d, truth


def test_identify_from_a_csv_writes_the_corrected_urdf(recording, capsys):
    d, truth = recording
    urdf = sd.builtin_path("ur5e")
    assert main(["identify", urdf, str(d / "run.csv"), "--method", "physical",
                 "--validate", str(d / "run_bag"), "--out", str(d / "identified.urdf"),
                 "--plot", str(d / "fit.png")]) == 0
    text = capsys.readouterr().out
    assert "parameter" in text and "std" in text and "URDF" in text and "change %" in text
    assert "fv1" in text and "validation relative error" in text
    assert "every body physically consistent" in text
    assert (d / "fit.png").stat().st_size > 10_000
    identified = sd.load_urdf(str(d / "identified.urdf"))
    # the identified URDF is much closer to the truth than the one we started from
    bp = ident.base_parameters(identified, friction=True)
    b_true = bp.beta(truth.inertial_parameters(friction=True))
    b_id = bp.beta(identified.inertial_parameters(friction=True))
    b_urdf = bp.beta(sd.default_robot().inertial_parameters(friction=True))
    k = [i for i, nm in enumerate(bp.names) if not nm.startswith("fo")]
    assert np.linalg.norm((b_id - b_true)[k]) < 0.1 * np.linalg.norm((b_urdf - b_true)[k])


def test_identify_errors_are_one_line(recording, tmp_path):
    d, _ = recording
    bad = tmp_path / "bad.csv"
    text = (d / "run.csv").read_text().splitlines()
    cells = text[5].split(",")
    cells[3] = "nan"
    text[5] = ",".join(cells)
    bad.write_text("\n".join(text) + "\n")
    out = subprocess.run([sys.executable, "-m", "serial_dynamics.cli", "identify",
                          sd.builtin_path("ur5e"), str(bad)], capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 2, out.stderr
    assert out.stderr.startswith("serial-dynamics: error: q_elbow_joint is nan at t = 0.004 s")
    assert "Traceback" not in out.stderr
