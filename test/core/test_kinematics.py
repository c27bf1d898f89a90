"""The compiled kinematics (core/kinematics.py: frame poses, Jacobians, frame
accelerations, center of mass, centroidal momentum, potential energy, the Coriolis matrix)
against the NumPy reference on every kind of robot
-- chain, tree, mimic joints, planar, floating base -- to 1e-12; a batch row is bitwise the
single-state answer; bad input names the culprit. (Pinocchio agreement of the same methods:
test/oracles/test_pinocchio*.py, which run the compiled backend.)"""
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from pin_reference import erd
from serial_dynamics.builtin.synthetic import mimic_chain_urdf, two_arm_urdf

ROBOTS = {
    "ur5e": lambda fl: sd.load_urdf(sd.builtin_path("ur5e"), floating_base=fl),
    "planar_3r": lambda fl: sd.load_urdf(sd.builtin_path("planar_3r"), floating_base=fl),
    "two arms": lambda fl: sd.load_urdf(two_arm_urdf(3, base_mass=4.0), floating_base=fl),
    "mimic chain": lambda fl: sd.load_urdf(mimic_chain_urdf(4), floating_base=fl),
    "talos (tree, mimic)": lambda fl: sd.load_urdf(erd("talos_data/robots/talos_full_v2.urdf"),
                                                   floating_base=fl),
}


def close(a, b):
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * max(1.0, np.max(np.abs(b))))


@pytest.fixture(params=[(name, fl) for name in ROBOTS for fl in (False, True)
                        if not (fl and name == "planar_3r")],      # its base has no mass
                ids=lambda p: f"{p[0]}{', floating' if p[1] else ''}")
def pair(request):
    name, fl = request.param
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        fast = ROBOTS[name](fl)
    return fast, sd.Robot(fast.model, backend="numpy")


def test_the_compiled_kinematics_is_the_reference(pair):
    fast, ref = pair
    q, qd = fast.random_state(3, batch=4)
    if fast.is_floating:
        q[1, 3:7] *= 2.5                     # any quaternion length means the same rotation
    qdd = np.random.default_rng(4).uniform(-2, 2, qd.shape)
    for link in [None] + fast.link_names:    # every link, the base's and the tip included
        X, J = fast.forward_kinematics(q, link), fast.jacobian(q, link)
        A = fast.frame_acceleration(q, qd, qdd, link)
        close(X, ref.forward_kinematics(q, link))
        close(J, ref.jacobian(q, link))
        close(A, ref.frame_acceleration(q, qd, qdd, link))
        for k in range(4):                   # a batch row is the single call's bits
            assert fast.forward_kinematics(q[k], link).tobytes() == X[k].tobytes()
            assert fast.jacobian(q[k], link).tobytes() == J[k].tobytes()
            assert fast.frame_acceleration(q[k], qd[k], qdd[k], link).tobytes() == A[k].tobytes()
        close(fast.jacobian_dot_qd(q[0], qd[0], link), ref.jacobian_dot_qd(q[0], qd[0], link))
    for name, args in (("center_of_mass", (q,)), ("potential_energy", (q,)),
                       ("centroidal_momentum", (q, qd)), ("coriolis_matrix", (q, qd))):
        batch = getattr(fast, name)(*args)
        close(batch, getattr(ref, name)(*args))
        for k in range(4):
            assert np.asarray(getattr(fast, name)(*(a[k] for a in args))).tobytes() == \
                np.asarray(batch[k]).tobytes()
    # one configuration broadcast over a batch of velocities
    close(fast.centroidal_momentum(q[0], qd), ref.centroidal_momentum(q[:1], qd))
    close(fast.coriolis_matrix(q[0], qd), ref.coriolis_matrix(q[:1], qd))


def test_centroidal_momentum_is_the_jacobians_momentum():
    """An independent identity: p = sum m_i J_v(c_i) qd over the bodies (the linear momentum
    from each body's Jacobian at its center of mass, here by finite differences of the
    center of mass), so a wrong velocity recursion cannot agree with itself."""
    robot = sd.load_urdf(two_arm_urdf(3, base_mass=4.0), floating_base=True)
    q, v = robot.random_state(11)
    m = robot.model.base_mass + robot.model.mass.sum()
    h = 1e-6
    dc = (robot.center_of_mass(robot.integrate(q, v, h))
          - robot.center_of_mass(robot.integrate(q, v, -h))) / (2 * h)
    np.testing.assert_allclose(robot.centroidal_momentum(q, v)[:3], m * dc, rtol=1e-7)


def test_bad_states_are_named():
    robot = sd.load_urdf(sd.builtin_path("ur5e"), floating_base=True)
    q, v = robot.random_state(0)
    q[3:7] = 0.0
    with pytest.raises(ValueError, match="quaternion"):
        robot.forward_kinematics(q)
    q, v = robot.random_state(0)
    v[8] = np.nan
    with pytest.raises(ValueError, match="^v has a NaN"):
        robot.centroidal_momentum(q, v)
    with pytest.raises(ValueError, match="^q has shape"):
        robot.jacobian(q[:-1])
    with pytest.raises(ValueError, match="'no_such_link' is not a link of the model"):
        robot.jacobian(q, "no_such_link")
    fixed = sd.load_urdf(sd.builtin_path("ur5e"))
    with pytest.raises(ValueError, match="joint 'elbow_joint'"):
        fixed.center_of_mass([0.0, 0.0, np.inf, 0.0, 0.0, 0.0])
