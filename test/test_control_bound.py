"""The explicit-PD stability bound of ``serial_dynamics.control`` (plain Python, no
rclpy): the closed form against the spectral radius of the step matrix, the effective
inertia against the inverse mass matrix, and the xArm7 case of issue 20."""
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics import control

from pin_reference import erd


def step_radius(kp, kd, m, h):
    """Spectral radius of one period of semi-implicit Euler under the PD of the state at
    the period's start: v+ = v + h (-kp x - kd v)/m, x+ = x + h v+."""
    a = np.array([[1.0, h], [0.0, 1.0]]) @ np.array([[1.0, 0.0], [-h * kp / m, 1.0 - h * kd / m]])
    return np.max(np.abs(np.linalg.eigvals(a)))


def test_the_closed_form_is_the_spectral_radius_bound():
    rng = np.random.default_rng(0)
    h, m = 0.002, 0.05
    for _ in range(2000):
        wh, zeta = rng.uniform(0.0, 2.5), rng.uniform(0.0, 3.0)
        w = wh / h
        kp, kd = m * w * w, 2.0 * zeta * w * m
        stable = step_radius(kp, kd, m, h) < 1.0 - 1e-9
        inside = wh < 2.0 * (np.sqrt(zeta ** 2 + 1.0) - zeta)      # docs/simulation.md
        if abs(wh - 2.0 * (np.sqrt(zeta ** 2 + 1.0) - zeta)) < 1e-3:
            continue                                              # on the edge: either
        assert stable == inside == (len(control.beyond([kp], [kd], [m], h)) == 0), (wh, zeta)
    # Kp = 0 (damping only): Kd h < 2 m
    assert len(control.beyond([0.0], [1.9 * m / h], [m], h)) == 0
    assert len(control.beyond([0.0], [2.1 * m / h], [m], h)) == 1


@pytest.fixture(scope="module")
def xarm():
    try:
        path = erd("xarm_description/urdf/xarm7.urdf")
    except Exception as exc:   # noqa: BLE001
        pytest.skip(str(exc))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return sd.load_urdf(path, "link_base", "link7")


def test_effective_inertia_and_the_xarm7_at_rest_upright(xarm):
    q = np.zeros(xarm.dof)
    M = xarm.mass_matrix(q)
    m = control.effective_inertia(xarm, q)
    assert np.allclose(m, 1.0 / np.diag(np.linalg.inv(M)), rtol=1e-10)
    assert np.all(m <= np.diag(M) * (1 + 1e-12))
    ratio = np.diag(M) / m
    assert ratio[0] > 10 and ratio[2] > 10, ratio          # the axes that line up
    h = 1 / 500
    # docs/ros.md's example gains times M_ii(0): inside the bound, but only just
    kp, kd = 900 * np.diag(M), 60 * np.diag(M)
    assert len(control.beyond(kp, kd, m, h)) == 0
    assert np.max(control.smallest_inertia(kp, kd, h) / m) > 0.25
    # the controller's default (control.pd_gains): every mode of the arm held at q,
    # M x'' = -Kp' x - Kd' x', is x'' + mu kd x' + mu kp x = 0 with 0 < mu <= 1 (= 1 for
    # one), so within the bound whenever kp h^2 + 2 kd h < 4 (0.24 here), at every pose
    for q in np.random.default_rng(1).uniform(-1, 1, (20, xarm.dof)):
        m = control.effective_inertia(xarm, q)
        kp, kd = control.pd_gains(xarm, q, 900.0, 60.0)
        assert len(control.beyond(kp, kd, m, h)) == 0
        M = xarm.mass_matrix(q)
        mu = np.linalg.eigvals(np.linalg.solve(M, np.diag(kp))).real / 900.0
        assert np.isclose(mu.max(), 1.0, rtol=1e-9) and mu.min() > 0, mu
        mu_d = np.linalg.eigvals(np.linalg.solve(M, np.diag(kd))).real / 60.0
        assert np.allclose(np.sort(mu_d), np.sort(mu), rtol=1e-9)
    # twenty times too stiff at the first joint: flagged, and explained by name
    m = control.effective_inertia(xarm, np.zeros(xarm.dof))
    kp = 900 * m
    kp[0] *= 20 * 400
    assert control.beyond(kp, 60 * m, m, h).tolist() == [0]
    text = control.explain("joint1", kp[0], 60 * m[0], m[0], h)
    assert "joint1" in text and "500 Hz" in text and "raise control_rate" in text, text
