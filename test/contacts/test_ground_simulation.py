"""Unilateral frictional contacts with the ground in simulation (sd.Ground, sd.simulate(...,
ground=, contacts=); contacts/stepping.py): a box dropped comes to rest on its bottom face
carrying its weight; on a slope (gravity tilted by alpha) it sticks for tan alpha < mu and
slides with g (sin alpha - mu cos alpha) for tan alpha > mu; Solo12 held by contact inverse
dynamics and a small PD stands still, and dropped from 5 cm lands on its four feet;
contacts never add energy; bad input is refused with its name."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from contact_cases import FEET, SOLO
from pin_reference import erd

import serial_dynamics as sd

G, MASS, SIDE = 9.81, 2.0, 0.2
# a 0.2 m cube of 2 kg, a free body (dof 0, nq 7, nv 6); its <collision> box gives the
# eight corners
BOX = f"""<robot name="box">
 <link name="base_link">
  <inertial><mass value="{MASS}"/>
   <inertia ixx="{MASS * SIDE**2 / 6}" iyy="{MASS * SIDE**2 / 6}" izz="{MASS * SIDE**2 / 6}"
            ixy="0" ixz="0" iyz="0"/></inertial>
  <collision><geometry><box size="{SIDE} {SIDE} {SIDE}"/></geometry></collision>
 </link>
</robot>"""
EULER = dict(method="semi_implicit_euler", dt=1e-3)


def box(alpha=0.0):
    """The box with gravity tilted by alpha about y (a slope down +x)."""
    return sd.load_urdf(BOX, floating_base=True,
                        gravity=(G * np.sin(alpha), 0.0, -G * np.cos(alpha)))


def box_at(z, rotvec=(0.0, 0.0, 0.0)):
    return np.r_[0.0, 0.0, z, Rotation.from_rotvec(rotvec).as_quat()]


def test_box_dropped_comes_to_rest_carrying_its_weight():
    robot = box()
    assert (robot.dof, robot.nq, robot.nv, robot.joint_names) == (0, 7, 6, [])
    res = sd.simulate(robot, 1.0, box_at(0.2), ground=sd.Ground(friction=0.8), **EULER)
    k = len(robot.contact_points())
    assert k == 8 and res.contact_forces.shape == (res.t.size, k, 3)
    assert res.contact_active.shape == (res.t.size, k) and res.contact_active.dtype == bool
    assert abs(res.q[-1, 2] - SIDE / 2) < 2e-3               # on its bottom face
    assert np.max(np.abs(res.qd[-1])) < 1e-6                 # at rest
    weight = MASS * G
    assert abs(res.contact_forces[-1, :, 2].sum() - weight) < 0.01 * weight
    bottom = [c.point[2] < 0 for c in robot.contact_points()]
    assert np.array_equal(res.contact_active[-1], bottom)    # the four bottom corners push
    assert not res.contact_active[0].any()                   # in the air at first
    assert res.q[:, 2].min() > SIDE / 2 - 1e-6               # no sinking in


@pytest.mark.parametrize("alpha", [0.3, 0.6])
def test_box_on_a_slope_sticks_or_slides_by_coulomb(alpha):
    mu = 0.5
    res = sd.simulate(box(alpha), 0.5, box_at(SIDE / 2), ground=sd.Ground(friction=mu),
                      **EULER)
    f = res.contact_forces
    tangential, normal = np.hypot(f[..., 0], f[..., 1]), f[..., 2]
    assert np.all(normal >= 0) and np.all(tangential <= mu * normal * (1 + 1e-9) + 1e-12)
    x = res.q[:, 0]
    if np.tan(alpha) < mu:                                   # sticks
        assert np.max(np.abs(x)) < 1e-9
    else:                                                    # slides: x = a t^2 / 2
        a = 2 * np.polyfit(res.t[50:], x[50:], 2)[0]
        expected = G * (np.sin(alpha) - mu * np.cos(alpha))
        assert abs(a - expected) < 0.02 * expected
    assert np.max(np.abs(res.q[:, 2] - SIDE / 2)) < 1e-6     # on the slope throughout


def test_a_ball_rests_on_its_radius():
    """A <collision> sphere: one contact at its centre, held its radius above the ground."""
    ball = sd.load_urdf(BOX.replace(f'<box size="{SIDE} {SIDE} {SIDE}"/>',
                                    '<sphere radius="0.07"/>'), floating_base=True)
    (c,) = ball.contact_points()
    assert c.radius == 0.07
    res = sd.simulate(ball, 0.3, box_at(0.12), ground=sd.Ground(height=0.01), output_dt=0.01,
                      **EULER)
    assert res.contact_forces.shape == (31, 1, 3) and res.contact_active.shape == (31, 1)
    assert res.contact_active[-1, 0] and abs(res.q[-1, 2] - 0.08) < 1e-9


def test_bounce_height_scales_with_restitution_squared():
    """Dropped from 0.1 m, the box bounces back to e^2 of it (Newton's restitution)."""
    e = 0.5
    res = sd.simulate(box(), 0.6, box_at(SIDE / 2 + 0.1), ground=sd.Ground(restitution=e),
                      **EULER)
    z = res.q[:, 2] - SIDE / 2
    after = np.flatnonzero(res.contact_active.any(axis=1))[0]
    assert abs(z[after:].max() - e**2 * 0.1) < 0.05 * e**2 * 0.1


def step_identity(robot, res, contacts):
    """max |M a + b - tau - delta - sum_k J_k^T f_k| over the samples, a = (v1 - v) / dt the
    velocity change of each step: the step's equation of motion with its contact forces."""
    worst, nb = 0.0, robot.nv - robot.dof
    for q, v, a, tau, delta, f in zip(res.q, res.qd, res.qdd, res.tau, res.delta,
                                      res.contact_forces):
        rhs = np.r_[np.zeros(nb), tau + delta]
        for c, fk in zip(contacts, f):
            X, J = robot.forward_kinematics(q, c.link), robot.jacobian(q, c.link)
            r = X[:3, :3] @ np.array(c.point)
            rhs += (J[:3] - np.cross(r, J[3:].T).T).T @ fk          # J_P = J_v - [r]x J_w
        lhs = robot.mass_matrix(q) @ a + robot.bias_torques(q, v)
        worst = max(worst, np.max(np.abs(lhs - rhs)) / max(1.0, np.max(np.abs(rhs))))
    return worst


def test_fixed_base_arm_falls_onto_a_table():
    """A UR5e with no torque falls until a point past its tool touches a table 5 cm below:
    the contact holds it there (no penetration), and every step meets M a + b = tau +
    delta + J_P^T f with the forces reported (a fixed base: the ground in base axes)."""
    arm = sd.load_urdf(sd.builtin_path("ur5e"))
    q0 = np.array([0.0, -1.0, 1.2, -0.3, -1.57, 0.0])
    tip = sd.Contact("tool0", point=(0.0, 0.0, 0.05))
    X = arm.forward_kinematics(q0, "tool0")
    height = (X[:3, 3] + X[:3, :3] @ np.array(tip.point))[2] - 0.05
    damping = sd.Dissipation(tuple(arm.joint_names), 50.0 * np.diag(arm.mass_matrix(q0)),
                             *np.zeros((3, 6)))
    res = sd.simulate(arm, 0.5, q0, ground=sd.Ground(height=height, friction=0.8),
                      contacts=[tip], dissipation=damping, **EULER)
    assert not res.contact_active[0, 0] and res.contact_active[-1, 0]
    z = [(arm.forward_kinematics(q, "tool0") @ np.r_[tip.point, 1.0])[2] for q in res.q]
    assert min(z) > height - 1e-6
    assert step_identity(arm, res, [tip]) < 1e-9


def test_a_tilted_ground_is_the_same_slope():
    """The slope again as a plane tilted by alpha (normal (sin a, 0, cos a), 0.2 m high at
    the origin) under vertical gravity, the box turned onto it: the same acceleration along
    the plane's downhill direction, and the box stays on the plane."""
    alpha, mu = 0.6, 0.5
    n, downhill = np.array([np.sin(alpha), 0, np.cos(alpha)]), np.array([np.cos(alpha), 0,
                                                                         -np.sin(alpha)])
    q0 = box_at(0.0, (0.0, alpha, 0.0))
    q0[:3] = (0.2 + SIDE / 2) * n
    res = sd.simulate(box(), 0.5, q0, ground=sd.Ground(height=0.2, normal=n, friction=mu),
                      **EULER)
    s = (res.q[:, :3] - q0[:3]) @ downhill
    a = 2 * np.polyfit(res.t[50:], s[50:], 2)[0]
    expected = G * (np.sin(alpha) - mu * np.cos(alpha))
    assert abs(a - expected) < 0.02 * expected
    assert np.max(np.abs(res.q[:, :3] @ n - 0.2 - SIDE / 2)) < 1e-6


def solo_standing():
    robot = sd.load_urdf(erd(SOLO), floating_base=True)
    qj = np.array([0, 0.8, -1.6, 0, 0.8, -1.6, 0, -0.8, 1.6, 0, -0.8, 1.6])
    q0 = np.r_[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, qj]
    q0[2] = -min(robot.forward_kinematics(q0, f)[2, 3] for f in FEET)   # feet on the ground
    feet = [sd.Contact(f) for f in FEET]
    still = np.zeros(robot.nv)
    tau, _ = robot.contact_inverse_dynamics(q0, still, still, feet, friction=1.0)

    def control(t, q, v):                                    # contact ID + a small PD
        return tau[6:] + 5.0 * (qj - q[7:]) - 0.1 * v[6:]
    return robot, q0, feet, control


def test_solo12_stands_where_it_stands():
    robot, q0, feet, control = solo_standing()
    res = sd.simulate(robot, 1.0, q0, torque=control, ground=sd.Ground(friction=1.0),
                      contacts=feet, **EULER)
    assert np.max(np.abs(res.q[:, :3] - q0[:3])) < 1e-3
    assert res.contact_active.all()
    assert step_identity(robot, res, feet) < 1e-9


def test_solo12_dropped_from_5_cm_comes_to_rest_on_its_four_feet():
    robot, q0, feet, control = solo_standing()
    q0[2] += 0.05
    res = sd.simulate(robot, 1.0, q0, torque=control, ground=sd.Ground(friction=1.0),
                      contacts=feet, **EULER)
    assert not res.contact_active[0].any() and res.contact_active[-1].all()
    assert np.max(np.abs(res.qd[-1])) < 1e-2
    weight = (robot.model.base_mass + robot.model.mass.sum()) * G
    assert abs(res.contact_forces[-1, :, 2].sum() - weight) < 0.01 * weight
    upright = Rotation.from_quat(res.q[-1, 3:7]).magnitude()
    assert upright < 1e-3 and res.q[-1, 2] > 0.15


@pytest.mark.parametrize("restitution, friction", [(0.0, 0.8), (0.5, 0.3)])
def test_contacts_create_no_energy(restitution, friction):
    """A spinning, tilted box thrown onto the ground: corners strike one after another,
    slide, stick, bounce; no input, so the energy may only fall."""
    res = sd.simulate(box(), 1.5, box_at(0.4, (0.4, 0.3, 0.2)), np.r_[1.0, 0, 0, 0, 2, 5],
                      ground=sd.Ground(friction=friction, restitution=restitution), **EULER)
    assert res.contact_active.any()
    assert np.max(res.energy - res.energy[0]) <= 1e-9 * res.energy[0]
    assert res.energy[-1] < 0.5 * res.energy[0]              # it came down and lost some
    if restitution == 0:                                     # the contacts' work, each step
        assert np.max(np.diff(res.work_external)) <= 1e-9 * res.energy[0]


def test_ground_and_contacts_bad_input():
    for kw in (dict(friction=-0.1), dict(friction=np.nan), dict(restitution=1.5),
               dict(normal=(0, 0, 0)), dict(normal=(0, 1)), dict(height="low")):
        with pytest.raises(ValueError, match="Ground " + next(iter(kw))):
            sd.Ground(**kw)
    assert sd.Ground(normal=(0, 0, 2)).normal == (0.0, 0.0, 1.0)        # normalised
    robot, q0 = box(), box_at(SIDE / 2)
    ground = sd.Ground()
    with pytest.raises(ValueError, match="no_such_link"):
        sd.simulate(robot, 0.01, q0, ground=ground, contacts=[sd.Contact("no_such_link")],
                    **EULER)
    with pytest.raises(ValueError, match="semi_implicit_euler"):
        sd.simulate(robot, 0.01, q0, ground=ground, method="RK45")
    with pytest.raises(ValueError, match="semi_implicit_euler"):
        sd.simulate(robot, 0.01, q0, ground=ground, method="rk4", dt=1e-3)
    with pytest.raises(ValueError, match="without a ground"):
        sd.simulate(robot, 0.01, q0, contacts=[sd.Contact("base_link")], **EULER)
    with pytest.raises(ValueError, match="frame"):
        sd.simulate(robot, 0.01, q0, ground=ground,
                    contacts=[sd.Contact("base_link", frame=True)], **EULER)
    with pytest.raises(ValueError, match="sd.Ground"):
        sd.simulate(robot, 0.01, q0, ground=0.0, **EULER)
    solo = sd.load_urdf(erd(SOLO), floating_base=True)        # meshes: no contact points
    with pytest.raises(ValueError, match="no <collision> sphere or box"):
        sd.simulate(solo, 0.01, ground=ground, **EULER)
