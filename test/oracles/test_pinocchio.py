"""Agreement with Pinocchio on real robots (example-robot-data), relative error <= 1e-9.

Two parts:
- ``CHAINS``: hand-picked chains (arms, legs, torsos with prismatic joints, continuous
  joints, fixed links carrying mass, bases that are not the URDF root) checked on every
  quantity: inverse dynamics with and without a tip wrench, mass matrix, gravity torques,
  forward dynamics (ABA), C qd, tip pose and Jacobian.
- ``test_every_chain_of``: every URDF of example-robot-data, every chain from the root to
  the end of a movable branch. A chain either agrees with Pinocchio or is refused for a
  reason checked here independently (a non-physical body, a mimic joint on the chain, a
  joint that moves no mass); a chain refused for a body alone loads with
  ``repair_inertia=True`` and agrees with Pinocchio given the repaired inertias.

Gravity is tilted in the world (the URDF root frame, which is Pinocchio's world frame), so
that carrying it into a base frame that is not the root is checked as well.
"""
import glob
import os
import warnings

import numpy as np
import pytest

from pin_reference import ERD_ROOT, PinReference, erd, pin

import serial_dynamics as sd

G_WORLD = np.array([0.8, -1.3, -9.7])
RTOL = 1e-9
EPS = np.finfo(float).eps

# id: (URDF, base_link, tip_link, what the chain exercises)
CHAINS = {
    "panda": ("panda_description/urdf/panda.urdf", "panda_link0", "panda_link8",
              "fingers held and lumped"),
    "panda_finger": ("panda_description/urdf/panda_collision.urdf", "panda_link0",
                     "panda_leftfinger", "prismatic last joint; mimic finger held"),
    "ur5": ("ur_description/urdf/ur5_robot.urdf", "base_link", "tool0", "base below the root"),
    "ur3": ("ur_description/urdf/ur3_robot.urdf", None, "tool0", "fixed tail to tool0"),
    "ur10_limited": ("ur_description/urdf/ur10_joint_limited_robot.urdf", None, "ee_link", ""),
    "double_pendulum": ("double_pendulum_description/urdf/double_pendulum.urdf", None, None, ""),
    "double_pendulum_continuous": (
        "double_pendulum_description/urdf/double_pendulum_continuous.urdf", None, None,
        "continuous joints"),
    "z1": ("z1_description/urdf/z1.urdf", None, None, "fixed gripper stator carrying mass"),
    "xarm7": ("xarm_description/urdf/xarm7.urdf", None, None, ""),
    "so100": ("so_arm_description/urdf/so100.urdf", None, None, ""),
    "so101": ("so_arm_description/urdf/so101.urdf", None, None, ""),
    "kinova": ("kinova_description/robots/kinova.urdf", None, None, "continuous joints"),
    "talos_left_arm": ("talos_data/robots/talos_left_arm.urdf", None,
                       "gripper_left_motor_double_link", "fixed wrist links carrying mass"),
    "talos_right_leg": ("talos_data/robots/talos_reduced.urdf", "base_link", "right_sole_link",
                        "humanoid leg as a fixed-base chain"),
    "talos_torso_arm": ("talos_data/robots/talos_full_v2.urdf", "base_link",
                        "gripper_right_base_link", "torso + arm; head, other arm, legs held"),
    "baxter_right_arm": ("baxter_description/urdf/baxter.urdf", "right_arm_mount",
                         "right_gripper", "base yawed off the root; held prismatic fingers"),
    "tiago_torso_arm": ("tiago_description/robots/tiago_no_hand.urdf", "torso_fixed_link",
                        "wrist_ft_tool_link", "prismatic torso lift; fixed F/T links with mass"),
    "tiago_pro_torso_arm": ("tiago_pro_description/robots/tiago_pro.urdf", "base_footprint",
                            "gripper_left_outer_finger_left_link", "prismatic torso lift"),
    "pr2_right_arm": ("pr2_description/urdf/pr2.urdf", "r_shoulder_pan_link",
                      "r_gripper_tool_frame", "continuous rolls; fixed upper arm/forearm carry "
                      "6 kg and 2.6 kg; mimic gripper joints held"),
    "baxter_finger": ("baxter_description/urdf/baxter.urdf", "base", "r_gripper_l_finger_tip",
                      "7 revolute + prismatic finger"),
    "romeo_left_arm": ("romeo_description/urdf/romeo.urdf", "base_link", "l_gripper",
                       "trunk + arm; legs, head, fingers held"),
    "centauro_arm": ("centauro_description/urdf/centauro.urdf", "torso_2", "ball1_tip",
                     "base below a held torso joint; fixed ball carrying mass"),
    "b1_leg": ("b1_description/urdf/b1.urdf", "trunk", "RL_foot", "quadruped leg, rotors lumped"),
    "go1_leg": ("go1_description/urdf/go1.urdf", "trunk", "FR_foot", "quadruped leg, foot mass"),
    "a1_leg": ("a1_description/urdf/a1.urdf", None, "RL_foot", "quadruped leg"),
    "solo12_leg": ("solo_description/robots/solo12.urdf", None, "HR_FOOT", "quadruped leg"),
    "anymal_knee": ("anymal_b_simple_description/robots/anymal.urdf", "LF_HIP", "LF_FOOT",
                    "hip and knee below a held abduction joint; adapter and foot lumped"),
    "g1_arm": ("g1_description/urdf/g1_29dof_rev_1_0.urdf", None, "left_wrist_yaw_link",
               "waist + arm"),
    "human_right_arm": ("human_description/robots/human.urdf", None, "right_hand", "13 joints"),
    "hextilt_arm": ("hextilt_description/urdf/hextilt_flying_arm_5.urdf", None, None, ""),
    "finger_edu": ("finger_edu_description/robots/finger_edu.urdf", None, None, ""),
    "icub_left_arm": ("icub_description/robots/icub.urdf", None, "l_hand",
                      "torso + arm; the held head carries a round-off inertia (entries ~1e-35 "
                      "kg m^2, an eigenvalue < 0) that used to refuse every chain"),
    "icub_right_leg": ("icub_description/robots/icub_reduced.urdf", None, "r_foot",
                       "round-off inertias on the chain (r_hip_2, r_upper_leg, r_lower_leg, "
                       "r_ankle_1: entries 1e-21 .. 1e-18 kg m^2, indefinite)"),
    "anymal_c_leg": ("anymal_c_simple_description/urdf/anymal.urdf", None, "LF_SHANK",
                     "a joint and a link share a name: Pinocchio's full model as reference"),
}


BACKENDS = ("numba", "numpy")     # compiled kernels and the NumPy reference algorithms


def _load(path, base, tip, backend="numba"):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        return sd.Robot(sd.load_urdf(path, base, tip, gravity=G_WORLD).model, backend=backend)


def _load_repaired(path, tip):
    """(robot, the InertiaRepairWarning messages) of the chain to ``tip``, repair_inertia=True."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        robot = sd.load_urdf(path, None, tip, gravity=G_WORLD, repair_inertia=True)
    return robot, [str(w.message) for w in caught if w.category is sd.InertiaRepairWarning]


def reference(robot, path, full=False):
    ref = (FullPinReference if full else PinReference)(robot, path)
    ref.model.gravity.linear[:] = G_WORLD      # Pinocchio's world frame is the URDF root
    return ref


class FullPinReference(PinReference):
    """Pinocchio's full model of the URDF, with the joints we hold at neutral and their
    velocities and accelerations zero: for URDFs whose reduced model Pinocchio cannot build
    (anymal_c: a joint and a link share a name, and buildReducedModel refuses the frames).
    Inverse dynamics and the mass matrix are the rows (and columns) of our joints; forward
    dynamics solves the block of our joints, M_ours qdd = tau - b_ours, the held joints
    being locked (their accelerations zero)."""

    def __init__(self, robot, path):
        self.model = pin.buildModelFromUrdf(path)
        self.model.gravity.linear[:] = robot.gravity
        self.data = self.model.createData()
        self.robot = robot
        self.jid = [self.model.getJointId(n) for n in robot.joint_names]
        self.iv = np.array([self.model.idx_vs[j] for j in self.jid])

    def aba(self, q, qd, tau):
        b = self.rnea(q, qd, np.zeros_like(qd))
        return np.linalg.solve(self.mass_matrix(q), tau - b)


def rel_err(actual, expected):
    return np.max(np.abs(np.asarray(actual) - expected)) / max(np.max(np.abs(expected)), 1e-300)


def pin_frames(ref, robot, q):
    """(base placement, tip placement, last joint placement) in Pinocchio's world."""
    m, d = ref.model, ref.data
    pin.forwardKinematics(m, d, ref.q(q))
    pin.updateFramePlacements(m, d)
    oMb = d.oMf[m.getFrameId(robot.base_link, pin.BODY)]
    oMt = d.oMf[m.getFrameId(robot.tip_link, pin.BODY)]
    return oMb, oMt, d.oMi[ref.jid[-1]]


def pin_fext(ref, robot, q, w):
    """Our tip wrench (at the tip origin, base axes) as Pinocchio's per-joint external forces
    (at the last joint's origin, its local axes)."""
    oMb, oMt, oMj = pin_frames(ref, robot, q)
    f, m = oMb.rotation @ w[:3], oMb.rotation @ w[3:]            # world axes
    r = oMt.translation - oMj.translation
    R = oMj.rotation
    fext = [pin.Force.Zero() for _ in range(ref.model.njoints)]
    fext[ref.jid[-1]] = pin.Force(R.T @ f, R.T @ (m + np.cross(r, f)))
    return fext


def samples(robot, count=4, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q, qd = robot.random_state(rng, speed=2.0)
        w = rng.normal(size=6) * [30, 30, 30, 3, 3, 3]
        yield q, qd, rng.uniform(-3, 3, robot.dof), w


@pytest.fixture(scope="module", params=[(c, b) for c in sorted(CHAINS) for b in BACKENDS],
                ids=lambda p: f"{p[0]}-{p[1]}")
def chain(request):
    name, backend = request.param
    rel, base, tip, _ = CHAINS[name]
    path = erd(rel)
    robot = _load(path, base, tip, backend)
    try:
        return robot, reference(robot, path)
    except ValueError as exc:       # Pinocchio cannot reduce the model (anymal_c)
        assert "Several frames match" in str(exc), exc
        return robot, reference(robot, path, full=True)


def test_the_full_model_reference_agrees_with_the_reduced_one():
    """FullPinReference (held joints at neutral in Pinocchio's full model) is the reference
    of anymal_c's chains: on the panda, whose reduced model Pinocchio builds, both agree."""
    path = erd("panda_description/urdf/panda.urdf")
    robot = _load(path, None, "panda_link8")
    reduced, full = reference(robot, path), reference(robot, path, full=True)
    assert full.model.nv == robot.dof + 2 and reduced.model.nv == robot.dof   # fingers held
    for q, qd, qdd, w in samples(robot, count=3, seed=11):
        for a, b in ((reduced.rnea(q, qd, qdd, pin_fext(reduced, robot, q, w)),
                      full.rnea(q, qd, qdd, pin_fext(full, robot, q, w))),
                     (reduced.mass_matrix(q), full.mass_matrix(q)),
                     (reduced.aba(q, qd, qdd), full.aba(q, qd, qdd)),
                     (reduced.coriolis_times_qd(q, qd), full.coriolis_times_qd(q, qd))):
            assert rel_err(b, a) <= 1e-12


def test_anymal_c_needs_the_full_model():
    """anymal_c's chains load, and Pinocchio cannot reduce its model: they are checked
    against the full one (test_every_chain_of, CHAINS["anymal_c_leg"])."""
    path = erd("anymal_c_simple_description/urdf/anymal.urdf")
    robot = _load(path, None, "LF_SHANK")
    with pytest.raises(ValueError, match="Several frames match"):
        reference(robot, path)
    ref = reference(robot, path, full=True)
    for q, qd, qdd, _ in samples(robot, count=2, seed=12):
        assert rel_err(robot.inverse_dynamics(q, qd, qdd), ref.rnea(q, qd, qdd)) <= RTOL


# ---------------------------------------------------------------- hand-picked chains
def test_inverse_dynamics(chain):
    robot, ref = chain
    for q, qd, qdd, _ in samples(robot):
        assert rel_err(robot.inverse_dynamics(q, qd, qdd), ref.rnea(q, qd, qdd)) <= RTOL


def test_inverse_dynamics_with_tip_wrench(chain):
    robot, ref = chain
    for q, qd, qdd, w in samples(robot, seed=1):
        expected = ref.rnea(q, qd, qdd, pin_fext(ref, robot, q, w))
        assert rel_err(robot.inverse_dynamics(q, qd, qdd, wrench=w), expected) <= RTOL
        assert rel_err(ref.rnea(q, qd, qdd), expected) > 1e-6    # the wrench matters


def test_mass_matrix(chain):
    robot, ref = chain
    for q, *_ in samples(robot, seed=2):
        assert rel_err(robot.mass_matrix(q), ref.mass_matrix(q)) <= RTOL


def test_gravity_torques(chain):
    robot, ref = chain
    for q, *_ in samples(robot, seed=3):
        assert rel_err(robot.gravity_torques(q), ref.gravity(q)) <= RTOL


@pytest.mark.parametrize("method", ["cholesky", "qr", "aba"])
def test_forward_dynamics(chain, method):
    robot, ref = chain
    for q, qd, qdd, w in samples(robot, seed=4):
        tau = ref.rnea(q, qd, qdd)
        expected = ref.aba(q, qd, tau)
        assert rel_err(robot.forward_dynamics(q, qd, tau, method=method), expected) <= RTOL
        # with a tip wrench: the torques that produce qdd against it give qdd back
        tau_w = ref.rnea(q, qd, qdd, pin_fext(ref, robot, q, w))
        assert rel_err(robot.forward_dynamics(q, qd, tau_w, wrench=w, method=method),
                       expected) <= RTOL


def test_coriolis_times_qd(chain):
    robot, ref = chain
    for q, qd, *_ in samples(robot, seed=5):
        assert rel_err(robot.coriolis_matrix(q, qd) @ qd, ref.coriolis_times_qd(q, qd)) <= RTOL


def test_tip_pose_and_jacobian(chain):
    robot, ref = chain
    for q, *_ in samples(robot, count=2, seed=6):
        oMb, oMt, _ = pin_frames(ref, robot, q)
        bMt = oMb.actInv(oMt)
        X = robot.forward_kinematics(q)
        np.testing.assert_allclose(X[:3, :3], bMt.rotation, atol=1e-12)
        np.testing.assert_allclose(X[:3, 3], bMt.translation, atol=1e-12)
        fid = ref.model.getFrameId(robot.tip_link, pin.BODY)
        Jw = pin.computeFrameJacobian(ref.model, ref.data, ref.q(q), fid, pin.LOCAL_WORLD_ALIGNED)
        Rb = oMb.rotation
        Jb = np.vstack([Rb.T @ Jw[:3], Rb.T @ Jw[3:]])[:, ref.iv]   # base axes, our joints
        assert rel_err(robot.jacobian(q), Jb) <= 1e-12


def test_gravity_is_carried_into_the_base_frame(chain):
    robot, ref = chain
    oMb = pin_frames(ref, robot, np.zeros(robot.dof))[0]
    np.testing.assert_allclose(robot.gravity, oMb.rotation.T @ G_WORLD, atol=1e-12)


def test_panda_warns_about_the_held_fingers():
    with pytest.warns(sd.HeldJointsWarning, match="panda_finger_joint1") as record:
        robot = sd.load_urdf(erd("panda_description/urdf/panda.urdf"), "panda_link0", "panda_link8")
    message = str(record[0].message)
    assert "panda_finger_joint2" in message
    assert robot.dof == 7 and robot.joint_names[-1] == "panda_joint7"
    assert not any("finger" in j for j in robot.joint_names)


def test_hand_picked_chains_cover_the_joint_kinds():
    kinds = set()
    for rel, base, tip, _ in CHAINS.values():
        path = os.path.join(ERD_ROOT, rel)
        if os.path.isfile(path):
            kinds |= set(_load(path, base, tip).joint_types)
    assert kinds >= {"revolute", "continuous", "prismatic"}
    assert len(CHAINS) >= 15


# ---------------------------------------------------------------- every chain of every URDF
# URDFs of example-robot-data whose every root-to-branch-end chain is refused, and why.
# (Links fixed to the base are not part of the model and are not checked, so a bad antenna
# on a mobile base does not refuse the arm.) Each refusal names a mimic joint on the chain, a
# joint that moves no mass, or a body whose inertia no rigid body has: judged on the body
# the dynamics uses, its links lumped (issue 52), and re-checked independently on the body
# Pinocchio lumps (_inertia_is_unphysical); such a chain loads with repair_inertia=True
# (test_every_chain_of checks it against Pinocchio with the repaired inertias).
KNOWN_INVALID = {
    "ur_description/urdf/ur3.urdf": "an empty <robot> without a name (Pinocchio refuses it too)",
}
# Loaded since the bodies are judged lumped (issue 52), formerly listed here for a link alone:
# the Allegro hands (link_15.0, link_7.0), HyQ's feet (1e-6 in every entry), the PR2's
# 'sensor_mount_link', Alex's psyonic hand bases. With repair_inertia=True: the chains of
# romeo_small and romeo_laas_small through an arm body that is still no rigid body's.

URDFS = sorted(os.path.relpath(p, ERD_ROOT)
               for p in glob.glob(os.path.join(ERD_ROOT, "**", "*.urdf"), recursive=True))


def _tree(path):
    import yourdfpy
    urdf = yourdfpy.URDF.load(path, build_scene_graph=False, load_meshes=False,
                              build_collision_scene_graph=False, load_collision_meshes=False)
    return urdf.robot


def _branch_ends(robot_xml):
    """Children of movable joints with no movable joint below them."""
    children = {}
    for j in robot_xml.joints:
        children.setdefault(j.parent, []).append(j)

    def movable_below(link):
        return any(j.type != "fixed" or movable_below(j.child) for j in children.get(link, []))

    return sorted(j.child for j in robot_xml.joints
                  if j.type != "fixed" and not movable_below(j.child))


def _subtree_mass(xml, link):
    """Total <inertial> mass of ``link`` and every link below it."""
    below = {j.parent: [] for j in xml.joints}
    for j in xml.joints:
        below[j.parent].append(j.child)
    mass = {lk.name: (lk.inertial.mass or 0.0) if lk.inertial else 0.0 for lk in xml.links}
    total, stack = 0.0, [link]
    while stack:
        name = stack.pop()
        total += mass[name]
        stack += below.get(name, [])
    return total


# What no rigid body has, argued here from physics rather than from the library's formula
# (which this test is to question, not repeat): along the principal axes of the inertia
# about the center of mass, with principal moments I_k, the second moments of mass are
# s_x = int x^2 dm = (I_y + I_z - I_x) / 2, ... A body of non-negative mass density has every
# s_k >= 0 (and then every I_k = s_j + s_l >= 0: positive semi-definite, and the triangle
# inequality). Unphysical: some s_k < -(m d^2 + e), d = 1 micrometre (no part of a robot is
# thinner, so shortfalls of that size are round-off: iCub's 1e-20 .. 1e-35 kg m^2 inertias
# are point masses) and e = 1e-6 max|I| (the rounding of values written with six digits).
# Every refusal in example-robot-data falls short by 1e-3 .. 1.5 of max|I| (measured).
THINNEST = 1e-6       # m


def _inertia_is_unphysical(link):
    return _unphysical(link.inertial.mass, link.inertial.inertia)


def _unphysical(mass, inertia):
    moments = np.linalg.eigvalsh(inertia)
    second = moments.sum() / 2 - moments           # s_k, along the principal axes
    return second.min() < -(mass * THINNEST**2 + 1e-6 * np.max(np.abs(inertia)))


def test_the_physical_check_of_this_file():
    """The independent check above, on bodies whose answer is known."""
    class Link:                                     # a yourdfpy link, as far as it is read
        def __init__(self, m, I):
            self.inertial = type("Inertial", (), {"mass": m, "inertia": np.asarray(I, float)})

    rod = np.diag([0.0, 1.0, 1.0]) / 12              # a thin rod: I1 = 0, I2 + I1 = I3
    assert not _inertia_is_unphysical(Link(1.0, rod))
    assert not _inertia_is_unphysical(Link(1.0, np.zeros((3, 3))))              # a point mass
    assert not _inertia_is_unphysical(Link(0.5, [[1e-20, 0, 0], [0, -1e-20, 0], [0, 0, 0]]))
    assert _inertia_is_unphysical(Link(1.0, np.diag([0.01, 0.01, 0.05])))       # triangle
    assert _inertia_is_unphysical(Link(1.0, np.diag([-0.01, 0.02, 0.02])))      # negative
    assert _inertia_is_unphysical(Link(1e-6, np.full((3, 3), 1e-6)))            # hyq's feet


def _check_mimic_reduction(robot):
    """A chain with mimic joints is the reduced system G^T (.) G of the chain with every
    joint free (q_all = G q + o): check that, and return the chain with every joint free
    (test_mimic.py checks the reduction against Pinocchio's own mimic joints)."""
    import dataclasses
    n = robot.model.dof
    free = sd.Robot(dataclasses.replace(robot.model, mimic_leader=np.full(n, -1)))
    G, o = robot.model.mimic_matrix
    for q, qd, qdd, w in samples(robot, count=2, seed=3):
        qa, qda, qdda = G @ q + o, G @ qd, G @ qdd
        assert rel_err(robot.inverse_dynamics(q, qd, qdd, w),
                       G.T @ free.inverse_dynamics(qa, qda, qdda, w)) <= 1e-14
        assert rel_err(robot.mass_matrix(q), G.T @ free.mass_matrix(qa) @ G) <= 1e-14
    return free


def _repaired_reference(robot, path, said, refused):
    """Pinocchio's model of a chain loaded with repair_inertia=True, its bodies' inertias
    ours. Checked first: Pinocchio lumps the same mass and center of mass into every body and
    the same inertia into every body we kept; the bodies we repaired (one warning each, the
    first the one the refusal named) are those whose inertia, as Pinocchio lumps it, is no
    rigid body's; each is now physical, about the same principal axes, its second moments
    of mass along them Pinocchio's where those are >= 0 and 0 where they are not."""
    ref = reference(robot, path)
    m = robot.model
    bad = []
    for i, j in enumerate(ref.jid):
        Y = ref.model.inertias[j]
        assert abs(m.mass[i] - Y.mass) <= RTOL * max(Y.mass, 1e-300)
        assert rel_err(m.com[i], Y.lever) <= RTOL or np.allclose(m.com[i], Y.lever, atol=1e-15)
        if not _unphysical(Y.mass, Y.inertia):
            assert rel_err(m.inertia[i], Y.inertia) <= RTOL
            continue
        bad.append(m.link_names[i])
        assert not _unphysical(m.mass[i], m.inertia[i])
        s, V = np.linalg.eigh(np.trace(Y.inertia) / 2 * np.eye(3) - Y.inertia)
        ours = V.T @ (np.trace(m.inertia[i]) / 2 * np.eye(3) - m.inertia[i]) @ V
        np.testing.assert_allclose(ours, np.diag(np.maximum(s, 0)), atol=1e-12 * np.abs(s).max())
        ref.model.inertias[j] = pin.Inertia(m.mass[i], m.com[i], m.inertia[i])
    assert bad and bad[0] == refused and len(said) == len(bad), (bad, said)
    assert all(text.startswith(f"link {b!r}") for b, text in zip(bad, said)), said
    ref.data = ref.model.createData()
    return ref


def _refused_for_an_inertia(msg, xml, joints):
    """True for a refusal of a body whose inertia no rigid body has (it names the option);
    else check the reason given: a mimic joint on the chain, or a joint that moves no mass."""
    name = msg.split("'")[1]      # every message starts with "link 'x'" / "joint 'x'"
    if msg.startswith("joint") and "mimics" in msg:
        assert joints[name].mimic is not None and joints[name].type != "fixed", msg
    elif msg.startswith("joint") and "moves no mass" in msg:   # a massless subtree
        assert _subtree_mass(xml, joints[name].child) == 0.0, msg
    else:
        assert msg.startswith("link") and "repair_inertia=True" in msg, msg
        return True
    return False


@pytest.mark.parametrize("rel", URDFS)
def test_every_chain_of(rel):
    path = erd(rel)
    try:
        xml = _tree(path)
    except Exception:
        with pytest.raises(sd.URDFError, match="cannot parse"):
            sd.load_urdf(path)
        pytest.skip(f"{rel}: {KNOWN_INVALID[rel]}")
    joints = {joint.name: joint for joint in xml.joints}
    ends = _branch_ends(xml)
    if not ends:
        with pytest.raises(sd.URDFError, match="no movable joint"):
            sd.load_urdf(path)
        pytest.skip(f"{rel} has no movable joint")
    checked = 0
    for tip in ends:
        repaired = None
        try:
            robot = _load(path, None, tip)
        except (sd.URDFError, sd.ModelError) as exc:
            if not _refused_for_an_inertia(str(exc), xml, joints):
                continue
            try:                          # a body no rigid body is: repaired, checked below
                robot, said = _load_repaired(path, tip)
            except (sd.URDFError, sd.ModelError) as again:    # and refused for more
                assert not _refused_for_an_inertia(str(again), xml, joints), again
                continue
            repaired = (said, str(exc).split("'")[1])
        if robot.dof != robot.model.dof:     # mimic joints on the chain: the reduction
            robot = _check_mimic_reduction(robot)    # is checked; then the chain, all joints free
        try:
            ref = (_repaired_reference(robot, path, *repaired) if repaired
                   else reference(robot, path))
        except ValueError as exc:   # Pinocchio cannot reduce a model whose joint and link
            assert "Several frames match" in str(exc), exc   # share a name (anymal_c, b1-z1):
            ref = reference(robot, path, full=True)          # its full model, others held
        for r in (robot, sd.Robot(robot.model, backend="numpy")):
            for q, qd, qdd, w in samples(robot, count=2, seed=7):
                tau = ref.rnea(q, qd, qdd, pin_fext(ref, robot, q, w))
                assert rel_err(r.inverse_dynamics(q, qd, qdd, wrench=w), tau) <= RTOL, tip
                assert rel_err(r.mass_matrix(q), ref.mass_matrix(q)) <= RTOL, tip
                # forward dynamics is defined to cond(M) eps at best: iCub's neck carries
                # point masses on its axes (cond(M) up to 2e9 on the chain to 'head')
                fd_tol = max(RTOL, 100 * np.linalg.cond(ref.mass_matrix(q)) * EPS)
                assert rel_err(r.forward_dynamics(q, qd, tau, wrench=w),
                               ref.aba(q, qd, ref.rnea(q, qd, qdd))) <= fd_tol, tip
        checked += 1
    if checked == 0:
        pytest.skip(f"{rel}: no chain loads: {KNOWN_INVALID[rel]}")
    assert rel not in KNOWN_INVALID, f"{rel} now loads: update KNOWN_INVALID"
