"""The planar fast path: ``algorithms/planar.py`` (detection, layout Q, NumPy reference) and
``core/planar.py`` (compiled kernels) against the general path.

- detection: planar chains (the built-in planar 3R, a 6-link chain, chains with in-plane
  prismatic joints, a plane tilted by the base joint's origin rpy, axes of both senses,
  link frames turned about the normal, offsets along it, products of inertia) give a Q;
  UR5e, the spatial 3R, a prismatic-only chain and chains that miss being planar give None;
- inverse dynamics, bias and gravity torques (with and without a tip wrench) and the mass
  matrix equal the general path's (``Robot``, compiled and NumPy) to 1e-12 relative, one
  state and batches, the NumPy reference and the compiled kernels;
- the armature; textbook example A (shared/reference/textbook_examples.md) through the
  planar functions; status codes (NaN/Inf, wrong lengths); a sample's bits are the same
  alone or in a batch.
"""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.algorithms import planar as ref
from serial_dynamics.core.planar_layout import (ANG, ARM, GX, GY, IZ, RX, RY, SGN, TX, TY,
                                               planar_pack)
from serial_dynamics.core import flags as F
from serial_dynamics.core import OTHER_TYPES
from serial_dynamics.core import K as cp   # the compiled entry points, planar ones included
from serial_dynamics.builtin import planar_3r_urdf
from serial_dynamics.builtin.synthetic import chain_urdf
from test_textbook import G, PLANAR_PARAMS, planar_oracle

TOL = 1e-12
QD_QDD = F.QD | F.QDD


def rel(a, b):
    return np.max(np.abs(np.asarray(a) - b)) / max(np.max(np.abs(b)), 1e-300)


# ------------------------------------------------------------------ robots
def _rot(rpy):
    r, p, y = rpy
    Rx = np.array([[1, 0, 0], [0, np.cos(r), -np.sin(r)], [0, np.sin(r), np.cos(r)]])
    Ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
    Rz = np.array([[np.cos(y), -np.sin(y), 0], [np.sin(y), np.cos(y), 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def _v(x):
    return " ".join(repr(float(v)) for v in x)


def general_planar_urdf(kinds, rpy0=(0.4, -0.9, 0.3), seed=0, tilt=None, name="tilted"):
    """A chain that moves in one plane, written to exercise every field of Q: the base
    joint's origin rpy tilts the whole plane; later joints are turned about the normal and
    some flipped (axis -normal, rpy (pi, 0, yaw)); origins, centers of mass and the tip
    sit off the plane; inertias are full (products of inertia in every frame; built from
    point masses, so physical). Prismatic axes lie in the plane at random angles.
    ``tilt``: (joint index, angle) turns that joint's axis out of the plane (not planar)."""
    rng = np.random.default_rng(seed)
    out = ['<?xml version="1.0"?>', f'<robot name="{name}">', '<link name="base_link"/>']
    parent = "base_link"
    for i, kind in enumerate(kinds):
        m = float(rng.uniform(0.5, 3.0))
        pts = rng.normal(size=(4, 3)) * 0.08                    # point masses about the com
        I = sum(0.25 * m * (p @ p * np.eye(3) - np.outer(p, p)) for p in pts).tolist()
        com, irpy = rng.normal(size=3) * 0.1, rng.uniform(-np.pi, np.pi, 3)
        out.append(f'<link name="link{i + 1}"><inertial><origin xyz="{_v(com)}" rpy="{_v(irpy)}"/>'
                   f'<mass value="{m!r}"/><inertia ixx="{I[0][0]!r}" ixy="{I[0][1]!r}" '
                   f'ixz="{I[0][2]!r}" iyy="{I[1][1]!r}" iyz="{I[1][2]!r}" izz="{I[2][2]!r}"/>'
                   '</inertial></link>')
        if i == 0:
            xyz, rpy = (0.1, -0.2, 0.3), rpy0
        else:
            xyz = (rng.uniform(0.1, 0.4), rng.uniform(-0.1, 0.1), rng.uniform(-0.2, 0.2))
            rpy = (np.pi if rng.uniform() < 0.4 else 0.0, 0.0, rng.uniform(-np.pi, np.pi))
        if kind == "prismatic":
            a = rng.uniform(-np.pi, np.pi)
            axis = (np.cos(a), np.sin(a), 0.0)
            limit = '<limit lower="-0.5" upper="0.5" effort="100" velocity="10"/>'
        else:
            axis = (0.0, 0.0, 1.0 if rng.uniform() < 0.6 else -1.0)
            limit = '<limit lower="-3" upper="3" effort="100" velocity="10"/>'
        if tilt is not None and tilt[0] == i:
            axis = _rot((tilt[1], 0.0, 0.0)) @ np.array(axis)
        out.append(f'<joint name="joint{i + 1}" type="{kind}"><parent link="{parent}"/>'
                   f'<child link="link{i + 1}"/><origin xyz="{_v(xyz)}" rpy="{_v(rpy)}"/>'
                   f'<axis xyz="{_v(axis)}"/>{limit}</joint>')
        parent = f"link{i + 1}"
    out.append('<link name="tip"/>')
    out.append(f'<joint name="tip_joint" type="fixed"><parent link="{parent}"/><child link="tip"/>'
               f'<origin xyz="0.15 0.05 -0.07" rpy="0.3 1.1 -0.4"/></joint>')
    out.append("</robot>")
    return "\n".join(out) + "\n"


MIXED = ["revolute", "prismatic", "revolute", "prismatic", "revolute"]
ROBOTS = {
    # wall-mounted, loaded from 'world': the plane is the world's x-z plane
    "planar_3r": lambda: sd.builtin_robot("planar_3r"),
    "planar_3r_base": lambda: sd.load_urdf(planar_3r_urdf(), base_link="base_link"),
    "planar_6": lambda: sd.load_urdf(chain_urdf(6, axes=("y",))),
    "planar_prismatic": lambda: sd.load_urdf(chain_urdf(5, axes=("z", "x", "z", "y", "z"), kinds=MIXED),
                                             gravity=(1.5, -9.81, 0.4)),
    "tilted": lambda: sd.load_urdf(general_planar_urdf(["revolute"] * 6)),
    "tilted_prismatic": lambda: sd.load_urdf(general_planar_urdf(MIXED + ["revolute"], seed=3)),
    "prismatic_first": lambda: sd.load_urdf(general_planar_urdf(["prismatic", "revolute", "prismatic",
                                                                 "revolute"], seed=5)),
}


class General(sd.Robot):
    """The general (spatial) path for any chain: Robot(model) of a planar chain builds a
    PlanarRobot, a subclass of Robot builds what it names."""


@pytest.fixture(scope="module", params=list(ROBOTS))
def case(request):
    facade = ROBOTS[request.param]()
    assert facade.is_planar and type(facade).__name__ == "PlanarRobot"
    Q = planar_pack(facade.model)
    assert Q is not None, f"{request.param} is planar"
    return request.param, General(facade.model), sd.Robot(facade.model, backend="numpy"), Q


def test_the_facade_of_a_planar_chain_is_the_planar_path(case):
    """Robot(model) of a planar chain answers through the planar kernels: equal to the
    general path to round-off, single states bitwise equal to their rows in a batch."""
    _, general, _, Q = case
    facade = sd.Robot(general.model)
    q, qd, qdd, w = states(general, batch=40, seed=9)
    for args in ((q, qd, qdd), (q, qd, qdd, w)):
        T = facade.inverse_dynamics(*args)
        assert rel(T, general.inverse_dynamics(*args)) <= TOL
        assert not np.array_equal(T, general.inverse_dynamics(*args)) or Q.shape[0] < 3
        for k in (0, 17, 39):
            np.testing.assert_array_equal(T[k], facade.inverse_dynamics(*(a[k] for a in args)))
    M = facade.mass_matrix(q)
    assert rel(M, general.mass_matrix(q)) <= TOL
    np.testing.assert_array_equal(M[5], facade.mass_matrix(q[5]))
    assert rel(facade.bias_torques(q[3], qd[3]), general.bias_torques(q[3], qd[3])) <= TOL
    assert rel(facade.gravity_torques(q[3]), general.gravity_torques(q[3])) <= TOL


def states(robot, seed=0, batch=None):
    rng = np.random.default_rng(seed)
    q, qd = robot.random_state(rng, batch=batch, speed=2.0)
    shape = q.shape
    w = rng.normal(size=6 if batch is None else (batch, 6)) * 5
    return q, qd, rng.normal(size=shape) * 3, w


# ------------------------------------------------------------------ detection
def test_detection_negatives():
    assert planar_pack(sd.default_robot().model) is None                       # UR5e
    assert planar_pack(sd.builtin_robot("spatial_3r").model) is None
    assert planar_pack(sd.load_urdf(chain_urdf(6)).model) is None              # axes z, y, x
    prismatic_only = sd.load_urdf(chain_urdf(3, axes=("x", "y", "x"), kinds="prismatic"))
    assert planar_pack(prismatic_only.model) is None                           # no plane
    # a prismatic axis along the normal, a revolute axis off it by 1e-6 rad or 0.3 rad
    along = sd.load_urdf(chain_urdf(3, axes=("z", "z", "z"), kinds=["revolute", "prismatic", "revolute"]))
    assert planar_pack(along.model) is None
    for tilt in [(2, 1e-6), (3, 0.3), (1, 1e-6)]:
        urdf = general_planar_urdf(MIXED, seed=3, tilt=tilt)
        assert planar_pack(sd.load_urdf(urdf).model) is None, tilt


def test_layout_of_the_planar_3r():
    """Example A from its base: joint frames = planar frames, angles 0, offsets the link
    lengths, gravity -g along the planar y axis, I_nn = I + m (a/2)^2."""
    a, m = np.array([0.4, 0.3, 0.2]), np.array([3.0, 2.0, 1.0])
    robot = sd.load_urdf(planar_3r_urdf(a, m), base_link="base_link")
    Q = planar_pack(robot.model)
    assert Q.shape == (4, ref.WIDTH)
    np.testing.assert_allclose(Q[:3, ANG], 0.0, atol=1e-15)
    np.testing.assert_allclose(Q[:3, SGN], 1.0)
    np.testing.assert_allclose(Q[:3, RX], [0.0, 0.4, 0.3], atol=1e-15)
    np.testing.assert_allclose(Q[:3, RY], 0.0, atol=1e-15)
    I = m * (3 * 0.02**2 + a**2) / 12.0
    np.testing.assert_allclose(Q[:3, IZ], I + m * (a / 2) ** 2, rtol=1e-14)
    np.testing.assert_allclose(Q[3, [GX, GY]], [0.0, -G], atol=1e-14)
    np.testing.assert_allclose(Q[3, [TX, TY]], [0.2, 0.0], atol=1e-15)
    np.testing.assert_allclose(Q[:3, ARM], 0.0)


def test_tilted_chain_uses_both_axis_senses(case):
    """The generated chains have axes of both senses and turned planar frames."""
    name, _, _, Q = case
    if name.startswith("tilted"):
        rev = Q[:-1, SGN] != 0.0
        assert set(Q[:-1, SGN][rev]) == {1.0, -1.0}
        assert np.any(np.abs(Q[1:-1, ANG]) > 1e-3)


# ------------------------------------------------------------------ against the general path
@pytest.mark.parametrize("batch", [None, 37])
def test_reference_matches_the_general_path(case, batch):
    _, robot, numpy_robot, Q = case
    q, qd, qdd, w = states(robot, batch=batch)
    for general in (robot, numpy_robot):
        assert rel(ref.inverse_dynamics(Q, q, qd, qdd), general.inverse_dynamics(q, qd, qdd)) <= TOL
        assert rel(ref.inverse_dynamics(Q, q, qd, qdd, w), general.inverse_dynamics(q, qd, qdd, w)) <= TOL
        assert rel(ref.bias_torques(Q, q, qd), general.bias_torques(q, qd)) <= TOL
        assert rel(ref.bias_torques(Q, q, qd, w), general.bias_torques(q, qd, w)) <= TOL
        assert rel(ref.mass_matrix(Q, q), general.mass_matrix(q)) <= TOL
        assert rel(ref.gravity_torques(Q, q), general.gravity_torques(q)) <= TOL


def test_compiled_single_state_matches_the_general_path(case):
    _, robot, numpy_robot, Q = case
    n = robot.dof
    tau, M = np.empty(n), np.empty((n, n))
    for seed in range(5):
        q, qd, qdd, w = states(robot, seed=seed)
        for general in (robot, numpy_robot):
            assert cp.planar_rnea(Q, q, qd, qdd, QD_QDD, tau) == 0
            assert rel(tau, general.inverse_dynamics(q, qd, qdd)) <= TOL
            assert cp.planar_rnea_wrench(Q, q, qd, qdd, w, QD_QDD, tau) == 0
            assert rel(tau, general.inverse_dynamics(q, qd, qdd, w)) <= TOL
            assert cp.planar_rnea(Q, q, qd, qdd, F.QD, tau) == 0
            assert rel(tau, general.bias_torques(q, qd)) <= TOL
            assert cp.planar_rnea_wrench(Q, q, qd, qdd, w, F.QD, tau) == 0
            assert rel(tau, general.bias_torques(q, qd, w)) <= TOL
            assert cp.planar_rnea(Q, q, qd, qdd, 0, tau) == 0
            assert rel(tau, general.gravity_torques(q)) <= TOL
            assert cp.planar_crba(Q, q, M) == 0
            assert rel(M, general.mass_matrix(q)) <= TOL
        # and against the planar reference
        assert cp.planar_rnea_wrench(Q, q, qd, qdd, w, QD_QDD, tau) == 0
        assert rel(tau, ref.inverse_dynamics(Q, q, qd, qdd, w)) <= TOL
        assert rel(M, ref.mass_matrix(Q, q)) <= TOL


def test_compiled_batches_match_the_general_path(case):
    _, robot, numpy_robot, Q = case
    N, n = 77, robot.dof                 # two full blocks of 32 and a partial one
    q, qd, qdd, W = states(robot, seed=7, batch=N)
    out, MM = np.empty((N, n)), np.empty((N, n, n))
    no_w = np.zeros((1, 6))
    for general in (robot, numpy_robot):
        assert cp.planar_rnea_batch(Q, q, qd, qdd, no_w, QD_QDD, out) == 0
        assert rel(out, general.inverse_dynamics(q, qd, qdd)) <= TOL
        assert cp.planar_rnea_batch(Q, q, qd, qdd, W, QD_QDD | F.WRENCH, out) == 0
        assert rel(out, general.inverse_dynamics(q, qd, qdd, W)) <= TOL
        assert cp.planar_rnea_batch(Q, q, qd, q, W[:1], F.QD | F.WRENCH, out) == 0   # one wrench
        assert rel(out, general.bias_torques(q, qd, W[0])) <= TOL
        assert cp.planar_crba_batch(Q, q, MM) == 0
        assert rel(MM, general.mass_matrix(q)) <= TOL
    # rows of length 1 broadcast: one configuration, many rates
    assert cp.planar_rnea_batch(Q, q[:1], qd, qdd[:1], no_w, QD_QDD, out) == 0
    expect = robot.inverse_dynamics(np.repeat(q[:1], N, 0), qd, np.repeat(qdd[:1], N, 0))
    assert rel(out, expect) <= TOL
    assert cp.planar_crba_batch(Q, q[:1], MM) == 0
    assert rel(MM, np.broadcast_to(robot.mass_matrix(q[0]), (N, n, n))) <= TOL
    # and the reference broadcasts the same way
    assert rel(ref.inverse_dynamics(Q, q[:1], qd, qdd[:1]), expect) <= TOL


def test_a_sample_is_bitwise_the_same_alone_or_in_a_batch(case):
    _, robot, _, Q = case
    N, n = 45, robot.dof
    q, qd, qdd, W = states(robot, seed=11, batch=N)
    q[3, 0], q[40, -1] = 3e5, -2e6        # beyond SMALL_ANGLE: libm's sine and cosine
    out, MM = np.empty((N, n)), np.empty((N, n, n))
    tau, M = np.empty(n), np.empty((n, n))
    for flags in (0, F.QD, F.QDD, QD_QDD, QD_QDD | F.WRENCH):
        assert cp.planar_rnea_batch(Q, q, qd, qdd, W, flags, out) == 0
        for k in range(N):
            if flags & F.WRENCH:
                assert cp.planar_rnea_wrench(Q, q[k], qd[k], qdd[k], W[k], flags, tau) == 0
            else:
                assert cp.planar_rnea(Q, q[k], qd[k], qdd[k], flags, tau) == 0
            assert np.array_equal(tau, out[k]), (flags, k)
    assert cp.planar_crba_batch(Q, q, MM) == 0
    for k in range(N):
        assert cp.planar_crba(Q, q[k], M) == 0 and np.array_equal(M, MM[k]), k


def test_armature():
    """armature[i] adds armature[i] qdd_i to tau_i and to M[i, i], in the planar path and
    in the general one."""
    kinds = MIXED + ["revolute"]
    names = [f"joint{i + 1}" for i in range(6)]
    arm = dict(zip(names, [0.3, 2.0, 0.05, 0.7, 0.0, 0.11]))
    plain = sd.load_urdf(general_planar_urdf(kinds, seed=3))
    geared = sd.load_urdf(general_planar_urdf(kinds, seed=3), armature=arm)
    Q0, Q = planar_pack(plain.model), planar_pack(geared.model)
    a = np.array([arm[k] for k in names])
    np.testing.assert_array_equal(Q[:-1, ARM], a)
    q, qd, qdd, w = states(geared, seed=2, batch=40)
    expect = ref.inverse_dynamics(Q0, q, qd, qdd, w) + a * qdd
    assert rel(ref.inverse_dynamics(Q, q, qd, qdd, w), expect) <= TOL
    assert rel(ref.mass_matrix(Q, q), ref.mass_matrix(Q0, q) + np.diag(a)) <= TOL
    out, MM = np.empty_like(q), np.empty((40, 6, 6))
    assert cp.planar_rnea_batch(Q, q, qd, qdd, w, QD_QDD | F.WRENCH, out) == 0
    assert rel(out, expect) <= TOL
    assert cp.planar_crba_batch(Q, q, MM) == 0
    assert rel(MM, ref.mass_matrix(Q0, q) + np.diag(a)) <= TOL
    tau, M = np.empty(6), np.empty((6, 6))
    assert cp.planar_rnea_wrench(Q, q[0], qd[0], qdd[0], w[0], QD_QDD, tau) == 0
    assert rel(tau, expect[0]) <= TOL
    assert cp.planar_crba(Q, q[0], M) == 0
    assert rel(M, MM[0]) <= TOL
    # the general path with the same armature
    assert rel(out, geared.inverse_dynamics(q, qd, qdd, w)) <= TOL
    assert rel(MM, geared.mass_matrix(q)) <= TOL


# ------------------------------------------------------------------ textbook example A
@pytest.mark.parametrize("params", sorted(PLANAR_PARAMS))
def test_textbook_planar_3r(params):
    a, m, I = PLANAR_PARAMS[params]
    robot = sd.load_urdf(planar_3r_urdf(a, m, I), base_link="base_link")
    if I is None:
        I = np.asarray(m) * (3 * 0.02**2 + np.asarray(a) ** 2) / 12.0
    Q = planar_pack(robot.model)
    rng = np.random.default_rng(12)
    tau, M = np.empty(3), np.empty((3, 3))
    for _ in range(20):
        q, qd, qdd = rng.uniform(-np.pi, np.pi, 3), rng.uniform(-3, 3, 3), rng.uniform(-5, 5, 3)
        M0, v, g = planar_oracle(a, m, I, q, qd)
        assert rel(ref.mass_matrix(Q, q), M0) <= TOL
        assert rel(ref.gravity_torques(Q, q), g) <= TOL
        assert rel(ref.bias_torques(Q, q, qd), v + g) <= TOL
        assert rel(ref.inverse_dynamics(Q, q, qd, qdd), M0 @ qdd + v + g) <= TOL
        assert cp.planar_crba(Q, q, M) == 0 and rel(M, M0) <= TOL
        assert cp.planar_rnea(Q, q, qd, qdd, 0, tau) == 0 and rel(tau, g) <= TOL
        assert cp.planar_rnea(Q, q, qd, qdd, F.QD, tau) == 0 and rel(tau, v + g) <= TOL
        assert cp.planar_rnea(Q, q, qd, qdd, QD_QDD, tau) == 0 and rel(tau, M0 @ qdd + v + g) <= TOL


# ------------------------------------------------------------------ status codes
def test_status_codes():
    robot = sd.load_urdf(general_planar_urdf(MIXED, seed=3))
    Q, n = planar_pack(robot.model), robot.dof
    q, qd, qdd, w = states(robot)
    tau, M = np.empty(n), np.empty((n, n))
    assert cp.planar_rnea(Q, q, qd, qdd, QD_QDD, tau) == 0
    for bad in (np.nan, np.inf, -np.inf):
        for j in (0, 1):                                # a revolute and a prismatic joint
            x = q.copy()
            x[j] = bad
            assert cp.planar_rnea(Q, x, qd, qdd, QD_QDD, tau) == 1
            assert cp.planar_rnea_wrench(Q, x, qd, qdd, w, QD_QDD, tau) == 1
            assert cp.planar_crba(Q, x, M) == 1
        x = qd.copy()
        x[2] = bad
        assert cp.planar_rnea(Q, q, x, qdd, QD_QDD, tau) == 1
        assert cp.planar_rnea(Q, q, x, qdd, F.QDD, tau) == 0        # qd not read
        assert cp.planar_rnea(Q, q, qd, x, QD_QDD, tau) == 1
        assert cp.planar_rnea(Q, q, qd, x, F.QD, tau) == 0          # qdd not read
        x = w.copy()
        x[4] = bad
        assert cp.planar_rnea_wrench(Q, q, qd, qdd, x, QD_QDD, tau) == 1
    # wrong lengths
    assert cp.planar_rnea(Q, q[:-1], qd, qdd, QD_QDD, tau) == 2
    assert cp.planar_rnea(Q, q, qd[:-1], qdd, QD_QDD, tau) == 2
    assert cp.planar_rnea(Q, q, qd, np.zeros(n + 1), QD_QDD, tau) == 2
    assert cp.planar_rnea(Q, q, qd, qdd, QD_QDD, np.empty(n - 1)) == 2
    assert cp.planar_rnea_wrench(Q, q, qd, qdd, w[:5], QD_QDD, tau) == 2
    assert cp.planar_crba(Q, q[:-1], M) == 2
    assert cp.planar_crba(Q, q, np.empty((n, n - 1))) == 2
    # a moving base is not modelled here: the caller's general path takes it
    if getattr(F, "BASE", 0):
        assert cp.planar_rnea(Q, q, qd, qdd, QD_QDD | F.BASE, tau) == 2
        assert cp.planar_rnea_wrench(Q, q, qd, qdd, w, QD_QDD | F.BASE, tau) == 2
        assert cp.planar_rnea_batch(Q, q[None], qd[None], qdd[None], w[None], QD_QDD | F.BASE,
                                    tau[None]) == 2
    # other argument types: a status, not an exception (as core.K's entry points)
    assert cp.planar_rnea(Q, list(q), qd, qdd, QD_QDD, tau) == OTHER_TYPES
    assert cp.planar_crba(Q, q.astype(np.float32), M) == OTHER_TYPES
    # batches
    N = 40
    Qb, QDb, QDDb, W = states(robot, batch=N)
    out, MM = np.empty((N, n)), np.empty((N, n, n))
    for arr, row in ((Qb, 33), (QDb, 5), (QDDb, 39)):
        saved = arr[row, 1]
        arr[row, 1] = np.nan
        assert cp.planar_rnea_batch(Q, Qb, QDb, QDDb, W, QD_QDD | F.WRENCH, out) == 1
        if arr is Qb:
            assert cp.planar_crba_batch(Q, Qb, MM) == 1
        arr[row, 1] = saved
    W[17, 0] = np.inf
    assert cp.planar_rnea_batch(Q, Qb, QDb, QDDb, W, QD_QDD | F.WRENCH, out) == 1
    assert cp.planar_rnea_batch(Q, Qb, QDb, QDDb, W, QD_QDD, out) == 0      # w not read
    assert cp.planar_rnea_batch(Q, Qb[:, :-1], QDb, QDDb, W, QD_QDD, out) == 2
    assert cp.planar_rnea_batch(Q, Qb, QDb[:-1], QDDb, W, QD_QDD, out) == 2
    assert cp.planar_rnea_batch(Q, Qb, QDb, QDDb, W[:, :5], QD_QDD | F.WRENCH, out) == 2
    assert cp.planar_rnea_batch(Q, Qb, QDb, QDDb, W, QD_QDD, out[:, :-1]) == 2
    assert cp.planar_crba_batch(Q, Qb[:3], MM) == 2
    assert cp.planar_crba_batch(Q, Qb, MM[:, :, :-1]) == 2
    assert cp.planar_crba_batch(Q, Qb, MM[:0]) == 2
