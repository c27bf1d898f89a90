"""Every ```python block of the README and of docs/ runs as written (each in a fresh
interpreter, in an empty working directory), so that the documentation cannot drift from
the code. Blocks that only show a signature are fenced as ```text."""
import glob
import os
import re
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FILES = [os.path.join(ROOT, "README.md")] + sorted(glob.glob(os.path.join(ROOT, "docs", "*.md")))
BLOCKS = [(os.path.relpath(f, ROOT), s[:m.start()].count("\n") + 2, m.group(1))
          for f in FILES for s in [open(f).read()]
          for m in re.finditer(r"```python\n(.*?)```", s, re.S)]


def test_the_docs_have_code_blocks():
    assert {f for f, _, _ in BLOCKS} >= {"README.md", "docs/speed.md", "docs/simulation.md"}


@pytest.mark.parametrize("where, line, code", BLOCKS, ids=[f"{f}:{n}" for f, n, _ in BLOCKS])
def test_code_block_runs_as_written(where, line, code, tmp_path):
    run = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                         text=True, timeout=600, env=dict(os.environ, MPLBACKEND="Agg"))
    assert run.returncode == 0, f"{where}, the block from line {line}:\n{run.stderr[-3000:]}"
