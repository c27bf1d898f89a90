"""core/cache.py: each version of the sources has its own numba cache folder, so a cached
kernel that includes a changed source is never run, and nothing is deleted at import."""
import os
import subprocess
import sys
import textwrap

from serial_dynamics.core import cache
from serial_dynamics.core.cache import PREFIX, fingerprint, folder

INCLUDES = {"core": ("core",), "sim": ("core", "sim")}


def test_a_folder_follows_the_sources_it_includes(tmp_path, monkeypatch):
    monkeypatch.setattr(cache.config, "CACHE_DIR", str(tmp_path / "numba"))
    monkeypatch.setattr(cache, "_FOLDERS", {})
    monkeypatch.setattr(cache, "_DIGESTS", {})
    root = tmp_path / "pkg"
    for name, text in (("core", "x = 1\n"), ("sim", "y = 2\n")):
        (root / name).mkdir(parents=True)
        (root / name / f"{name}_a.py").write_text(text)

    def folders():
        cache._FOLDERS.clear()
        cache._DIGESTS.clear()
        return folder("core", root, INCLUDES), folder("sim", root, INCLUDES)
    core, sim = folders()
    assert core.parent == sim.parent == tmp_path / "numba"       # under NUMBA_CACHE_DIR
    assert core.name == PREFIX + "core-" + fingerprint(root, ("core",))[:20]
    assert sim.name == PREFIX + "sim-" + fingerprint(root, ("core", "sim"))[:20]
    assert folders() == (core, sim)                               # nothing changed
    (root / "sim" / "sim_a.py").write_text("y = 3\n")             # sim's own source
    core2, sim2 = folders()
    assert core2 == core and sim2 != sim
    (root / "core" / "core_b.py").write_text("z = 4\n")           # a new file in core
    core3, sim3 = folders()
    assert core3 != core and sim3 not in (sim, sim2)


def test_the_package_is_cached_in_its_folders():
    from serial_dynamics.core import K
    where = folder("core")
    assert where is not None and where.name.startswith(PREFIX + "core-")
    K.crba
    cached = [f for _, _, fs in os.walk(where) for f in fs]
    assert any(f.startswith("crba.crba-") and f.endswith(".nbi") for f in cached), cached
    assert any(f.startswith("cabi.cabi_crba-") for f in cached), cached    # its cfunc wrapper
    assert cache.config.CACHE_DIR == os.environ.get("NUMBA_CACHE_DIR", "")  # restored after it


_RUN = """
import sys
from pathlib import Path
from serial_dynamics.core.cache import in_folder
with in_folder("core", Path(sys.argv[1]) / "pkg", {"core": ("core",)}) as where:
    from pkg.core.kernel import kernel
print(where.name, kernel(1.0))
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


def test_an_edited_inline_step_reaches_its_cached_caller_and_nothing_is_deleted(tmp_path):
    core = tmp_path / "pkg" / "core"
    core.mkdir(parents=True)
    (core / "step.py").write_text(textwrap.dedent(_STEP.format("1.0")))
    (core / "kernel.py").write_text(textwrap.dedent(_KERNEL))
    (tmp_path / "run.py").write_text(_RUN)
    numba_cache = tmp_path / "numba"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path)] + sys.path),
               NUMBA_CACHE_DIR=str(numba_cache))

    def run():
        out = subprocess.run([sys.executable, str(tmp_path / "run.py"), str(tmp_path)],
                             env=env, capture_output=True, text=True, check=True)
        name, value = out.stdout.split()
        return name, float(value)

    def files():
        return {os.path.join(d, f): os.stat(os.path.join(d, f)).st_mtime_ns
                for d, _, fs in os.walk(numba_cache) for f in fs}
    first, value = run()
    assert value == 2.0                                           # compiled and cached
    cached = files()
    assert any(f.endswith(".nbi") for f in cached)
    (core / "step.py").write_text(textwrap.dedent(_STEP.format("2.0")))   # kernel.py as it was
    second, value = run()
    assert value == 3.0 and second != first                       # the new step, not the cached
    assert all(files().get(f) == t for f, t in cached.items())   # the first folder untouched
    (core / "step.py").write_text(textwrap.dedent(_STEP.format("1.0")))   # back again
    before = files()
    assert run() == (first, 2.0)                                  # its folder, loaded
    assert files() == before                                      # nothing compiled or written
