"""What identification writes, sd.load_urdf reads (issue 22, items 1 and 2): the issue's
loop (UR5e with masses off by 30 %, a 20 s five-harmonic excitation, 0.05 N m torque
noise, the default method, ``write_urdf(path)``, ``load_urdf``), and the robot's own URDF
as the default source of ``write_urdf``."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics import identification as ident
from serial_dynamics.cli import main

from ident_helpers import perturbed_truth

NOISE = 0.05          # N m


@pytest.fixture(scope="module")
def loop(tmp_path_factory):
    d = tmp_path_factory.mktemp("loadable")
    nominal, truth = perturbed_truth(d / "truth.urdf")
    ex = ident.excitation(nominal, duration=20, harmonics=5, maxiter=0, seed=0)
    t, q, qd, qdd = ex.sample(0.02)
    rng = np.random.default_rng(1)
    tau = (truth.inverse_dynamics(q, qd, qdd) - truth.dissipation.torque(qd)
           + NOISE * rng.standard_normal(q.shape))
    return d, nominal, truth, (t, q, qd, tau)


def held_out_rms(robot, truth):
    """Torque error (N m, RMS per joint) of ``robot`` against the truth at random states:
    the base parameters decide every torque, seen in the recording or not."""
    rng = np.random.default_rng(5)
    q, qd, qdd = (rng.uniform(-1, 1, (200, 6)) * s for s in (np.pi, 1.0, 2.0))
    err = (robot.inverse_dynamics(q, qd, qdd) - robot.dissipation.torque(qd)
           - truth.inverse_dynamics(q, qd, qdd) + truth.dissipation.torque(qd))
    return np.sqrt(np.mean(err ** 2, axis=0))


def test_the_default_path_writes_a_urdf_that_loads(loop):
    d, nominal, truth, (t, q, qd, tau) = loop
    assert nominal.model.source == sd.builtin_path("ur5e")
    res = ident.identify(nominal, t, q, tau)                     # method "wls", no source
    # the plain fit is not physical for some bodies: what is written is the closest
    # physically consistent set, and the summary says so
    assert res.method == "wls" and res.unphysical, res.summary()
    assert f"not physically consistent for {list(res.unphysical)}" in res.summary()
    assert res.physical().all()
    assert np.all(res.consistent_rms < 1.02 * res.rms) and np.all(res.rms < 1.1 * NOISE)
    res.write_urdf(d / "identified.urdf")                         # no source=
    identified = sd.load_urdf(str(d / "identified.urdf"))
    err = held_out_rms(identified, truth)
    assert np.all(err < 0.2 * held_out_rms(nominal, truth)), err
    assert np.all(err < NOISE), err


def test_a_robot_keeps_its_source_across_payloads_and_strings(loop, tmp_path):
    d, _, _, (t, q, qd, tau) = loop
    xml = (d / "truth.urdf").read_text()
    from_string = sd.load_urdf(xml)
    assert from_string.model.source == xml
    assert from_string.with_payload(0.5).model.source == xml
    assert from_string.with_payload(0.5).without_payload().model.source == xml
    res = ident.identify(from_string, t, q, tau, method="ols")
    res.write_urdf(tmp_path / "from_string.urdf")
    assert sd.load_urdf(str(tmp_path / "from_string.urdf")).dof == 6
    # a model built by hand has no URDF: the message says what to give
    m = from_string.model
    import dataclasses
    by_hand = ident.identify(sd.Robot(dataclasses.replace(m, source=None)), t, q, tau,
                             method="ols")
    with pytest.raises(ValueError, match="built by hand.*source="):
        by_hand.write_urdf(tmp_path / "x.urdf")


def test_the_cli_default_writes_a_urdf_that_loads(loop, capsys):
    d, _, truth, (t, q, qd, tau) = loop
    names = truth.joint_names
    header = ["t"] + [f"{w}_{j}" for w in ("q", "qd", "tau") for j in names]
    np.savetxt(d / "run.csv", np.column_stack([t, q, qd, tau]), delimiter=",",
               header=",".join(header), comments="")
    assert main(["identify", sd.builtin_path("ur5e"), str(d / "run.csv"), "--quiet",
                 "--out", str(d / "cli.urdf")]) == 0
    text = capsys.readouterr().out
    assert "method wls" in text and "write_urdf writes the physically consistent" in text
    assert np.all(held_out_rms(sd.load_urdf(str(d / "cli.urdf")), truth) < NOISE)
