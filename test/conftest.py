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


# The suite runs in two pytest-xdist workers (setup.cfg: -n 2 --dist loadgroup), one a core.
# Each test file goes to one worker whole (its module fixtures run once); the files that
# start ROS nodes (test/ros/, and test_docs.py with its ROS blocks) all go to the same
# worker, one after another as in a one-process run, so that no two ROS tests share the
# machine: what the other worker does is the load those tests are checked to stand
# (issue 26: test/ros passes 10 times in a row while another process keeps a core busy).
ROS_FILES = (os.path.join(HERE, "ros") + os.sep, os.path.join(HERE, "test_docs.py"))


@pytest.hookimpl(tryfirst=True)      # before xdist's, which reads the marks
def pytest_collection_modifyitems(config, items):
    for item in items:
        path = str(item.path)
        group = "ros" if path.startswith(ROS_FILES) else os.path.relpath(path, HERE)
        item.add_marker(pytest.mark.xdist_group(group))
