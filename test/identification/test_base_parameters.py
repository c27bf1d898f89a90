"""Base parameters (Gautier's numerical method): counts, groupings, the projection.

Closed forms (derived here; the classic results of Khalil & Dombre, *Modeling,
Identification and Control of Robots*, 2002, and Mayeda, Yoshida & Osuka, IEEE Trans. Robot.
Autom. 6(3), 1990):

- planar nR arm, parallel axes: the torques about the axes see of body i only m_i, the two
  in-plane first moments and the inertia about the axis (the others act along or about
  directions no joint measures). Body i's origin is a fixed point of body i-1, so m_i acts
  as a point mass there and groups into body i-1's first moment and inertia (m_1: into
  nothing, body 1's origin never moves): 3 per body, b = 3n, when gravity lies in the
  plane of motion (vertical plane). In a horizontal plane the first moments of body 1
  give no torque (its origin is fixed and no gravity acts in the plane): b = 3n - 2.
  For the planar 2R of ``chain_urdf`` (axes y, joint 2 at l = 0.3 m on link 1) the
  groupings are mx1 + l m2 and Iyy1 + l^2 m2.
- armature on a planar arm: Ia_1 has the column qdd_1 e_1, the same as body 1's inertia
  about the axis (it only turns about joint 1): grouped; the others are not: + (n - 1).
- Cartesian PPP (orthogonal prismatic axes z, x, y, gravity along z): only masses act,
  tau_3 = m3 qdd3, tau_2 = (m2 + m3) qdd2, tau_1 = (m1 + m2 + m3)(qdd1 + g): b = 3.
- friction adds its 3n columns (viscous, Coulomb, offset), independent of the rest.

Real arms: the count equals the numerical rank (SVD) of Pinocchio's own regressor
(``computeJointTorqueRegressor``) stacked at random states.
"""
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.identification import BaseParameters, base_parameters
from serial_dynamics.builtin.synthetic import chain_urdf


def rel(a, b):
    return np.max(np.abs(np.asarray(a) - b)) / max(np.max(np.abs(b)), 1e-300)


def planar(n, vertical=True, **kw):
    return sd.load_urdf(chain_urdf(n, axes=("y",) if vertical else ("z",), **kw))


@pytest.mark.parametrize("n", [2, 3, 5])
def test_planar_arm_counts(n):
    assert base_parameters(planar(n, vertical=True)).count == 3 * n
    assert base_parameters(planar(n, vertical=False)).count == 3 * n - 2
    assert base_parameters(planar(n, vertical=True), friction=True).count == 3 * n + 3 * n
    arm = planar(n, vertical=True).model
    with_rotors = sd.load_urdf(chain_urdf(n, axes=("y",)), armature={j: 0.1 for j in arm.joint_names})
    assert base_parameters(with_rotors).count == 3 * n + n - 1
    assert base_parameters(planar(n, vertical=False), armature=True).count == 3 * n - 2 + n - 1


def test_planar_2r_grouping():
    bp = base_parameters(planar(2))
    assert list(bp.names) == ["mx1 + 0.3 m2", "mz1", "Iyy1 + 0.09 m2", "mx2", "mz2", "Iyy2"]
    names = list(bp.standard_names)
    K = bp.K
    r = names.index("mx1")
    assert K[0, names.index("m2")] == pytest.approx(0.3, rel=1e-12)
    assert K[2, names.index("m2")] == pytest.approx(0.09, rel=1e-12)
    assert list(bp.independent) == [names.index(k) for k in ("mx1", "mz1", "Iyy1", "mx2", "mz2", "Iyy2")]
    assert r == bp.independent[0]


def test_cartesian_ppp():
    robot = sd.load_urdf(chain_urdf(3, kinds="prismatic", axes=("z", "x", "y")))
    bp = base_parameters(robot)
    assert list(bp.names) == ["m1", "m2", "m3"]
    assert base_parameters(robot, friction=True).count == 3 + 9


def _robots():
    from test_mimic import mimic_chain
    from test_regressor import spatial_chain
    return {
        "ur5e": sd.default_robot(),
        "spatial_friction_armature": sd.load_urdf(spatial_chain(["revolute", "prismatic", "revolute", "revolute"], 3),
                                                  armature={"j0": 0.5, "j2": 0.1}),
        "mimic": sd.load_urdf(mimic_chain()),
        "payload": sd.default_robot().with_payload(1.0, (0.0, 0.0, 0.1)),
    }


@pytest.mark.parametrize("name", ["ur5e", "spatial_friction_armature", "mimic", "payload"])
def test_base_regressor_reproduces_the_torques(name):
    robot = _robots()[name]
    for friction in (False, True):
        bp = base_parameters(robot, friction=friction)
        p = len(bp.standard_names)
        assert bp.K.shape == (bp.count, p) and bp.count < p
        np.testing.assert_array_equal(bp.K[:, bp.independent], np.eye(bp.count))
        assert np.all(np.diff(bp.independent) > 0)
        rng = np.random.default_rng(42)                 # states other than the ones sampled
        q, qd = robot.random_state(rng, batch=20, speed=3.0)
        qdd = rng.normal(size=q.shape) * 5
        Y = robot.regressor(q, qd, qdd, friction=friction)
        phi = robot.inertial_parameters(friction=friction)
        assert rel(bp.project(Y) @ bp.beta(phi), Y @ phi) <= 1e-10
        # any parameters, not only the robot's: Y phi depends on phi only through beta
        psi = rng.normal(size=p)
        assert rel(bp.project(Y) @ bp.beta(psi), Y @ psi) <= 1e-10
        assert rel(bp.project(Y[0]) @ bp.beta(psi), Y[0] @ psi) <= 1e-10


def test_deterministic():
    robot = sd.default_robot()
    a, b = base_parameters(robot, friction=True), base_parameters(robot, friction=True)
    np.testing.assert_array_equal(a.independent, b.independent)
    np.testing.assert_array_equal(a.K, b.K)
    assert a.names == b.names
    c = base_parameters(robot, friction=True, seed=7, samples=200)   # other states, same answer
    np.testing.assert_array_equal(a.independent, c.independent)
    assert np.max(np.abs(a.K - c.K)) <= 1e-9
    assert a.names == c.names


def test_names_are_readable():
    bp = base_parameters(sd.default_robot())
    assert isinstance(bp, BaseParameters) and len(bp.names) == bp.count == 36
    assert "mx6" in bp.names and "Ixx6 - Iyy6" in bp.names
    assert bp.standard_names[:3] == ("m1", "mx1", "my1")
    assert "m1" not in " ".join(bp.names).split()              # body 1's origin never moves


@pytest.mark.parametrize("kw, match", [(dict(tol=0.0), "tol"), (dict(tol=2.0), "tol"),
                                       (dict(samples=3), "samples = 3")])
def test_bad_arguments(kw, match):
    with pytest.raises(ValueError, match=match):
        base_parameters(sd.default_robot(), **kw)


# ---------------------------------------------------------------- Pinocchio's regressor rank
PIN_CHAINS = ["ur5", "panda", "kinova", "z1", "tiago_torso_arm", "baxter_right_arm", "so100",
              "double_pendulum"]


@pytest.mark.parametrize("name", PIN_CHAINS)
def test_count_is_the_rank_of_pinocchios_regressor(name):
    from pin_reference import erd, pin
    from test_pinocchio import CHAINS, _load, reference
    rel_path, base, tip, _ = CHAINS[name]
    path = erd(rel_path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = _load(path, base, tip)
    ref = reference(robot, path)
    cols = np.concatenate([np.arange(10 * (j - 1), 10 * j) for j in ref.jid])
    rng = np.random.default_rng(3)
    rows = []
    for _ in range(-(-4 * cols.size // robot.dof)):
        q, qd = robot.random_state(rng)
        qdd = rng.normal(size=robot.dof)
        Yp = pin.computeJointTorqueRegressor(ref.model, ref.data, ref.q(q), ref.v(qd), ref.v(qdd))
        rows.append(Yp[np.ix_(ref.iv, cols)])
    rank = np.linalg.matrix_rank(np.vstack(rows))
    assert base_parameters(robot, armature=False).count == rank
