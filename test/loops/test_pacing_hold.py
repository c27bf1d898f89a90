"""The simulator's wall-clock pacing (``loops/pacing.py``) and command hold
(``sim/command_hold.py``): plain Python, tested without rclpy and without waiting (the
pacer reads a clock given here)."""
import numpy as np

from serial_dynamics.loops.pacing import Pacer
from serial_dynamics.sim.command_hold import CommandHold


class Clock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


def test_the_pacer_schedules_catches_up_and_gives_up_when_too_late():
    clock = Clock()
    p = Pacer(dt=0.001, real_time_factor=0.5, max_lag=0.1, clock=clock)   # a step per 2 ms
    assert p.wait(0) == 0.0                         # due now
    assert np.isclose(p.wait(1), 0.002)             # due in 2 ms
    clock.t += 0.0015
    assert np.isclose(p.wait(1), 0.0005)
    clock.t += 0.011                                # 12.5 ms in: steps 1..6 are due
    assert [p.wait(k) for k in (1, 2, 3, 4, 5, 6)] == [0.0] * 6
    assert p.late_steps == 5                        # more than a period late: 1 to 5
    assert np.isclose(p.wait(7), 0.0015)            # back on schedule
    clock.t += 1.0                                  # a stall: 1 s behind
    assert p.wait(7) == 0.0 and p.reanchors == 1    # re-anchored at now: no burst ...
    assert np.isclose(p.wait(8), 0.002)             # ... the next step a period later
    assert p.achieved(8, 0.001) == (8 * 0.001) / (clock.t - 100.0)
    assert Pacer(0.001, 0.0, clock=clock).wait(10 ** 6) == 0.0     # 0: as fast as possible


def test_the_hold_keeps_commands_until_replaced_or_timed_out():
    h = CommandHold(3, kp=np.full(3, 100.0), kd=np.full(3, 10.0), timeout_steps=5,
                    wrench_timeout_steps=3)
    assert np.all(h.tau == 0) and h.servo is None and h.expire(100) == []   # nothing to time out
    h.command(10, np.array([0, 2]), np.array([1.0, 2.0]))
    h.command(11, np.array([1]), np.array([5.0]), position=np.array([0.3]))
    assert h.tau.tolist() == [1.0, 5.0, 2.0]
    assert np.isnan(h.q_target[[0, 2]]).all() and h.q_target[1] == 0.3 and h.servo is not None
    h.command(12, np.array([1]), np.array([4.0]))  # targets of joint 1 gone: no servo
    assert h.servo is None and h.tau.tolist() == [1.0, 4.0, 2.0]
    assert h.expire(17) == [] and h.tau.tolist() == [1.0, 4.0, 2.0]      # 5 steps: held
    assert h.expire(18) == ["command"] and np.all(h.tau == 0)              # 6: timed out
    assert h.expire(30) == []                                               # once
    h.push(20, np.arange(6.0))
    assert h.expire(22) == [] and h.wrench is not None
    assert h.expire(23) == ["wrench"] and h.wrench is None
    forever = CommandHold(1, np.ones(1), np.ones(1))                        # 0: hold forever
    forever.command(0, np.array([0]), np.array([7.0]))
    forever.push(0, np.ones(6))
    assert forever.expire(10 ** 9) == [] and forever.tau[0] == 7.0 and forever.wrench is not None
