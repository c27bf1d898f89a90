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


# The suite runs in two pytest-xdist workers (setup.cfg: -n 2 --dist loadfile; the machine
# has two cores and much of the suite waits on subprocesses and ROS graphs). WORKER is "gw0",
# "gw1", ... in a worker and "" in the controller or in a run without xdist (-n 0).
WORKER = os.environ.get("PYTEST_XDIST_WORKER", "")
REPRODUCIBILITY = os.path.join(HERE, "core", "test_reproducibility.py")


def pytest_sessionstart(session):
    """Compile (or load) every numba kernel once, before any test: on a fresh clone the
    cache is cold, and the workers and the ROS tests' node processes then load it instead
    of each compiling the kernels again. xdist's controller runs this before it starts the
    workers; a worker loads each kernel when a test first calls it."""
    if WORKER:
        return
    from serial_dynamics.precompile import precompile
    print(f"\nnumba kernels compiled or loaded in {precompile(jobs=2):.1f} s (two processes)")
    # xdist's controller collects nothing: it starts the cold runs where its arguments name
    # test_reproducibility's file or a folder above it
    if session.config.getoption("numprocesses", None) and any(
            os.path.commonpath([os.path.abspath(a.split("::")[0]), REPRODUCIBILITY])
            == os.path.abspath(a.split("::")[0]) for a in session.config.args):
        _start_cold_runs()


def _start_cold_runs():
    """test_reproducibility's two compiles from an empty cache (``start_cold_runs``)."""
    import test_reproducibility
    try:
        test_reproducibility.start_cold_runs()
    except pytest.skip.Exception:  # example-robot-data missing: the test skips itself
        pass


def pytest_collection_modifyitems(session, config, items):
    """test_reproducibility's test_identical_across_processes runs last (in a run without
    xdist; in xdist's workers with its file): its two compiles from an empty cache (a few
    minutes each on a core) start when the session starts (xdist's controller) or when
    the tests are collected (below), and run beside the first tests."""
    last = [item for item in items if item.name == "test_identical_across_processes"]
    items[:] = [item for item in items if item not in last] + last


def pytest_collection_finish(session):
    if any(item.name == "test_identical_across_processes" for item in session.items):
        if not WORKER:     # in xdist's workers the controller started them (sessionstart)
            _start_cold_runs()
