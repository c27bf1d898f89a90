"""core/stale_cache.py: a cached kernel that includes a changed source is not run."""
import os
import subprocess
import sys
import textwrap

from serial_dynamics.core.stale_cache import STAMP, cache_folder, clear_stale, fingerprint

INCLUDES = {"core": ("core",), "sim": ("core", "sim")}


def _package(root):
    for folder, text in (("core", "x = 1\n"), ("sim", "y = 2\n")):
        (root / folder / "__pycache__").mkdir(parents=True)
        (root / folder / f"{folder}_a.py").write_text(text)
    return root


def _entries(root, folder):
    return sorted(f.name for f in (root / folder / "__pycache__").iterdir()
                  if f.suffix in (".nbi", ".nbc"))


def _cache(root):
    for folder in INCLUDES:
        for suffix in ("nbi", "nbc"):
            (root / folder / "__pycache__" / f"{folder}_a.f-1.py311.{suffix}").write_text("")
    (root / "core" / "__pycache__" / "core_a.cpython-311.pyc").write_text("")  # not numba's


def test_a_folder_is_cleared_when_a_source_it_includes_changes(tmp_path):
    root = _package(tmp_path)
    assert cache_folder(root / "core" / "core_a.py") == root / "core" / "__pycache__"
    _cache(root)
    assert clear_stale(root, INCLUDES) == ["core", "sim"]      # entries and no fingerprint
    assert _entries(root, "core") == _entries(root, "sim") == []
    assert (root / "core" / "__pycache__" / "core_a.cpython-311.pyc").exists()
    assert (root / "sim" / "__pycache__" / STAMP).read_text() == fingerprint(root, ("core", "sim"))

    _cache(root)
    assert clear_stale(root, INCLUDES) == []                    # nothing changed: all kept
    assert len(_entries(root, "core")) == len(_entries(root, "sim")) == 2

    (root / "sim" / "sim_a.py").write_text("y = 3\n")           # sim's own source
    assert clear_stale(root, INCLUDES) == ["sim"]
    assert len(_entries(root, "core")) == 2 and _entries(root, "sim") == []

    _cache(root)
    (root / "core" / "core_a.py").write_text("x = 4\n")         # included by both
    assert clear_stale(root, INCLUDES) == ["core", "sim"]
    assert _entries(root, "core") == _entries(root, "sim") == []


_RUN = """
import sys
from pathlib import Path
from serial_dynamics.core.stale_cache import clear_stale
if sys.argv[1] == "guard":
    clear_stale(Path(sys.argv[2]) / "pkg", {"core": ("core",)})
from pkg.core.kernel import kernel
print(kernel(1.0))
"""
_STEP = """
from numba import njit
@njit(cache=True, inline="always")
def step(x):
    return x + {}
"""
_KERNEL = """
from numba import njit
from .step import step
@njit(cache=True)
def kernel(x):
    return step(x)
"""


def test_an_edited_inline_step_reaches_its_cached_caller(tmp_path):
    core = tmp_path / "pkg" / "core"
    core.mkdir(parents=True)
    (core / "step.py").write_text(textwrap.dedent(_STEP.format("1.0")))
    (core / "kernel.py").write_text(textwrap.dedent(_KERNEL))
    (tmp_path / "run.py").write_text(_RUN)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path)] + sys.path))
    env.pop("NUMBA_CACHE_DIR", None)

    def run(mode):
        out = subprocess.run([sys.executable, str(tmp_path / "run.py"), mode, str(tmp_path)],
                             env=env, capture_output=True, text=True, check=True)
        return float(out.stdout.split()[-1])
    assert run("guard") == 2.0                                  # compiled and cached
    assert any(f.suffix == ".nbi" for f in (core / "__pycache__").iterdir())
    (core / "step.py").write_text(textwrap.dedent(_STEP.format("2.0")))   # kernel.py as it was
    assert run("guard") == 3.0                                  # the new step, not the cached
