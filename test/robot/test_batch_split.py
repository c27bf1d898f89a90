"""The split of a large batch over the cores (robot/batches.py): one thread per core the
process may run on (its affinity mask, not a fixed cap), and the same bits whatever the
number of threads and chunks."""
import os

import numpy as np

import serial_dynamics as sd
from serial_dynamics.robot import batches


def test_one_thread_per_core_of_the_affinity_mask():
    assert batches.WORKERS == batches.cores() == len(os.sched_getaffinity(0))


def test_a_split_batch_is_the_bits_of_one_call(monkeypatch):
    robot = sd.default_robot()
    q, qd = robot.random_state(3, batch=5000)
    qdd = np.random.default_rng(4).uniform(-2.0, 2.0, q.shape)
    out = {}
    for workers in (1, 3, 7):            # 7: chunks of unequal length, the last one short
        monkeypatch.setattr(batches, "WORKERS", workers)
        monkeypatch.setattr(batches, "_pool", None)
        out[workers] = (robot.inverse_dynamics(q, qd, qdd), robot.mass_matrix(q),
                        robot.forward_dynamics(q, qd, qdd))
    for workers in (3, 7):
        for a, b in zip(out[1], out[workers]):
            assert a.tobytes() == b.tobytes()
