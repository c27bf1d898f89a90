"""control.py: the three laws, against their definitions."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics import control


def test_the_laws():
    robot = sd.default_robot()
    robot.dissipation = robot.dissipation.override(viscous=0.4, coulomb=1.5)
    rng = np.random.default_rng(4)
    q, qd = robot.random_state(rng)
    e, ed, qdd = rng.normal(size=(3, robot.dof))
    kp, kd = np.full(6, 400.0), np.full(6, 40.0)
    ct = control.torque(robot, "computed_torque", q, qd, e, ed, qdd, kp, kd)
    # tau = M (qdd + kp e + kd ed) + b: the closed loop's error obeys e'' + kd e' + kp e = 0
    np.testing.assert_allclose(ct, robot.mass_matrix(q) @ (qdd + kp * e + kd * ed)
                               + robot.bias_torques(q, qd), rtol=1e-10, atol=1e-10)
    pkp, pkd = control.pd_gains(robot, q, kp, kd)
    Minv = np.linalg.inv(robot.mass_matrix(q))
    m = 1.0 / np.diag(Minv)                                   # effective inertias at q
    lam = np.linalg.eigvalsh(np.sqrt(m)[:, None] * Minv * np.sqrt(m)[None, :])[-1]
    assert lam >= 1.0                                         # unit diagonal: the coupling
    np.testing.assert_allclose(pkp, kp * m / lam, rtol=1e-10)    # Kp' = kp m / lam
    np.testing.assert_allclose(pkd, kd * m / lam, rtol=1e-10)
    pd = control.torque(robot, "pd_gravity", q, qd, e, ed, qdd, pkp, pkd)
    np.testing.assert_allclose(pd, pkp * e + pkd * ed + robot.gravity_torques(q), rtol=1e-13)
    g = control.torque(robot, "gravity_compensation", q, qd, e, ed, qdd, kp, kd, True)
    np.testing.assert_allclose(g, robot.gravity_torques(q) - robot.dissipation_torques(qd))
    with pytest.raises(ValueError, match="'impedance' unknown"):
        control.torque(robot, "impedance", q, qd, e, ed, qdd, kp, kd)
