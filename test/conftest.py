import glob
import os
import sys

import pytest

# serial_dynamics.gpu's tests (test/gpu/) run in numba's CUDA simulator on a machine without
# a card. numba-cuda reads NUMBA_ENABLE_CUDASIM through numba's own config, which numba reads
# when it is first imported (and again only when it compiles): pytest_sessionstart below
# imports numba before pytest loads test/gpu/conftest.py, so the variable is set here, when
# this conftest is loaded and before anything imports numba. A value already in the
# environment is kept (bench/gpu_on_card.sh sets 0: the tests on the card).
if "NUMBA_ENABLE_CUDASIM" not in os.environ and not glob.glob("/dev/nvidia[0-9]*"):
    os.environ["NUMBA_ENABLE_CUDASIM"] = "1"


# The tests mirror the package (test/robot/ tests serial_dynamics/robot/, ...); oracles that
# cut across it are in test/oracles/. Test modules share helpers (pin_reference, chains built
# in test_mimic, the Pinocchio cases of test_pinocchio): test/ and each of its folders are on
# the path, so that a helper is imported by its name wherever it lives.
HERE = os.path.dirname(os.path.abspath(__file__))
for _d in sorted(os.listdir(HERE), reverse=True):
    if os.path.isdir(os.path.join(HERE, _d)) and not _d.startswith((".", "_")):
        sys.path.insert(0, os.path.join(HERE, _d))
sys.path.insert(0, HERE)


def pytest_sessionstart(session):
    """Compile (or load) every numba kernel once, before any test: on a fresh clone the
    cache is cold, and the ROS tests' node processes then load it instead of each
    compiling the kernels again."""
    from serial_dynamics.precompile import precompile
    print(f"\nnumba kernels compiled or loaded in {precompile(jobs=2):.1f} s (two processes)")


def pytest_collection_modifyitems(session, config, items):
    """test_reproducibility's test_identical_across_processes runs last: its two compiles
    from an empty cache (a minute each on a core) start when the tests are collected
    (below) and run beside the single-threaded tests at the start of the suite, long before
    the ROS tests, which a loaded machine would disturb."""
    last = [item for item in items if item.name == "test_identical_across_processes"]
    items[:] = [item for item in items if item not in last] + last


def pytest_collection_finish(session):
    for item in session.items:
        if item.name == "test_identical_across_processes":
            try:
                item.module.start_cold_runs()
            except pytest.skip.Exception:  # example-robot-data missing: the test skips itself
                pass
