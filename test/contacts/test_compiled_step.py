"""The ground's step in one compiled call (contacts/compiled_step.py) against the NumPy step
it replaces (contacts/stepping.py, the reference): from the same state and warm start, each
step's q1, v1, contact forces, active set and impulses agree to 1e-12 (relative) on every
kind of robot -- Solo12 standing on its feet under a PD (a floating tree), a box dropped
spinning onto its corners (a floating body: impacts, sliding, PGS sweeps), a box sliding
down a slope (PGS on the friction discs' edge), a UR5e pressing its tool onto a table with
the implicit servo (a fixed chain), Solo12 on a fixed base pressing its feet down (a fixed
tree); a whole run in one compiled call gives the steps' bits; the same calls give the same
bits; what the kernel does not cover takes the NumPy step (Coulomb friction, the NumPy
backend, a wrench); a run that diverges says so, naming the joint."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from contact_cases import FEET, SOLO
from pin_reference import erd
from test_ground_simulation import SIDE, box

import serial_dynamics as sd
from serial_dynamics.contacts.stepper import GroundStepper
from serial_dynamics.model.errors import SimulationError
from serial_dynamics.sim.servo import servo

DT = 1e-3
LEGS = np.array([0.0, 0.8, -1.6, 0.0, 0.8, -1.6, 0.0, -0.8, 1.6, 0.0, -0.8, 1.6])


def pair(robot, ground, contacts, dissipation=True):
    """Two steppers of one robot: the compiled step's and the NumPy reference's."""
    fast = GroundStepper(robot, ground, contacts, DT, dissipation)
    ref = GroundStepper(robot, ground, contacts, DT, dissipation)
    assert fast.fast is not None
    ref.fast = None                                   # the NumPy step, the reference
    return fast, ref


def rel(a, b):
    return np.max(np.abs(np.asarray(a, dtype=float) - b)) / max(1.0, np.max(np.abs(b)))


def agree(fast, ref, q, v, steps, torque, servo_of=None):
    """Steps along the reference's path, each from the same state and warm start; the worst
    relative differences (q1, v1, forces, impulses), how many steps had contacts pushing,
    and the PGS sweeps the reference made."""
    worst = np.zeros(4)
    pushing = 0
    for k in range(steps):
        tau = torque(q, v)
        s = None if servo_of is None else servo_of(q)
        fast.solver.lam[:] = ref.solver.lam
        q1, v1 = fast.step(q, v, tau, servo=s)
        r1, w1 = ref.step(q, v, tau, servo=s)
        lam_ref = ref.solver.lam
        worst = np.maximum(worst, [rel(q1, r1), rel(v1, w1), rel(fast.forces, ref.forces),
                                   rel(fast.solver.lam, lam_ref)])
        assert np.array_equal(fast.active, ref.active), k
        if s is not None:
            assert rel(fast.servo_torque, ref.servo_torque) < 1e-11
        pushing += bool(ref.active.any())
        q, v = r1, w1
    return worst, pushing, ref.solver.iterations


def test_solo12_standing_steps_agree():
    robot = sd.load_urdf(erd(SOLO), floating_base=True)
    q0 = np.r_[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, LEGS]
    q0[2] = -min(robot.forward_kinematics(q0, f)[2, 3] for f in FEET) + 0.003
    feet = [sd.Contact(f) for f in FEET]
    still = np.zeros(robot.nv)
    tau0, _ = robot.contact_inverse_dynamics(q0, still, still, feet, friction=1.0)
    fast, ref = pair(robot, sd.Ground(friction=1.0), feet)
    worst, pushing, _ = agree(fast, ref, q0, still, 300,
                              lambda q, v: tau0[6:] + 5.0 * (LEGS - q[7:]) - 0.1 * v[6:])
    assert pushing > 250                              # it lands, then stands
    assert np.all(worst < 1e-12), worst


@pytest.mark.parametrize("restitution, friction", [(0.0, 0.8), (0.5, 0.3)])
def test_a_box_dropped_spinning_steps_agree(restitution, friction):
    robot = box()
    q0 = np.r_[0.0, 0.0, 0.3, Rotation.from_rotvec([0.4, 0.3, 0.2]).as_quat()]
    fast, ref = pair(robot, sd.Ground(friction=friction, restitution=restitution),
                     robot.contact_points())
    worst, pushing, sweeps = agree(fast, ref, q0, np.r_[1.0, 0, 0, 0, 2, 5], 500,
                                   lambda q, v: np.zeros(0))
    assert pushing > 10 and sweeps > 50              # corners strike, slide: PGS sweeps
    assert np.all(worst < 1e-12), worst


def test_a_box_sliding_down_a_slope_steps_agree():
    robot = box(0.6)                                  # tan 0.6 > mu = 0.5: it slides
    fast, ref = pair(robot, sd.Ground(friction=0.5), robot.contact_points())
    worst, pushing, sweeps = agree(fast, ref, np.r_[0.0, 0.0, SIDE / 2, 0, 0, 0, 1.0],
                                   np.zeros(6), 300, lambda q, v: np.zeros(0))
    assert pushing == 300 and sweeps > 300            # the sliding solve is PGS's
    assert np.all(worst < 1e-12), worst


def test_a_fixed_arm_with_the_servo_on_a_table_steps_agree():
    """A fixed chain (UR5e) with viscous damping and the implicit servo, its tool pressed
    onto a table: the servo's (M + D) in the Delassus matrix too."""
    arm = sd.load_urdf(sd.builtin_path("ur5e"))
    q0 = np.array([0.0, -1.0, 1.2, -0.3, -1.57, 0.0])
    tip = sd.Contact("tool0", point=(0.0, 0.0, 0.05))
    X = arm.forward_kinematics(q0, "tool0")
    table = (X[:3, 3] + X[:3, :3] @ np.array(tip.point))[2] - 0.02
    damping = sd.Dissipation(tuple(arm.joint_names), np.full(6, 0.5), *np.zeros((3, 6)))
    fast, ref = pair(arm, sd.Ground(height=table, friction=0.5), [tip], damping)
    s = servo(np.full(6, 400.0), np.full(6, 5.0), q0 + np.array([0, 0.1, 0.1, 0, 0, 0]),
              np.zeros(6))
    g = arm.gravity_torques(q0)
    worst, pushing, _ = agree(fast, ref, q0, np.zeros(6), 300, lambda q, v: g,
                              lambda q: s)
    assert pushing > 100
    assert np.all(worst < 1e-12), worst


def test_a_fixed_tree_pressing_its_feet_steps_agree():
    """Solo12 on a fixed base (a tree), its feet 2 mm into a ground that pushes them out
    against a joint PD holding the legs."""
    robot = sd.load_urdf(erd(SOLO))
    height = max(robot.forward_kinematics(LEGS, f)[2, 3] for f in FEET) + 0.002
    fast, ref = pair(robot, sd.Ground(height=height, friction=0.7),
                     [sd.Contact(f) for f in FEET])
    worst, pushing, _ = agree(fast, ref, LEGS, np.zeros(12), 300,
                              lambda q, v: 3.0 * (LEGS - q) - 0.05 * v)
    assert pushing > 100
    assert np.all(worst < 1e-12), worst


def test_a_whole_run_is_the_steps_and_the_same_bits_twice():
    """sd.simulate with torques known in advance runs every step in one compiled call: the
    GroundStepper's compiled steps give its bits; two runs give the same bits; the NumPy
    loop agrees to 1e-9 over the run (each step's round-off carried along)."""
    robot = box()
    q0 = np.r_[0.0, 0.0, 0.3, Rotation.from_rotvec([0.4, 0.3, 0.2]).as_quat()]
    v0 = np.r_[1.0, 0, 0, 0, 2, 5]
    ground = sd.Ground(friction=0.8)
    kw = dict(ground=ground, method="semi_implicit_euler", dt=DT)
    res = sd.simulate(robot, 0.4, q0, v0, **kw)
    again = sd.simulate(robot, 0.4, q0, v0, **kw)
    assert "compiled loop" in res.stats.message
    for name in ("q", "qd", "qdd", "contact_forces", "contact_active", "energy"):
        np.testing.assert_array_equal(getattr(res, name), getattr(again, name))
    stepper = GroundStepper(robot, ground, robot.contact_points(), DT)
    q, v = q0, v0
    for k in range(400):
        q, v = stepper.step(q, v, np.zeros(0))
        np.testing.assert_array_equal(q, res.q[k + 1])
        np.testing.assert_array_equal(v, res.qd[k + 1])
        np.testing.assert_array_equal(stepper.forces, res.contact_forces[k])
    assert res.contact_active.any()


def test_what_the_kernel_does_not_cover_takes_the_numpy_step():
    robot = sd.load_urdf(erd(SOLO), floating_base=True)
    feet = [sd.Contact(f) for f in FEET]
    ground = sd.Ground()
    assert GroundStepper(robot, ground, feet).fast is not None
    coulomb = sd.Dissipation(tuple(robot.joint_names), np.zeros(12), np.full(12, 0.01),
                             *np.zeros((2, 12)))
    assert GroundStepper(robot, ground, feet, dissipation=coulomb).fast is None
    numpy_robot = sd.Robot(robot.model, backend="numpy")
    assert GroundStepper(numpy_robot, ground, feet).fast is None
    # a tip wrench: this step is NumPy's (the reference's numbers), the next compiled again
    fast, ref = pair(robot, ground, feet)
    q = np.r_[0.0, 0.0, 0.3, 0, 0, 0, 1.0, LEGS]
    w = np.array([0.0, 0.0, 5.0, 0.1, 0.0, 0.0])
    for a, b in zip(fast.step(q, np.zeros(18), np.zeros(12), wrench=w),
                    ref.step(q, np.zeros(18), np.zeros(12), wrench=w)):
        np.testing.assert_array_equal(a, b)


def test_a_diverging_run_names_the_joint():
    """A torque far beyond any motor's makes a joint's speed exceed its bound in the
    compiled run's first step: the NumPy step takes that step again and raises, naming the
    time and the joint."""
    robot = sd.load_urdf(erd(SOLO), floating_base=True)
    q0 = np.r_[0.0, 0.0, 0.5, 0, 0, 0, 1.0, LEGS]
    tau = np.zeros(12)
    tau[4] = 1e9
    with pytest.raises(SimulationError, match=r"diverged at t = 0.001 s: joint '(\w+)'") as e:
        sd.simulate(robot, 0.1, q0, torque=tau, ground=sd.Ground(),
                    contacts=[sd.Contact(f) for f in FEET], method="semi_implicit_euler",
                    dt=DT)
    assert e.value.joint in robot.joint_names and e.value.reason == "speed"
