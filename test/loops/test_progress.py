"""loops/progress.Heartbeat: a node's start-up says how long a slow step has taken (a cold
numba cache: minutes), and nothing when the step is quick (the cache warm)."""
import threading

import pytest

from serial_dynamics.loops.progress import Heartbeat


def test_a_slow_step_is_reported_while_it_runs_and_when_it_ends():
    lines, seen_inside = [], threading.Event()

    def say(text):
        lines.append(text)
        seen_inside.set()

    with Heartbeat(say, "compiling the dynamics kernels", after=0.02, every=0.05):
        assert seen_inside.wait(10.0)                      # said while the block still runs
    assert lines[0].startswith("compiling the dynamics kernels: ") and "so far" in lines[0]
    assert "numba cache" in lines[0]
    assert lines[-1].startswith("compiling the dynamics kernels: done in ")
    assert len(lines) >= 2


def test_a_quick_step_says_nothing():
    lines = []
    with Heartbeat(lines.append, "compiling", after=30.0):
        pass
    assert lines == []


def test_bad_periods_are_refused():
    with pytest.raises(ValueError, match="every > 0"):
        Heartbeat(print, "x", every=0.0)
