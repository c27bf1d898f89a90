"""Every ```python block of the README and of docs/ runs as written (each in a fresh
interpreter, in an empty working directory), so that the documentation cannot drift from
the code. Blocks that only show a signature are fenced as ```text.

The blocks run two at a time (each its own process, the machine has two cores): those that
start ROS nodes or processes one after another in one lane, so that no two of them share a
ROS graph at once, then the rest in both lanes from one queue; each test then reports its
block's outcome."""
import glob
import os
import queue
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


@pytest.fixture(scope="module")
def runs():
    """Each block's outcome, two at a time: one lane runs the ROS blocks one after another,
    then both lanes take the other blocks from one queue (balanced by how long they take)."""
    ros = [b for b in BLOCKS if any(w in b[2] for w in ROS_WORDS)]
    rest = queue.SimpleQueue()
    for b in BLOCKS:
        if b not in ros:
            rest.put(b)

    def lane(first):
        done = {(where, line): _run(code) for where, line, code in first}
        while True:
            try:
                where, line, code = rest.get_nowait()
            except queue.Empty:
                return done
            done[where, line] = _run(code)

    with ThreadPoolExecutor(max_workers=2) as pool:
        lanes = [pool.submit(lane, ros), pool.submit(lane, [])]
        return {k: v for f in lanes for k, v in f.result().items()}


def test_the_docs_have_code_blocks():
    assert {f for f, _, _ in BLOCKS} >= {"README.md", "docs/speed.md", "docs/simulation.md"}


@pytest.mark.parametrize("where, line", [(f, n) for f, n, _ in BLOCKS],
                         ids=[f"{f}:{n}" for f, n, _ in BLOCKS])
def test_code_block_runs_as_written(where, line, runs):
    run = runs[where, line]
    assert run.returncode == 0, f"{where}, the block from line {line}:\n{run.stderr[-3000:]}"
