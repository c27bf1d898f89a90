"""The charts of robot/charts.py against their definitions, by differences: q(phi) moves
with v as d phi/dt = C(phi) v says, the transposes are C's, and the chart's part of dT/dphi
is what C's dependence on phi adds to T."""
import numpy as np

import serial_dynamics as sd
from serial_dynamics.builtin.synthetic import satellite_urdf
from serial_dynamics.robot.charts import EUCLIDEAN, FREE_FLYER


def C_of(chart, q_ref, phi):
    """C(phi) (nv, nv) column by column from chart.rate."""
    q = chart.point(q_ref, phi)
    return np.column_stack([chart.rate(q, phi, e) for e in np.eye(phi.shape[0])])


def test_the_free_flyer_chart():
    robot = sd.load_urdf(satellite_urdf())
    q_ref, v = robot.random_state(7, speed=1.0)
    phi = np.r_[0.1, -0.2, 0.3, 0.4, -0.7, 0.5, q_ref[7:] + 0.1]
    np.testing.assert_allclose(FREE_FLYER.point(q_ref, FREE_FLYER.centre(q_ref)), q_ref,
                               rtol=0, atol=3e-16)          # the quaternion renormalized
    # d/dt q(phi + t C v) at t = 0 is the motion v: q(phi)'s integrate by v, to O(h^2)
    q = FREE_FLYER.point(q_ref, phi)
    for h in (1e-4, 1e-5):
        moved = FREE_FLYER.point(q_ref, phi + h * FREE_FLYER.rate(q, phi, v))
        assert np.max(np.abs(moved - robot.integrate(q, v, h))) <= 50 * h * h
    # the transposes are C's
    C, C0 = C_of(FREE_FLYER, q_ref, phi), C_of(FREE_FLYER, q_ref, FREE_FLYER.centre(q_ref))
    p = np.linspace(-1.0, 1.0, robot.nv)
    np.testing.assert_allclose(FREE_FLYER.transposed(q, phi, p), C.T @ p, rtol=0, atol=1e-14)
    at = FREE_FLYER.at_centre(q_ref)
    np.testing.assert_allclose(at.transposed(p), C0.T @ p, atol=1e-15)
    np.testing.assert_allclose(at.covector(p), np.linalg.solve(C0.T, p), atol=1e-15)
    np.testing.assert_allclose(at.vector(p), C0 @ p, atol=1e-15)
    # dT/dphi at the centre, fixed phi' (= C(0) v): the base's rows are the chart's part
    # (M does not depend on the base's pose: v is in the base frame)
    M = robot.mass_matrix(q_ref)
    rate = C0 @ v

    def T(x):
        w = np.linalg.solve(C_of(FREE_FLYER, q_ref, x), rate)
        return 0.5 * w @ M @ w
    centre, h = FREE_FLYER.centre(q_ref), 1e-6
    grad = np.array([(T(centre + h * e) - T(centre - h * e)) / (2 * h) for e in np.eye(robot.nv)[:6]])
    chart_part = FREE_FLYER.gradient(v, M @ v)
    np.testing.assert_allclose(chart_part[:6], grad, rtol=0, atol=1e-8 * np.abs(grad).max())
    assert not chart_part[6:].any() and np.abs(grad[3:]).max() > 1e-2      # not trivially 0
    # far from the centre: a turn beyond 1 rad
    assert FREE_FLYER.far(np.r_[0, 0, 0, 0.8, 0.7, 0, q_ref[7:]])
    assert not FREE_FLYER.far(np.r_[5.0, 5.0, 5.0, 0.5, 0.5, 0, q_ref[7:]])


def test_the_euclidean_chart_is_the_identity():
    q, v = np.linspace(-1, 1, 5), np.linspace(2, 3, 5)
    assert np.array_equal(EUCLIDEAN.point(q * 0, q), q) and EUCLIDEAN.point(q, q) is not q
    assert np.array_equal(EUCLIDEAN.rate(q, q, v), v) and np.array_equal(EUCLIDEAN.centre(q), q)
    at = EUCLIDEAN.at_centre(q)
    for f in (at.vector, at.covector, at.transposed):
        assert np.array_equal(f(v), v)
    assert np.array_equal(EUCLIDEAN.transposed(q, q, v), v) and not EUCLIDEAN.gradient(v, v).any()
    assert not EUCLIDEAN.far(q * 1e9)
    assert sd.default_robot().chart is EUCLIDEAN
    assert sd.load_urdf(satellite_urdf()).chart is FREE_FLYER
