"""The starved-controller scenario with real nodes on a loaded core (issue 20 item 3):

    python bench/bench_controller_load.py

runs test/ros/test_controller_load.py (the simulator and the controller as processes, the
controller pinned to a core with a busy process and stopped 30 ms in every 100 ms, the tip
pushed) with SERIAL_DYNAMICS_LOAD_SCENARIOS=1. Its outcome depends on the machine's load,
so it is not part of the test suite (issue 26 item 5); the suite checks the same scenario
deterministically in test/test_control_starved.py. Prints each mode's peak and end speeds.
"""
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

if __name__ == "__main__":
    env = {**os.environ, "SERIAL_DYNAMICS_LOAD_SCENARIOS": "1"}
    raise SystemExit(subprocess.call(
        [sys.executable, "-m", "pytest", "-q", "-s", "-p", "no:cacheprovider",
         os.path.join(ROOT, "test", "ros", "test_controller_load.py")], cwd=ROOT, env=env))
