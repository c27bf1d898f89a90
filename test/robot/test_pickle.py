"""A Robot travels as its model data: pickled here, unpickled in another process (a real
subprocess, which loads the kernels from its own numba cache), it computes the same bits.

Every kind: the UR5e, with a payload, with armature, a chain with mimic joints, a planar
chain, the UR5e on a free-floating base. The other process answers inverse dynamics, the
mass matrix, forward dynamics, gravity torques and the payload it carries; the bytes must
equal this process's.
"""
import pickle
import subprocess
import sys

import numpy as np

import serial_dynamics as sd
from test_output_hashes import MIMIC

# the other process: read pickled (robot, states) pairs, answer the results' bytes
CHILD = """
import pickle, sys
cases = pickle.load(sys.stdin.buffer)
out = {}
for name, (robot, q, qd) in cases.items():
    out[name] = (type(robot).__name__, repr(robot.payload), robot.inverse_dynamics(q, qd, 0.5 * qd).tobytes(),
                 robot.mass_matrix(q).tobytes(), robot.forward_dynamics(q, qd, qd).tobytes(),
                 robot.gravity_torques(q).tobytes())
pickle.dump(out, sys.stdout.buffer)
"""


def robots():
    ur5e = sd.default_robot()
    return {
        "ur5e": ur5e,
        "payload": ur5e.with_payload(1.7, (0.01, -0.02, 0.05), (0.01, 0.02, 0.015, 0.001, 0.0, 0.0)),
        "armature": sd.default_robot(armature={j: 0.05 * (k + 1)
                                               for k, j in enumerate(ur5e.joint_names)}),
        "mimic": sd.load_urdf(MIMIC),
        "planar": sd.builtin_robot("planar_3r"),
        "floating": sd.load_urdf(sd.builtin_path("ur5e"), floating_base=True),
    }


def test_every_kind_unpickles_in_another_process_to_the_same_bits():
    cases = {}
    expected = {}
    for k, (name, robot) in enumerate(robots().items()):
        q, qd = robot.random_state(k)
        cases[name] = (robot, q, qd)
        expected[name] = (type(robot).__name__, repr(robot.payload),
                          robot.inverse_dynamics(q, qd, 0.5 * qd).tobytes(),
                          robot.mass_matrix(q).tobytes(),
                          robot.forward_dynamics(q, qd, qd).tobytes(),
                          robot.gravity_torques(q).tobytes())
    data = pickle.dumps(cases)
    out = subprocess.run([sys.executable, "-c", CHILD], input=data, capture_output=True,
                         check=True, timeout=120).stdout
    got = pickle.loads(out)
    for name in expected:
        assert got[name] == expected[name], name


def test_a_robot_pickles_as_model_data_not_kernels():
    for name, robot in robots().items():
        data = pickle.dumps(robot)
        assert len(data) < 20_000, (name, len(data))     # the model's arrays: ~6-10 kB
        assert b"numba." not in data and b"Dispatcher" not in data and b"_P\x94" not in data
        again = pickle.loads(data)
        assert type(again) is type(robot) and again.joint_names == robot.joint_names
        assert not again.model.mass.flags.writeable                  # immutable as built
        assert np.array_equal(again.dissipation.viscous, robot.dissipation.viscous)


def test_changed_dissipation_and_payload_travel():
    robot = sd.default_robot().with_payload(2.0, (0.0, 0.0, 0.1))
    robot.dissipation = robot.dissipation.override(viscous=0.3, coulomb={"elbow_joint": 1.5})
    again = pickle.loads(pickle.dumps(robot))
    assert repr(again.payload) == repr(robot.payload)
    assert again.dissipation.coulomb.tobytes() == robot.dissipation.coulomb.tobytes()
    # without_payload after the trip: the robot as loaded, bit for bit
    q, qd = robot.random_state(3)
    assert (again.without_payload().inverse_dynamics(q, qd, q).tobytes()
            == sd.default_robot().inverse_dynamics(q, qd, q).tobytes())
