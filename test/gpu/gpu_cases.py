"""The robots of the gpu tests: one of every kind the kernels take, and small batches."""
import numpy as np

import serial_dynamics as sd
from mimic_cases import mimic_chain

N = 4              # states a batch: the simulator runs one Python thread per state


def robots():
    """{name: Robot}: a plain 6R arm, armature, payload, planar, mimic (revolute and
    prismatic followers)."""
    ur5e = sd.builtin.ur5e_urdf()
    arm = sd.load_urdf(ur5e)
    return {
        "ur5e": arm,
        "armature": sd.load_urdf(ur5e, armature={n: 0.1 * (i + 1) for i, n in
                                                 enumerate(arm.joint_names)}),
        "payload": arm.with_payload(2.5, com=(0.01, 0.02, 0.05), inertia=(0.02, 0.025, 0.03,
                                                                            0.001, 0.0, 0.002)),
        "planar_3r": sd.load_urdf(sd.builtin.planar_3r_urdf()),
        "mimic": sd.load_urdf(mimic_chain()),
        "mimic_prismatic": sd.load_urdf(mimic_chain("prismatic")),
    }


def states(robot, seed=0, n=N):
    """(Q, QD, QDD) of n states within the limits."""
    q, qd = robot.random_state(seed, batch=n, speed=2.0)
    qdd = np.random.default_rng(seed + 1).uniform(-3.0, 3.0, q.shape)
    return q, qd, qdd
