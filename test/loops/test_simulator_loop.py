"""The simulator node's loop without a node (``loops/simulator.py``), on the test's clock:
which steps publish joint_states and /clock (and their stamps), commands and their notes,
~/step and ~/reset answers, the thread's schedule, /diagnostics and the closing line."""
import threading

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.builtin.synthetic import satellite_urdf
from serial_dynamics.loops.simulator import SimulatorLoop
from serial_dynamics.model.errors import Rejected

pytest.importorskip("rclpy")    # the session is made from the node's parameter table
from serial_dynamics.ros import parameters  # noqa: E402
from serial_dynamics.ros.simulator_parameters import PARAMETERS, session  # noqa: E402

UR5E = sd.default_robot()
HOME = [0.0, -1.571, 1.571, -1.571, -1.571, 0.0]


class Clock:
    def __init__(self, step=0.0):
        self.t, self.step = 100.0, step

    def __call__(self):
        self.t += self.step
        return self.t


def loop(robot=UR5E, clock=None, **changes):
    p = {**parameters.defaults(PARAMETERS), "initial_positions": HOME, **changes}
    return SimulatorLoop(session(robot, p)[0], p, clock or Clock())


def test_joint_states_and_clock_fall_due_on_their_steps():
    sim = loop(sim_dt=0.002, publish_rate=50.0, clock_rate=100.0, publish_clock=True)
    assert (sim.publish_every, sim.clock_every, sim.dt_ns) == (10, 5, 2_000_000)
    ticks = [sim.step() for _ in range(20)]
    assert [k + 1 for k, t in enumerate(ticks) if t.publish] == [10, 20]
    assert [t.clock_ns for t in ticks if t.clock_ns] == [10_000_000, 20_000_000,
                                                          30_000_000, 40_000_000]
    assert sim.clock_ns(7) == 14_000_000
    quiet = loop(publish_clock=False)
    assert quiet.step().clock_ns is None and quiet.clock_ns(7) is None


def test_commands_clamp_with_a_note_and_refuse_targets_without_a_servo():
    sim = loop()
    assert sim.command(None, np.arange(6.0)) is None
    np.testing.assert_array_equal(sim.session.hold.tau, np.arange(6.0))
    note = sim.command(np.array([3, 1]), np.array([-40.0, 1.0]))
    assert note == ("effort command for wrist_1_joint: -40, beyond its limit 28; clamped to "
                    "the limit (logged once)")
    np.testing.assert_array_equal(sim.session.hold.tau, [0.0, 1.0, 2.0, -28.0, 4.0, 5.0])
    assert sim.command(np.array([2]), None, np.array([1.2]), None) is None   # effort: 0
    assert sim.session.hold.tau[2] == 0.0 and sim.report()[-1] == ("servoed joints", 1)
    rk4 = loop(integrator="rk4")
    with pytest.raises(Rejected, match="need an integrator with the implicit servo"):
        rk4.command(np.array([0]), None, None, np.array([0.1]))
    assert rk4.command(np.array([0]), np.array([2.0])) is None
    # the integrator says which methods have the servo (a floating base's: its own)
    sat = loop(sd.load_urdf(satellite_urdf(), gravity=(0, 0, 0)), initial_positions=None,
               floating_base=True, integrator="rk4")
    with pytest.raises(Rejected, match=r"implicit servo \('semi_implicit_euler',\); this"):
        sat.command(np.array([0]), None, np.array([0.1]), None)


def test_single_steps_only_while_paused_and_say_where_they_stopped():
    sim, published = loop(start_paused=False, step_count=5), []
    assert sim.single_steps(lambda force: sim.step(force).ok, lambda: published.append(1),
                            pytest.fail) == (
        False, "not paused: ~/step advances a paused simulation (~/pause true first)")
    sim = loop(start_paused=True, step_count=5, sim_dt=0.002)
    done, message = sim.single_steps(lambda force: sim.step(force).ok,
                                     lambda: published.append(sim.session.k), pytest.fail)
    assert (done, message, published) == (True, "advanced 5 step(s) to t = 0.010000 s", [5])
    # a kick to infinity: the third step diverges, the session pauses at the last good state
    wild = loop(start_paused=True, step_count=5, clamp_effort=False)
    wild.command(None, np.full(6, 1e12))
    done, message = wild.single_steps(lambda force: wild.step(force).ok, lambda: None,
                                      pytest.fail)
    assert not done and message.startswith("advanced ")
    assert message.endswith("; stopped: the step diverged (see the log)")
    assert wild.session.k < 5 and wild.report()[2] == ("divergence events", 1)


def test_a_step_that_raises_pauses_at_the_last_good_state_and_the_thread_goes_on():
    """Issue 52 item 0: an exception in a step (there, rclpy refusing a log call at a second
    severity) ended the simulation thread for good. Now the session pauses at the last good
    state with the reason, the thread goes on, and ~/reset with ~/pause false resume it."""
    stop, warned, errors, good, shown = threading.Event(), [], [], [], []
    sim = loop(real_time_factor=0.0)
    session, advance = sim.session, sim.session.integrator.step

    def broken(*args, **kwargs):
        raise RuntimeError("torque callable failed")

    def step():                      # as the node's: the session's step, then its log lines
        ok = sim.step().ok
        if session.k == 3 and not good:         # the next step fails inside the session
            session.integrator.step = broken
            good.append(session.q.copy())
        if session.k == 6 and len(shown) == 1:      # a good step whose log call raises
            raise ValueError("Logger severity cannot be changed between calls.")
        if session.k == 9:
            stop.set()
        return ok

    def publish():                   # paused: the state shown, then ~/pause false (after
        shown.append((session.k, session.q.copy()))     # ~/reset the second time)
        session.integrator.step = advance
        if len(shown) == 2:
            sim.reset()
        session.pause(False)
    watchdog = threading.Timer(20.0, stop.set)
    watchdog.start()
    sim.run(stop, step, publish, warned.append, errors.append)
    watchdog.cancel()
    assert [k for k, q in shown] == [3, 6] and session.k == 9 and not session.paused
    np.testing.assert_array_equal(shown[0][1], good[0])     # the state of step 3, kept
    assert errors == [
        "the step failed (RuntimeError: torque callable failed) -- paused at the last good "
        "state (t = 0.003 s); call ~/reset, then ~/pause false",
        "the step failed (ValueError: Logger severity cannot be changed between calls.) -- "
        "paused at the last good state (t = 0.006 s); call ~/reset, then ~/pause false"]
    assert warned == [] and sim.report()[2] == ("divergence events", 2)
    # ~/step on a paused session: the failed step stops it, the answer and the log say so
    session.pause(True)
    session.integrator.step = broken
    q = session.q
    done, message = sim.single_steps(lambda force: sim.step(force).ok, lambda: None,
                                     errors.append)
    assert not done and message.startswith("advanced 0 step(s)") and len(errors) == 3
    assert session.q is q and session.paused


def test_reset_answers_name_what_was_reset():
    sim = loop()
    sim.step()
    assert sim.reset() == "state reset to initial_positions, at rest"
    np.testing.assert_array_equal(sim.session.q, HOME)
    sat = loop(sd.load_urdf(satellite_urdf(), gravity=(0, 0, 0)), initial_positions=None,
               floating_base=True)
    assert sat.reset() == "state reset to initial_base_pose and initial_positions, at rest"
    assert sat.wrench_frame == ("odom", "world") and sat.frames == ("odom", "base_link")
    assert loop().wrench_frame == ("base_link", "base")


def test_the_report_real_time_factor_late_steps_and_the_push():
    clock = Clock()
    sim = loop(clock=clock, real_time_factor=1.0)
    for _ in range(10):
        sim.step()
    clock.t += 0.02                    # 10 ms simulated in 20 ms of wall time
    sim.session.push(np.array([1.0, 0.0, -2.5, 0.0, 0.125, 0.0]))
    assert sim.report() == [("real-time factor", "0.500", True), ("late steps", 0),
                            ("divergence events", 0), ("external wrench", "1 0 -2.5 0 0.125 0"),
                            ("servoed joints", 0)]
    for _ in range(10):
        sim.step()
    clock.t += 0.01                            # on time: not slow
    assert sim.report()[0] == ("real-time factor", "1.000", False)
    sim.session.pause(True)
    assert sim.report()[0] == ("real-time factor", "paused", False)


def test_the_thread_steps_on_schedule_publishes_while_paused_and_warns_once():
    # a clock 1 s later at every look: every step is more than MAX_LAG late
    clock, stop, warned = Clock(step=1.0), threading.Event(), []
    sim = loop(clock=clock, real_time_factor=1.0)

    def step():
        sim.step()
        if sim.session.k == 25:
            stop.set()
    sim.run(stop, step, lambda: None, warned.append)
    assert sim.session.k == 25 and sim.pacer.reanchors == 25 and sim.pacer.late_steps == 25
    assert warned == ["cannot keep up with real_time_factor 1.0: the simulation runs slower "
                      "(logged once)"]
    # the closing line: 25 ms simulated; since run began the clock was read 27 times (1 s
    # each): the anchor, 25 looks at the schedule, the summary
    assert sim.summary() == ("simulated 0.025 s in 27.000 s of wall time (real-time factor "
                             "0.001, pauses included)")
    # paused: publishes the state (once here: the publisher stops it), no step
    stop, published = threading.Event(), []
    paused = loop(start_paused=True, real_time_factor=0.0)
    paused.run(stop, lambda: pytest.fail("stepped while paused"),
               lambda: (published.append(paused.session.k), stop.set()), warned.append)
    assert published == [0] and paused.summary() is None


def test_lockstep_waits_for_the_controller_then_lets_go_after_its_timeout():
    # a clock 0.5 s later at every look, no pacing: the waits end only by their timeout
    clock, stop, warned, before = Clock(step=0.5), threading.Event(), [], []
    sim = loop(clock=clock, real_time_factor=0.0, lockstep=4, lockstep_timeout=2.0)
    assert sim.report()[2] == ("lockstep waits", 0)

    def step():
        before.append((sim.session.k, sim.lockstep_waits))
        sim.step()
        if sim.session.k in (3, 12):         # a command after steps 3 and 12, then silence
            sim.command(None, np.zeros(6))
        if sim.session.k == 20:
            stop.set()
    sim.run(stop, step, lambda: None, warned.append)
    # free before the first command; 4 steps past it (k = 7) it waits, times out after 2 s
    # (4 looks), runs free to the next command (k = 12) and waits again 4 steps later
    assert [k for k, waits in before] == list(range(20))
    assert [waits for k, waits in before] == [0] * 7 + [1] * 9 + [2] * 4
    assert warned == ["no command for 2 s of wall time: lockstep released until the next "
                      "command (logged once; command_timeout applies)"]
    assert sim.report()[2] == ("lockstep waits", 2)
    assert loop(lockstep=0).report()[2] == ("divergence events", 0)     # not listed


def test_lockstep_resumes_on_the_command_it_waited_for():
    # the clock stands still: only a command ends the wait (another thread, as rclpy's)
    stop, warned, ahead = threading.Event(), [], []
    sim = loop(real_time_factor=0.0, lockstep=2, lockstep_timeout=1.0)

    def step():
        sim.step()
        if sim.commanded_k is not None:
            ahead.append(sim.session.k - sim.commanded_k)
        if sim.session.k == 1:
            sim.command(None, np.zeros(6))
        if sim.session.k == 5:
            stop.set()

    def controller():          # answers the wait at k = 3, as a controller would
        while sim.lockstep_waits == 0 and not stop.is_set():
            stop.wait(0.001)
        held.append(sim.session.k)
        sim.command(None, np.ones(6))
    held = []
    thread = threading.Thread(target=controller)
    thread.start()
    watchdog = threading.Timer(20.0, stop.set)
    watchdog.start()
    sim.run(stop, step, lambda: None, warned.append)
    watchdog.cancel()
    thread.join()
    assert held == [3] and sim.session.k == 5 and warned == []
    # never more than lockstep steps past the last command: k = 2, 3, (the wait), 4, 5
    assert ahead == [1, 2, 1, 2]
    np.testing.assert_array_equal(sim.session.hold.tau, np.ones(6))


def test_stamped_lockstep_waits_for_the_answer_to_the_latest_state():
    # joint_states every 5 steps, /clock stamps: commands stamped with the state they answer
    clock, stop, warned, before = Clock(step=0.5), threading.Event(), [], []
    sim = loop(clock=clock, real_time_factor=0.0, lockstep=3, lockstep_timeout=2.0,
               publish_rate=200.0, publish_clock=True)
    assert sim.publish_every == 5

    def step():
        before.append((sim.session.k, sim.lockstep_waits))
        sim.step()
        if sim.session.k == 1:               # a stamped command (a stamp 0 is none)
            sim.command(None, np.zeros(6), stamp_ns=sim.clock_ns(1))
        if sim.session.k == 7:               # answers the state of step 5, two steps late
            sim.command(None, np.zeros(6), stamp_ns=sim.clock_ns(5))
        if sim.session.k == 18:
            stop.set()
    sim.run(stop, step, lambda: None, warned.append)
    # free to the first state shown (5); at 8, 3 past it, the answer to 5 is in: no wait
    # (an unstamped lockstep would wait there, 3 past the command); at 13, 3 past the state
    # of 10, whose answer never comes: the wait, its timeout, then free
    assert sim.published_k == 15 and sim.answered_k is None
    assert [waits for k, waits in before] == [0] * 13 + [1] * 5
    assert len(warned) == 1 and warned[0].startswith("no command for 2 s of wall time")
    # without publish_clock the stamps are wall time: not read, the unstamped rule holds
    wall = loop(lockstep=3, publish_clock=False)
    wall.command(None, np.zeros(6), stamp_ns=123_000_000)
    assert wall.answered_k is None and wall.commanded_k == 0
