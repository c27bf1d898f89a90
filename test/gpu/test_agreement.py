"""serial_dynamics.gpu against the CPU core, robot by robot (in numba's CUDA simulator on a
machine without a card: conftest.py): inverse dynamics, mass matrix, forward dynamics and
the derivatives of inverse dynamics of every fixed-base kind to 1e-12, a free-floating base
(a chain and a tree) to 1e-12, trees (two chains on one base) against their chains, the same
bits run after run and whatever the batch around a state."""
import numpy as np
import pytest

pytest.importorskip("numba_cuda")

import serial_dynamics as sd  # noqa: E402
from serial_dynamics import gpu  # noqa: E402
from serial_dynamics.gpu import device_model as dmod  # noqa: E402
from gpu_cases import robots, states  # noqa: E402
from test_trees import two_arms  # noqa: E402

ROBOTS = robots()


def close(a, b, tol=1e-12):
    """|a - b| <= tol (1 + |b|) everywhere."""
    np.testing.assert_array_less(np.abs(a - b), tol * (1.0 + np.abs(b)))


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_every_kind_agrees_with_the_cpu(name):
    robot = ROBOTS[name]
    q, qd, qdd = states(robot)
    tau = robot.inverse_dynamics(q, qd, qdd)
    close(gpu.inverse_dynamics(robot, q, qd, qdd), tau)
    close(gpu.mass_matrix(robot, q), robot.mass_matrix(q))
    close(gpu.forward_dynamics(robot, q, qd, tau), robot.forward_dynamics(q, qd, tau))
    close(gpu.forward_dynamics(robot, q, qd, tau), qdd, tol=1e-9)   # forward o inverse
    for got, cpu in zip(gpu.inverse_dynamics_derivatives(robot, q, qd, qdd),
                        robot.inverse_dynamics_derivatives(q, qd, qdd)):
        close(got, cpu)


@pytest.mark.parametrize("urdf", ["ur5e", "two_arms"])
def test_a_floating_base_agrees_with_the_cpu(urdf):
    robot = sd.load_urdf(sd.builtin.ur5e_urdf() if urdf == "ur5e" else two_arms(),
                         floating_base=True)
    rng = np.random.default_rng(4)
    q, v = robot.random_state(rng, batch=3, speed=2.0)          # q: [x, y, z, quaternion, joints]
    a = rng.uniform(-3.0, 3.0, v.shape)
    tau = robot.inverse_dynamics(q, v, a)
    close(gpu.inverse_dynamics(robot, q, v, a), tau)
    close(gpu.mass_matrix(robot, q), robot.mass_matrix(q))
    close(gpu.forward_dynamics(robot, q, v, tau), robot.forward_dynamics(q, v, tau))
    joints = rng.uniform(-5.0, 5.0, (3, robot.dof))              # the base free
    close(gpu.forward_dynamics(robot, q, v, joints), robot.forward_dynamics(q, v, joints))
    with pytest.raises(NotImplementedError, match="free-floating base is not supported yet"):
        gpu.inverse_dynamics_derivatives(robot, q, v, a)


def test_same_bits_run_after_run_and_in_any_batch():
    robot = ROBOTS["mimic"]
    q, qd, qdd = states(robot, seed=3)
    first = gpu.inverse_dynamics(robot, q, qd, qdd)
    assert gpu.inverse_dynamics(robot, q, qd, qdd).tobytes() == first.tobytes()
    alone = gpu.inverse_dynamics(robot, q[2:3], qd[2:3], qdd[2:3])
    assert alone.tobytes() == first[2:3].tobytes()
    M = gpu.mass_matrix(robot, q)
    assert gpu.mass_matrix(robot, q[::-1].copy())[::-1].tobytes() == M.tobytes()


def test_device_arrays_in_give_device_arrays_out():
    from numba import cuda
    robot = ROBOTS["ur5e"]
    q, qd, qdd = states(robot, seed=5)
    out = gpu.inverse_dynamics(robot, cuda.to_device(q), cuda.to_device(qd), cuda.to_device(qdd))
    assert not isinstance(out, np.ndarray)
    assert out.copy_to_host().tobytes() == gpu.inverse_dynamics(robot, q, qd, qdd).tobytes()


def _tree(a, b):
    """The DeviceModel of chains a and b hung from one base (a tree: b's first body's parent
    is -1), from their packed arrays; gravity and the tip from a (same gravity in both)."""
    A, B = dmod._build(a.model).host[0], dmod._build(b.model).host[0]
    na, nb = a.dof, b.dof
    P = np.vstack([A[:na], B[:nb], A[na:]])
    parent = np.concatenate([np.arange(na) - 1, np.r_[-1, np.arange(nb - 1) + na]])
    n = na + nb
    return dmod.DeviceModel(n=n, k=n, chain=False, mimic=False, floating=False,
                            host=(P, parent, np.arange(n), np.ones(n), np.zeros(n),
                                  np.zeros((1, 9))))


def test_a_tree_is_its_chains(monkeypatch):
    a, b = ROBOTS["ur5e"], ROBOTS["planar_3r"]
    assert np.allclose(a.gravity, b.gravity)
    tree, na = ROBOTS["payload"], a.dof        # any fixed-base robot stands in for the tree
    monkeypatch.setitem(dmod._CACHE, tree, _tree(a, b))
    (qa, qda, qdda), (qb, qdb, qddb) = states(a, 7), states(b, 8)
    q, qd, qdd = np.hstack([qa, qb]), np.hstack([qda, qdb]), np.hstack([qdda, qddb])
    monkeypatch.setattr(type(tree), "dof", property(lambda self: na + b.dof))
    tau = gpu.inverse_dynamics(tree, q, qd, qdd)
    close(tau, np.hstack([a.inverse_dynamics(qa, qda, qdda), b.inverse_dynamics(qb, qdb, qddb)]))
    M = gpu.mass_matrix(tree, q)
    close(M[:, :na, :na], a.mass_matrix(qa))
    close(M[:, na:, na:], b.mass_matrix(qb))
    assert not M[:, :na, na:].any() and not M[:, na:, :na].any()    # no coupling
    close(gpu.forward_dynamics(tree, q, qd, tau), qdd, tol=1e-9)
    with pytest.raises(NotImplementedError, match="a kinematic tree is not supported on the card yet"):
        gpu.inverse_dynamics_derivatives(tree, q, qd, qdd)


def test_a_chain_run_as_a_tree_gives_the_chains_bits(monkeypatch):
    robot = ROBOTS["armature"]
    q, qd, qdd = states(robot, seed=11)
    chain = gpu.inverse_dynamics(robot, q, qd, qdd), gpu.mass_matrix(robot, q)
    dm = dmod.device_model(robot, "inverse_dynamics")
    monkeypatch.setitem(dmod._CACHE, robot, dmod.DeviceModel(n=dm.n, k=dm.k, chain=False,
                                                             mimic=False, floating=False,
                                                             host=dm.host))
    assert gpu.inverse_dynamics(robot, q, qd, qdd).tobytes() == chain[0].tobytes()
    assert gpu.mass_matrix(robot, q).tobytes() == chain[1].tobytes()


def test_a_planar_joint_agrees_with_pinocchio(tmp_path):
    """A mobile manipulator on a URDF planar joint (test/planar_base.py): the card's inverse
    dynamics, mass matrix, forward dynamics and derivatives of inverse dynamics are
    Pinocchio's ``JointModelPlanar`` answers to 1e-9."""
    from planar_base import PlanarPinocchio, mobile_manipulator_urdf, states as planar_states
    path = tmp_path / "mobile_ur5.urdf"
    path.write_text(mobile_manipulator_urdf())
    robot = sd.load_urdf(str(path))
    pin = PlanarPinocchio(str(path), robot)
    q, qd, qdd = planar_states(np.random.default_rng(11), 3)
    tau = gpu.inverse_dynamics(robot, q, qd, qdd)
    M, a = gpu.mass_matrix(robot, q), gpu.forward_dynamics(robot, q, qd, tau)
    dq, dqd = gpu.inverse_dynamics_derivatives(robot, q, qd, qdd)
    for k in range(3):
        close(tau[k], pin.inverse_dynamics(q[k], qd[k], qdd[k]), tol=1e-9)
        close(M[k], pin.mass_matrix(q[k]), tol=1e-9)
        close(a[k], qdd[k], tol=1e-9)
        for got, want in zip((dq[k], dqd[k]), pin.inverse_dynamics_derivatives(q[k], qd[k], qdd[k])):
            close(got, want, tol=1e-9)
