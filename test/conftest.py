import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))   # test helpers (pin_reference)


def pytest_sessionstart(session):
    """Compile (or load) every numba kernel once, before any test: on a fresh clone the
    cache is cold, and the ROS tests' node processes then load it instead of each
    compiling the kernels again."""
    from serial_dynamics.precompile import precompile
    print(f"\nnumba kernels compiled or loaded in {precompile(jobs=2):.1f} s (two processes)")
