"""The floating-base reference (algorithms/floating.py): the textbook's natural orthogonal
complement with its identity block, and the two forward-dynamics routes against inverse
dynamics."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.algorithms import floating as fb
from serial_dynamics.urdf import load_model


def model(name="ur5e", **kw):
    return load_model(sd.builtin_path(name), floating_base=True, **kw)


@pytest.mark.filterwarnings("ignore::serial_dynamics.HeldJointsWarning")
def test_T_transpose_M_T_is_the_recursive_mass_matrix():
    """Angeles eq. 7.87-7.90: with the base's twist [omega_0; cdot_0] among the generalized
    speeds, T has the 6x6 identity block and I = T^T M T (then into v's order by C)."""
    for m in (model(), model(tip_link="forearm_link")):
        q, _ = fb.random_state(m, 1, batch=4)
        T, Mb, C = fb.twist_shaping(m, q), fb.mass_blocks(m, q), fb.speeds_from_v(m)
        np.testing.assert_array_equal(T[:, :6, :6], np.broadcast_to(np.eye(6), (4, 6, 6)))
        I_book = np.swapaxes(T, 1, 2) @ Mb @ T
        M = fb.mass_matrix(m, q)
        np.testing.assert_allclose(C.T @ I_book @ C, M, rtol=0, atol=1e-12 * np.abs(M).max())


def test_forward_dynamics_inverts_inverse_dynamics_by_both_routes():
    m = model()
    rng = np.random.default_rng(2)
    q, v = fb.random_state(m, rng, batch=6, speed=3.0)
    a = rng.normal(size=(6, m.dof + 6))
    w = rng.normal(size=(6, 6))
    tau = fb.inverse_dynamics(m, q, v, a, wrench=w)           # a wrench on the base too
    for method in ("aba", "cholesky"):
        np.testing.assert_allclose(fb.forward_dynamics(m, q, v, tau, w, method), a, atol=1e-10)


def test_a_massless_base_turned_by_its_first_joint_is_refused():
    """spatial_3r's base_link has no <inertial>: joint1 turns it against link1 at no cost."""
    with pytest.raises(sd.ModelError, match="singular mass matrix.*Give the base link an <inertial>"):
        model("spatial_3r")


def test_quaternions_of_any_length_mean_their_rotation():
    m = model()
    q, v = fb.random_state(m, 3)
    q2 = q.copy()
    q2[3:7] *= 7.0
    np.testing.assert_array_equal(fb.mass_matrix(m, q2), fb.mass_matrix(m, q))
    np.testing.assert_allclose(fb.inverse_dynamics(m, q2, v, v), fb.inverse_dynamics(m, q, v, v),
                               atol=1e-12)
