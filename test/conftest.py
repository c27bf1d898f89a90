import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))   # test helpers (pin_reference)


def pytest_sessionstart(session):
    """Compile (or load) every numba kernel once, before any test: on a fresh clone the
    cache is cold, and the ROS tests' node processes then load it instead of each
    compiling the kernels again."""
    from serial_dynamics.core import K
    from serial_dynamics.sim.loop import _loop
    t0 = time.perf_counter()
    K.load_all()
    _loop()
    print(f"\nnumba kernels compiled or loaded in {time.perf_counter() - t0:.1f} s")
