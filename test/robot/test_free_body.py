"""A free body: a URDF whose only joint is the floating root (a box, a satellite, a dropped
tool) loads with dof 0, nq 7, nv 6 and no joint, through the public facade. Every method of
a floating base holds on it, on both backends, one state and batches: against the
Newton-Euler equations of one rigid body in closed form, against Pinocchio's free-flyer
(JointModelFreeFlyer: q = [p, quaternion], v = [v_O, omega] in the body frame, as ours), and
simulated: no energy made or lost, the centre of mass falling at g."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pin_reference import pin

import serial_dynamics as sd

MASS = 2.0
C = np.array([0.1, -0.05, 0.2])              # the centre in the link frame (<inertial><origin>)
RPY = (0.3, 0.2, 0.1)                        # the principal axes, turned
I_PRINCIPAL = np.array([[0.3, 0.01, 0.02], [0.01, 0.4, -0.03], [0.02, -0.03, 0.5]])
SIZE = (0.2, 0.3, 0.4)
BOX = f"""<robot name="box">
 <link name="base_link">
  <inertial><origin xyz="{C[0]} {C[1]} {C[2]}" rpy="{RPY[0]} {RPY[1]} {RPY[2]}"/>
   <mass value="{MASS}"/>
   <inertia ixx="0.3" ixy="0.01" ixz="0.02" iyy="0.4" iyz="-0.03" izz="0.5"/></inertial>
  <collision><origin xyz="{C[0]} {C[1]} {C[2]}"/>
   <geometry><box size="{SIZE[0]} {SIZE[1]} {SIZE[2]}"/></geometry></collision>
 </link>
</robot>"""
R_I = Rotation.from_euler("xyz", RPY).as_matrix()         # URDF rpy: fixed x, y, z
I_C = R_I @ I_PRINCIPAL @ R_I.T                           # about the centre, link axes
GRAVITY = np.array([0.0, 0.0, -9.81])
BACKENDS = ("numba", "numpy")


def box(backend="numba", gravity=GRAVITY):
    robot = sd.load_urdf(BOX, floating_base=True, gravity=gravity)
    return robot if backend == "numba" else sd.Robot(robot.model, backend="numpy")


def skew(x):
    return np.array([[0.0, -x[2], x[1]], [x[2], 0.0, -x[0]], [-x[1], x[0], 0.0]])


def states(count=4, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q = np.r_[rng.uniform(-1, 1, 3), Rotation.random(random_state=rng).as_quat()]
        yield q, rng.uniform(-2, 2, 6), rng.uniform(-3, 3, 6)


def newton_euler(q, v, a, gravity=GRAVITY):
    """The base wrench [f; n] (base frame, about the link origin) that moves the box with
    v, a = dv/dt: Newton's and Euler's equations about the centre (Siciliano et al. 2009,
    Sec. 7.5), f = m (c'' - g) in world axes, n_C = I w' + w x I w, then n_O = n_C + c x f."""
    R = Rotation.from_quat(q[3:7]).as_matrix()
    v_o, w, dv_o, dw = v[:3], v[3:], a[:3], a[3:]
    acc_o = dv_o + np.cross(w, v_o)                   # R^T p'' (v_O in the turning frame)
    acc_c = acc_o + np.cross(dw, C) + np.cross(w, np.cross(w, C))
    f = R.T @ (MASS * (R @ acc_c - gravity))
    n_c = I_C @ dw + np.cross(w, I_C @ w)
    return np.r_[f, n_c + np.cross(C, f)]


def mass_matrix(q):
    """M of one body at its origin (v = [v_O; omega]): momentum m (v_O + w x c), I_O w + c x
    m v_O (Featherstone 2008, eq. 2.63, in [linear; angular] order)."""
    Cx = skew(C)
    return np.block([[MASS * np.eye(3), -MASS * Cx], [MASS * Cx, I_C - MASS * Cx @ Cx]])


def pin_box():
    model = pin.buildModelFromXML(BOX, pin.JointModelFreeFlyer())
    model.gravity.linear[:] = GRAVITY
    return model, model.createData()


def rel_err(a, b):
    return np.max(np.abs(np.asarray(a) - b)) / max(np.max(np.abs(b)), 1e-300)


def test_a_free_body_loads_with_no_joint():
    for robot in (box(), sd.load_urdf(BOX.replace('<robot name="box">', '''<robot name="box">
         <link name="world"/><joint name="root" type="floating"><parent link="world"/>
         <child link="base_link"/></joint>'''))):
        assert robot.is_floating and (robot.dof, robot.nq, robot.nv) == (0, 7, 6)
        assert robot.joint_names == [] and robot.lower.shape == (0,)
        assert robot.model.base_mass == MASS
        np.testing.assert_allclose(robot.model.base_com, C)
    with pytest.raises(sd.URDFError, match="no movable joint below base_link 'base_link'"):
        sd.load_urdf(BOX)                         # on a fixed base it has nothing to move


@pytest.mark.parametrize("backend", BACKENDS)
def test_the_dynamics_are_newton_and_euler(backend):
    robot = box(backend)
    for q, v, a in states():
        R = Rotation.from_quat(q[3:7]).as_matrix()
        tau = newton_euler(q, v, a)
        assert rel_err(robot.inverse_dynamics(q, v, a), tau) < 1e-13
        assert rel_err(robot.bias_torques(q, v), newton_euler(q, v, np.zeros(6))) < 1e-13
        assert rel_err(robot.gravity_torques(q), newton_euler(q, np.zeros(6), np.zeros(6))) < 1e-13
        M = mass_matrix(q)
        assert rel_err(robot.mass_matrix(q), M) < 1e-14
        assert rel_err(robot.coriolis_matrix(q, v) @ v + robot.gravity_torques(q),
                       robot.bias_torques(q, v)) < 1e-13
        assert rel_err(robot.regressor(q, v, a) @ robot.inertial_parameters(), tau) < 1e-13
        for method in ("aba", "cholesky"):
            assert rel_err(robot.forward_dynamics(q, v, tau, method=method), a) < 1e-12
            free = robot.forward_dynamics(q, v, np.zeros(0), method=method)   # no joint torque
            np.testing.assert_allclose(newton_euler(q, v, free), 0.0, rtol=0, atol=1e-12)
        assert robot.kinetic_energy(q, v) == pytest.approx(0.5 * v @ M @ v, rel=1e-14)
        assert robot.potential_energy(q) == pytest.approx(-MASS * GRAVITY @ (q[:3] + R @ C),
                                                          rel=1e-14)
        X = robot.forward_kinematics(q)
        np.testing.assert_allclose(X, np.block([[R, q[:3, None]], [np.zeros((1, 3)), 1.0]]),
                                   atol=1e-15)
        np.testing.assert_allclose(robot.jacobian(q, "base_link"),
                                   np.block([[R, np.zeros((3, 3))], [np.zeros((3, 3)), R]]),
                                   atol=1e-15)
        np.testing.assert_allclose(robot.center_of_mass(q), q[:3] + R @ C, atol=1e-15)
        w = np.array([3.0, -2.0, 5.0, 0.4, -0.7, 0.2])       # on the link origin, world axes
        J = robot.jacobian(q)
        assert rel_err(robot.inverse_dynamics(q, v, a, wrench=w), tau - J.T @ w) < 1e-13
        for method in ("aba", "cholesky"):
            assert rel_err(robot.forward_dynamics(q, v, tau - J.T @ w, wrench=w,
                                                  method=method), a) < 1e-12


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_free_body_falls_at_g_and_spins_as_euler_says(backend):
    """No wrench: the centre accelerates at g whatever the spin, and I w' = -w x I w."""
    robot = box(backend)
    for q, v, _ in states(seed=1):
        a = robot.forward_dynamics(q, v, np.zeros(0))
        R = Rotation.from_quat(q[3:7]).as_matrix()
        w, dw = v[3:], a[3:]
        acc_c = a[:3] + np.cross(w, v[:3]) + np.cross(dw, C) + np.cross(w, np.cross(w, C))
        np.testing.assert_allclose(R @ acc_c, GRAVITY, rtol=0, atol=1e-13)
        np.testing.assert_allclose(I_C @ dw, -np.cross(w, I_C @ w), rtol=0, atol=1e-13)


@pytest.mark.parametrize("backend", BACKENDS)
def test_pinocchios_free_flyer(backend):
    robot, (m, d) = box(backend), pin_box()
    assert m.nq == robot.nq and m.nv == robot.nv
    for q, v, a in states(seed=2):
        M = np.triu(pin.crba(m, d, q))
        assert rel_err(robot.mass_matrix(q), M + np.triu(M, 1).T) < 1e-13
        assert rel_err(robot.inverse_dynamics(q, v, a), pin.rnea(m, d, q, v, a)) < 1e-13
        tau = np.random.default_rng(3).normal(size=6)
        for method in ("aba", "cholesky"):
            assert rel_err(robot.forward_dynamics(q, v, tau, method=method),
                           pin.aba(m, d, q, v, tau)) < 1e-12
        assert rel_err(robot.gravity_torques(q), pin.computeGeneralizedGravity(m, d, q)) < 1e-13
        hg = pin.computeCentroidalMomentum(m, d, q, v)
        assert rel_err(robot.centroidal_momentum(q, v), np.r_[hg.linear, hg.angular]) < 1e-13
        assert rel_err(robot.center_of_mass(q), pin.centerOfMass(m, d, q)) < 1e-14
        np.testing.assert_allclose(robot.integrate(q, v, 0.01), pin.integrate(m, q, 0.01 * v),
                                   atol=1e-15)
        assert robot.kinetic_energy(q, v) == pytest.approx(pin.computeKineticEnergy(m, d, q, v),
                                                           rel=1e-13)


def central(f, robot, q, v, x, h=1e-6):
    """d f/d q along the tangent (integrate(q, e_k, +-h)) and d f/d v, central differences."""
    dq, dv = np.empty((6, 6)), np.empty((6, 6))
    for k, e in enumerate(np.eye(6)):
        up, down = robot.integrate(q, e, h), robot.integrate(q, e, -h)
        dq[:, k] = (f(up, v, x) - f(down, v, x)) / (2 * h)
        dv[:, k] = (f(q, v + h * e, x) - f(q, v - h * e, x)) / (2 * h)
    return dq, dv


@pytest.mark.parametrize("backend", BACKENDS)
def test_the_derivatives_are_those_of_the_dynamics(backend):
    robot = box(backend)
    w = np.array([3.0, -2.0, 5.0, 0.4, -0.7, 0.2])
    for q, v, a in states(count=2, seed=4):
        for wrench in (None, w) if backend == "numba" else (None,):   # NumPy's take none
            dq, dv = robot.inverse_dynamics_derivatives(q, v, a, wrench)
            nq, nv = central(lambda q, v, a: newton_euler(q, v, a) - (
                0.0 if wrench is None else robot.jacobian(q).T @ wrench), robot, q, v, a)
            assert rel_err(dq, nq) < 1e-7 and rel_err(dv, nv) < 1e-7
            tau = robot.inverse_dynamics(q, v, a, wrench)
            fq, fv, Minv = robot.forward_dynamics_derivatives(q, v, tau, wrench)
            FD = lambda q, v, t: robot.forward_dynamics(q, v, t, wrench)      # noqa: E731
            mq, mv = central(FD, robot, q, v, tau)
            assert rel_err(fq, mq) < 1e-6 and rel_err(fv, mv) < 1e-6
            assert rel_err(Minv, np.linalg.inv(mass_matrix(q))) < 1e-12
            for x, y in zip(robot.forward_dynamics_derivatives(q, v, np.zeros(0), wrench),
                            robot.forward_dynamics_derivatives(q, v, np.zeros(6), wrench)):
                np.testing.assert_array_equal(x, y)          # joint torques (none) or all six


@pytest.mark.parametrize("N", [37, 3000])
def test_batches_are_their_rows_and_the_reference(N):
    """More than one SIMD block with a short tail (37), and a batch split over the cores
    (3000): each row bitwise its single call, and the NumPy reference's to rounding."""
    robot, ref = box(), box("numpy")
    q, v = robot.random_state(5, batch=N, speed=2.0)
    rng = np.random.default_rng(6)
    a, tau, w = rng.normal(size=(N, 6)), rng.normal(size=(N, 6)), rng.normal(size=6)
    calls = {
        "inverse": lambda r, k: r.inverse_dynamics(q[k], v[k], a[k]),
        "inverse, wrench": lambda r, k: r.inverse_dynamics(q[k], v[k], a[k], wrench=w),
        "bias": lambda r, k: r.bias_torques(q[k], v[k]),
        "gravity": lambda r, k: r.gravity_torques(q[k]),
        "mass matrix": lambda r, k: r.mass_matrix(q[k]),
        "aba": lambda r, k: r.forward_dynamics(q[k], v[k], tau[k], w, method="aba"),
        "cholesky": lambda r, k: r.forward_dynamics(q[k], v[k], tau[k], w, method="cholesky"),
        "free": lambda r, k: r.forward_dynamics(q[k], v[k], np.zeros((N, 0))[k]),
        "kinetic": lambda r, k: r.kinetic_energy(q[k], v[k]),
        "potential": lambda r, k: r.potential_energy(q[k]),
        "jacobian": lambda r, k: r.jacobian(q[k]),
        "pose": lambda r, k: r.forward_kinematics(q[k]),
        "d inverse": lambda r, k: np.stack(r.inverse_dynamics_derivatives(q[k], v[k], a[k])),
        "d forward": lambda r, k: np.stack(r.forward_dynamics_derivatives(q[k], v[k], tau[k])),
    }
    rows = (0, 31, 32, N - 1)
    for name, call in calls.items():
        every = slice(None)
        got = call(robot, every)
        assert rel_err(got, call(ref, every)) < 1e-12, name
        for k in rows:
            assert np.array_equal(got[:, k] if name.startswith("d ") else got[k],
                                  call(robot, k)), (name, k)


@pytest.mark.parametrize("method", ["RK45", "DOP853", "Radau", "BDF", "LSODA",
                                    "semi_implicit_euler", "symplectic_euler", "rk4",
                                    "implicit_midpoint"])
def test_a_tumbling_box_keeps_its_energy_and_its_centre_falls_at_g(method):
    """Thrown and spinning about no principal axis: the centre's height is z0 + vz0 t - g t^2
    / 2, its momentum about the centre constant in the world, energy constant."""
    robot = box()
    q0 = np.r_[0.0, 0.0, 1.0, Rotation.from_rotvec([0.3, -0.2, 0.5]).as_quat()]
    v0 = np.array([0.5, -0.3, 2.0, 1.5, -2.0, 3.0])
    fixed = method in ("semi_implicit_euler", "symplectic_euler", "rk4", "implicit_midpoint")
    kw = dict(dt=1e-4) if fixed else dict(rtol=1e-10, atol=1e-12)
    res = sd.simulate(robot, 0.5, q0, v0, method=method, output_dt=0.01, **kw)
    assert res.q.shape[1] == 7 and res.qd.shape[1] == 6 and res.tau.shape[1] == 0
    c0, h0 = robot.center_of_mass(q0), robot.centroidal_momentum(q0, v0)
    dc0 = h0[:3] / MASS
    c = robot.center_of_mass(res.q)
    expected = c0 + np.outer(res.t, dc0) + 0.5 * np.outer(res.t ** 2, GRAVITY)
    first_order = method in ("semi_implicit_euler", "symplectic_euler")   # off by g dt t / 2
    tol = 9.81 * 1e-4 * 0.5 if first_order else 1e-7
    np.testing.assert_allclose(c, expected, rtol=0, atol=tol)
    h = robot.centroidal_momentum(res.q, res.qd)
    np.testing.assert_allclose(h[:, 3:], np.broadcast_to(h0[3:], h[:, 3:].shape), rtol=0,
                               atol=100 * tol)
    assert res.relative_energy_error() < (1e-3 if "euler" in method else 1e-6)


def test_a_free_body_without_spin_falls_at_g_step_by_step():
    """Turning with no spin and no torque, the velocity gains g dt each step exactly (to
    rounding) in every fixed-step method: the whole force is gravity's."""
    robot = box()
    q0 = np.r_[0.0, 0.0, 1.0, Rotation.from_rotvec([0.3, -0.2, 0.5]).as_quat()]
    R = Rotation.from_quat(q0[3:]).as_matrix()
    for method in ("semi_implicit_euler", "symplectic_euler", "rk4", "implicit_midpoint"):
        res = sd.simulate(robot, 0.1, q0, np.zeros(6), method=method, dt=1e-3)
        np.testing.assert_allclose(res.qd[:, :3], np.outer(res.t, R.T @ GRAVITY), rtol=0,
                                   atol=1e-12)
        np.testing.assert_allclose(res.qd[:, 3:], 0.0, atol=1e-12)
        np.testing.assert_allclose(res.q[:, 3:], np.broadcast_to(q0[3:], res.q[:, 3:].shape),
                                   atol=1e-12)


def test_a_dropped_box_lands_on_its_corners():
    """The <collision> box's eight corners, offset with the centre, stop it on the ground:
    it rests on a face with its whole weight on the ground."""
    robot = box()
    points = np.array([c.point for c in robot.contact_points()])
    corners = C + 0.5 * np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1)
                                  for z in (-1, 1)]) * SIZE
    assert sorted(map(tuple, points.round(12))) == sorted(map(tuple, corners.round(12)))
    q0 = np.r_[0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 1.0]
    res = sd.simulate(robot, 1.0, q0, ground=sd.Ground(friction=0.8),
                      method="semi_implicit_euler", dt=1e-3)
    assert np.max(np.abs(res.qd[-1])) < 1e-6
    assert abs(res.q[-1, 2] - (SIZE[2] / 2 - C[2])) < 2e-3          # on its bottom face
    assert abs(res.contact_forces[-1, :, 2].sum() + MASS * GRAVITY[2]) < 0.01 * MASS * 9.81


def test_the_simulator_session_publishes_only_the_base():
    """The simulator node's rclpy-free session (sim/session.py): no joint to publish, the
    base's pose and twist; semi-implicit Euler from rest: v = g t, z = z0 - g dt^2 k(k+1)/2."""
    from serial_dynamics.sim.session import Session
    pose = np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0])
    s = Session(box(), np.zeros(0), base_pose=pose, dt=1e-3, dissipation=False)
    for _ in range(10):
        assert s.step()[0]
    reading = s.joint_state()
    assert reading.position.shape == reading.velocity.shape == reading.effort.shape == (0,)
    p, twist = reading.base
    np.testing.assert_allclose(twist, np.r_[10e-3 * GRAVITY, np.zeros(3)], rtol=0, atol=1e-15)
    np.testing.assert_allclose(p, pose + np.r_[0, 0, 55e-6 * GRAVITY[2], np.zeros(4)], rtol=0,
                               atol=1e-15)
