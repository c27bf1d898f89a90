"""Every ```python block of the README and of docs/ runs as written (each in a fresh
interpreter, in an empty working directory), so that the documentation cannot drift from
the code. Blocks that only show a signature are fenced as ```text.

The blocks run two at a time (each its own process, the machine has two cores): those that
start ROS nodes or processes one after another in one lane, so that no two of them share a
ROS graph at once, the rest in the other; each test then reports its block's outcome."""
import glob
import os
import re
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FILES = [os.path.join(ROOT, "README.md")] + sorted(glob.glob(os.path.join(ROOT, "docs", "*.md")))
BLOCKS = [(os.path.relpath(f, ROOT), s[:m.start()].count("\n") + 2, m.group(1))
          for f in FILES for s in [open(f).read()]
          for m in re.finditer(r"```python\n(.*?)```", s, re.S)]
ROS_WORDS = ("rclpy", "serial_dynamics.ros", "ros2", "launch", "serial-dynamics", "subprocess")


def _run(code):
    with tempfile.TemporaryDirectory() as cwd:
        return subprocess.run([sys.executable, "-c", code], cwd=cwd, capture_output=True,
                              text=True, timeout=600, env=dict(os.environ, MPLBACKEND="Agg"))


def _lane(blocks):
    return {(where, line): _run(code) for where, line, code in blocks}


@pytest.fixture(scope="module")
def runs():
    ros = [b for b in BLOCKS if any(w in b[2] for w in ROS_WORDS)]
    rest = [b for b in BLOCKS if b not in ros]
    with ThreadPoolExecutor(max_workers=2) as pool:
        lanes = [pool.submit(_lane, ros), pool.submit(_lane, rest)]
        return {k: v for lane in lanes for k, v in lane.result().items()}


def test_the_docs_have_code_blocks():
    assert {f for f, _, _ in BLOCKS} >= {"README.md", "docs/speed.md", "docs/simulation.md"}


@pytest.mark.parametrize("where, line", [(f, n) for f, n, _ in BLOCKS],
                         ids=[f"{f}:{n}" for f, n, _ in BLOCKS])
def test_code_block_runs_as_written(where, line, runs):
    run = runs[where, line]
    assert run.returncode == 0, f"{where}, the block from line {line}:\n{run.stderr[-3000:]}"
