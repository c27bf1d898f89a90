"""No import cycles, every module importable on its own, no rclpy in the core library.

- ``test_imports_alone``: every module of the package (found with ``pkgutil.walk_packages``)
  is imported alone, first thing, in a fresh interpreter (forked from one that imported
  only numpy, scipy and numba: ``_FORKER``). An import cycle that only works
  in one import order, a missing import hidden by another module's side effect, a module
  that does real work at import time: all show up here. The core modules (everything
  outside ``serial_dynamics.ros``) must also leave ``rclpy`` out of ``sys.modules``.
- ``test_no_module_level_cycles``: the graph of intra-package imports executed at import
  time (module body, including ``if``/``try``/``with`` blocks and class bodies; not
  function bodies, not ``if TYPE_CHECKING:``, not ``if __name__ == "__main__":``) has no
  cycle. Each cycle is reported as a path ``a -> b -> a`` with file and line.
- ``test_no_hidden_cycles``: an import inside a function is still a dependency; the DESIGN
  asks for no import cycles at all, so a function-local import that closes a cycle (its
  target reaches the importer, through imports of either kind) fails too. This is the
  usual trick of "import it inside the function, because the other module imports us".
- ``test_core_never_imports_rclpy``: statically, no module outside ``serial_dynamics.ros``
  imports ``rclpy`` at import time.

Edges: ``import a.b.c`` and ``from a.b.c import x`` depend on ``a.b.c`` and on the packages
``a.b``, ``a`` that Python executes first, except the importer's own ancestor packages
(those are always executed before the importer; an edge to them would make every
``__init__`` that imports its submodules a "cycle"). ``from a.b import x`` depends on
``a.b.x`` too when ``x`` is a submodule. An ancestor package named explicitly
(``from .. import load_urdf``) is an edge.
"""
from __future__ import annotations

import ast
import importlib.util
import json
import os
import pkgutil
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import pytest

import serial_dynamics

PKG = "serial_dynamics"
ROS = PKG + ".ros"
HAVE_RCLPY = importlib.util.find_spec("rclpy") is not None


def _is_ros(name):
    return name == ROS or name.startswith(ROS + ".")


def _modules():
    """{module name: source file} of every module of the package (ros only with rclpy)."""
    out = {PKG: serial_dynamics.__file__}
    skipped_ros = lambda name: _is_ros(name) and not HAVE_RCLPY   # noqa: E731
    for info in pkgutil.walk_packages(serial_dynamics.__path__, PKG + ".",
                                      onerror=lambda name: None):
        if skipped_ros(info.name):
            continue
        leaf = info.name.rsplit(".", 1)[1]
        path = info.module_finder.path
        source = (os.path.join(path, leaf, "__init__.py") if info.ispkg
                  else os.path.join(path, leaf + ".py"))
        # None: a C extension (core/_fastcall), which has no Python source and imports nothing
        out[info.name] = source if os.path.isfile(source) else None
    # walk_packages does not descend into a subpackage it cannot import: list the files too,
    # so that a broken subpackage is reported rather than silently left out
    root = os.path.dirname(serial_dynamics.__file__)
    for dirpath, dirnames, files in os.walk(root):
        dirnames[:] = [d for d in dirnames if os.path.isfile(os.path.join(dirpath, d, "__init__.py"))]
        rel = os.path.relpath(dirpath, root)
        prefix = PKG if rel == "." else PKG + "." + rel.replace(os.sep, ".")
        for f in files:
            if f.endswith(".py"):
                name = prefix if f == "__init__.py" else prefix + "." + f[:-3]
                if not skipped_ros(name):
                    out.setdefault(name, os.path.join(dirpath, f))
    return dict(sorted(out.items()))


MODULES = _modules()


# ------------------------------------------------------------------ import each module alone
# ``__main__`` modules are scripts (``python -m serial_dynamics.builtin`` rewrites the URDF
# files): importing them runs them, so they are left out here (their imports are still in
# the static graph below).
ALONE = [m for m in MODULES if m.rsplit(".", 1)[-1] != "__main__"]

# One interpreter imports the third-party libraries every module needs (numpy, scipy,
# numba: ~1 s of a fresh interpreter's start) and then forks a child per module, which
# imports it first thing: each child is an interpreter in which nothing of the package (nor
# rclpy) has been imported, as a fresh one, for a fraction of the cost.
_FORKER = r"""
import importlib, json, os, sys, traceback
import numpy, numba, scipy.integrate, scipy.linalg, scipy.optimize   # third-party, paid once
assert not any(m == "rclpy" or m.startswith(("rclpy.", "serial_dynamics")) for m in sys.modules)
out = {}
for mod in sys.argv[1:]:
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(r)
        try:
            importlib.import_module(mod)
            msg, code = ("RCLPY_LOADED" if "rclpy" in sys.modules else "RCLPY_ABSENT"), 0
        except BaseException:
            msg, code = traceback.format_exc(), 1
        os.write(w, msg.encode())
        os._exit(code)
    os.close(w)
    with os.fdopen(r, "rb") as f:
        msg = f.read().decode()
    out[mod] = (os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]), msg)
print(json.dumps(out))
"""


def _import_alone(mods):
    """{module: (exit code, "RCLPY_LOADED" / "RCLPY_ABSENT" or the traceback)}."""
    env = dict(os.environ)
    env.pop("PYTHONSTARTUP", None)
    p = subprocess.run([sys.executable, "-c", _FORKER, *mods], capture_output=True,
                       text=True, timeout=600, env=env,
                       cwd=os.path.dirname(os.path.dirname(serial_dynamics.__file__)))
    assert p.returncode == 0, p.stderr[-3000:]
    return json.loads(p.stdout.strip().splitlines()[-1])


def test_imports_alone():
    assert len(ALONE) > 10, f"found only {ALONE}"
    with ThreadPoolExecutor(max_workers=2) as pool:          # two forking interpreters
        results = {k: v for part in pool.map(_import_alone, (ALONE[0::2], ALONE[1::2]))
                   for k, v in part.items()}
    assert sorted(results) == sorted(ALONE)
    failed, rclpy_in_core = [], []
    for mod, (code, msg) in results.items():
        if code != 0:
            tail = "\n    ".join(msg.strip().splitlines()[-12:])
            failed.append(f"{mod}: exit {code}\n    {tail}")
        elif not _is_ros(mod) and msg != "RCLPY_ABSENT":
            rclpy_in_core.append(mod)
    problems = []
    if failed:
        problems.append("modules that fail to import alone in a fresh interpreter:\n" + "\n".join(failed))
    if rclpy_in_core:
        problems.append(f"core modules whose import loads rclpy (only {ROS} may): {rclpy_in_core}")
    assert not problems, "\n".join(problems)


# ------------------------------------------------------------------ static import graph
@dataclass(frozen=True)
class Edge:
    src: str
    dst: str
    line: int
    local: bool          # inside a function body

    def where(self):
        return f"{os.path.relpath(MODULES[self.src], os.path.dirname(os.path.dirname(serial_dynamics.__file__)))}:{self.line}"


def _is_type_checking(test):
    return ((isinstance(test, ast.Name) and test.id == "TYPE_CHECKING")
            or (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"))


def _is_main_guard(test):
    return (isinstance(test, ast.Compare) and isinstance(test.left, ast.Name)
            and test.left.id == "__name__" and len(test.comparators) == 1
            and isinstance(test.comparators[0], ast.Constant)
            and test.comparators[0].value == "__main__")


def _import_nodes(tree):
    """(node, local) for every import statement: local = inside a function (or lambda);
    blocks that never run on import (TYPE_CHECKING, __main__ guard) are left out."""
    out = []

    def visit(node, local):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            out.append((node, local))
            return
        if isinstance(node, ast.If) and (_is_type_checking(node.test) or _is_main_guard(node.test)):
            for child in node.orelse:
                visit(child, local)
            return
        inner = local or isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
        for child in ast.iter_child_nodes(node):
            visit(child, inner)

    visit(tree, False)
    return out


def _ancestors(mod):
    parts = mod.split(".")
    return {".".join(parts[:k]) for k in range(1, len(parts))}


def _resolve(importer, node):
    """What executing ``node`` in ``importer`` imports: [(module name, explicit)], names
    possibly outside the package. ``from X import a`` names X explicitly unless every name
    it imports is a submodule of X (then X is only their container)."""
    is_pkg = os.path.basename(MODULES[importer]) == "__init__.py"
    if isinstance(node, ast.Import):
        return [(alias.name, True) for alias in node.names]
    if node.level:
        base = importer.split(".") if is_pkg else importer.split(".")[:-1]
        base = base[:len(base) - (node.level - 1)]
        target = ".".join(base + ([node.module] if node.module else []))
    else:
        target = node.module
    subs = [f"{target}.{alias.name}" for alias in node.names if f"{target}.{alias.name}" in MODULES]
    return [(target, len(subs) < len(node.names))] + [(sub, True) for sub in subs]


def _edges():
    edges = []
    for mod, path in MODULES.items():
        if path is None:
            continue
        with open(path, encoding="utf-8") as fh:
            tree = ast.parse(fh.read(), path)
        for node, local in _import_nodes(tree):
            for target, explicit in _resolve(mod, node):
                if not (target == PKG or target.startswith(PKG + ".")):
                    continue
                # the target if named explicitly; the packages Python executes before it
                # (and the target when it is only a container of submodules) unless they
                # are the importer's ancestors, which are always executed before it anyway
                implicit = set(_ancestors(target)) | (set() if explicit else {target})
                deps = (implicit - _ancestors(mod)) | ({target} if explicit else set())
                for dst in sorted(deps):
                    if dst != mod and dst in MODULES:
                        edges.append(Edge(mod, dst, node.lineno, local))
    return edges


def _graph(edges):
    g = {m: {} for m in MODULES}
    for e in edges:
        g[e.src].setdefault(e.dst, e)      # first (lowest-line) edge between two modules
    return g


def _cycles(g):
    """One cycle per back edge of a depth-first search, as lists of edges."""
    WHITE, GREY, BLACK = 0, 1, 2
    color = {m: WHITE for m in g}
    stack, found = [], []

    def dfs(u):
        color[u] = GREY
        for v, e in g[u].items():
            if color[v] == GREY:
                i = next(k for k, s in enumerate(stack) if s.src == v) if v != u else len(stack)
                found.append(stack[i:] + [e])
            elif color[v] == WHITE:
                stack.append(e)
                dfs(v)
                stack.pop()
        color[u] = BLACK

    for m in sorted(g):
        if color[m] == WHITE:
            dfs(m)
    return found


def _describe(cycle):
    path = " -> ".join([cycle[0].src] + [e.dst for e in cycle])
    lines = "\n".join(f"      {e.src} -> {e.dst}  ({e.where()}{', inside a function' if e.local else ''})"
                      for e in cycle)
    return f"  {path}\n{lines}"


def _reaches(g, start, goal):
    """A path of edges start -> ... -> goal in g, or None."""
    prev, todo = {start: None}, [start]
    while todo:
        u = todo.pop(0)
        if u == goal:
            path = []
            while prev[u] is not None:
                path.append(prev[u])
                u = prev[u].src
            return path[::-1]
        for v, e in g[u].items():
            if v not in prev:
                prev[v] = e
                todo.append(v)
    return None


EDGES = _edges()


def test_graph_sees_the_package():
    """The static graph is not vacuous: it finds the imports we know are there."""
    pairs = {(e.src, e.dst) for e in EDGES}
    assert (PKG, PKG + ".robot") in pairs
    assert (PKG + ".robot.facade", PKG + ".model.model") in pairs
    assert any(e.local for e in EDGES), "no function-local import found at all"


def _module_level_cycles(edges):
    return _cycles(_graph([e for e in edges if not e.local]))


def _hidden_cycles(edges):
    """Cycles closed by a function-local import A -> B where B already reaches A (through
    imports of either kind), each once."""
    full = _graph(edges)
    hidden, seen = [], set()
    for e in edges:
        if not e.local:
            continue
        back = _reaches(full, e.dst, e.src)
        if back is None:
            continue
        cycle = [e] + back
        key = frozenset((x.src, x.dst) for x in cycle)
        if key not in seen:
            seen.add(key)
            hidden.append(cycle)
    return hidden


def test_cycle_finders_find_planted_cycles():
    """The detectors themselves, on the package's real graph plus planted imports (any real
    import between the same two modules removed first, so that the planted one is seen)."""
    assert _cycles(_graph([])) == []

    def plant(src, dst, local):
        e = Edge(PKG + src, PKG + dst, 999, local)
        return e, [x for x in EDGES if (x.src, x.dst) != (e.src, e.dst)] + [e]

    # what builtin/__init__.py did: ``from .. import load_urdf`` inside a function, while
    # the package imports serial_dynamics.builtin at module level
    e, edges = plant(".builtin", "", True)
    (cycle,) = [c for c in _hidden_cycles(edges) if e in c]
    assert cycle[0] == e and cycle[-1].dst == e.src, _describe(cycle)
    assert not any(e in c for c in _module_level_cycles(edges))
    # the same import at module level is a module-level cycle of length two
    e, edges = plant(".builtin", "", False)
    cycles = [c for c in _module_level_cycles(edges) if e in c]
    assert len(cycles) == 1 and len(cycles[0]) == 2, [_describe(c) for c in cycles]
    # model -> robot at module level (robot imports model)
    e, edges = plant(".model", ".robot", False)
    assert any(e in c for c in _module_level_cycles(edges))
    # a function-local import downward (robot -> model) closes no cycle
    assert _hidden_cycles([Edge(PKG + ".robot", PKG + ".model", 1, True)]) == []


def test_resolve_relative_imports():
    tree = ast.parse("from .. import load_urdf\nfrom . import _f, synthetic\n"
                     "from ..algorithms import rnea\nimport serial_dynamics.robot as r\n"
                     "def f():\n    from .synthetic import x\n"
                     "if __name__ == '__main__':\n    from .. import cli\n")
    nodes = _import_nodes(tree)
    assert [local for _, local in nodes] == [False, False, False, False, True]
    got = [_resolve(PKG + ".builtin", n) for n, _ in nodes]
    assert got[0] == [(PKG, True)]
    assert got[1] == [(PKG + ".builtin", True), (PKG + ".builtin.synthetic", True)]
    assert got[2] == [(PKG + ".algorithms", False), (PKG + ".algorithms.rnea", True)]
    assert got[3] == [(PKG + ".robot", True)]
    assert got[4] == [(PKG + ".builtin.synthetic", True)]
    # from a plain module, "." is its package
    (node, _), = _import_nodes(ast.parse("from .model import Model"))
    assert _resolve(PKG + ".cli", node) == [(PKG + ".model", True)]


def test_no_module_level_cycles():
    cycles = _module_level_cycles(EDGES)
    assert not cycles, ("import cycles among module-level imports (each module in the cycle "
                        "needs the next one while it is itself half-initialised):\n"
                        + "\n".join(_describe(c) for c in cycles))


def test_no_hidden_cycles():
    hidden = _hidden_cycles(EDGES)
    assert not hidden, ("import cycles hidden by function-local imports (the import inside a "
                        "function points back up to a module that imports its importer):\n"
                        + "\n".join(_describe(c) for c in hidden))


def test_core_never_imports_rclpy():
    bad = []
    for mod, path in MODULES.items():
        if _is_ros(mod) or path is None:
            continue
        with open(path, encoding="utf-8") as fh:
            tree = ast.parse(fh.read(), path)
        for node, local in _import_nodes(tree):
            if local:
                continue
            for target, _ in _resolve(mod, node):
                if target == "rclpy" or target.startswith("rclpy."):
                    bad.append(f"{mod} ({path}:{node.lineno}) imports {target}")
    assert not bad, "the core library must not import rclpy at module level:\n" + "\n".join(bad)


def test_the_compiled_core_imports_nothing_from_the_reference():
    """Issue 50: ``core/`` and ``gpu/`` import nothing from ``algorithms/`` (the NumPy
    reference), at module level or in a function: what the kernels freeze in (a layout's
    columns) lies under core/'s cache fingerprint (core/cache.py), never outside it."""
    bad = []
    for mod, path in MODULES.items():
        if path is None or not mod.startswith((PKG + ".core", PKG + ".gpu")):
            continue
        with open(path, encoding="utf-8") as fh:
            tree = ast.parse(fh.read(), path)
        for node, _ in _import_nodes(tree):
            for target, _ in _resolve(mod, node):
                if target == PKG + ".algorithms" or target.startswith(PKG + ".algorithms."):
                    bad.append(f"{mod} ({path}:{node.lineno}) imports {target}")
    assert any(m.startswith(PKG + ".core.") for m in MODULES)
    assert not bad, "move what core/ needs into core/:\n" + "\n".join(bad)


@pytest.mark.skipif(not HAVE_RCLPY, reason="rclpy not importable: serial_dynamics.ros skipped")
def test_ros_modules_are_walked():
    assert any(_is_ros(m) for m in ALONE)


# ------------------------------------------------------------------ public paths
PUBLIC_PATHS = [   # documented import paths that must survive any move (issue 18)
    ("serial_dynamics", ["load_urdf", "Robot", "Model", "Dissipation", "simulate", "BaseMotion",
                         "RobotDescriptionError", "URDFError", "ModelError", "HeldJointsWarning",
                         "SimulationError", "default_robot", "builtin_robot", "builtin_path",
                         "InertiaRepairWarning"]),
    ("serial_dynamics.model", ["Model", "Dissipation", "ModelError", "RobotDescriptionError"]),
    ("serial_dynamics.urdf", ["load_model", "HeldJointsWarning", "URDFError"]),
    ("serial_dynamics.robot", ["Robot", "MimicRobot", "PlanarRobot", "FloatingMimicRobot",
                               "BaseMotion", "kind_of"]),
    ("serial_dynamics.sim.fixed_step", ["FixedStepIntegrator"]),
    ("serial_dynamics.sim.methods", ["SimulationError", "METHODS"]),
    ("serial_dynamics.identification", ["identify", "base_parameters"]),
    ("serial_dynamics.observers", ["MomentumObserver"]),
    ("serial_dynamics.trajectory", ["time_parameterize", "Waypoints", "pick_and_place",
                                    "UR5E_PICK_AND_PLACE", "Trajectory", "minimum_time"]),
    ("serial_dynamics.control", ["torque", "MODES", "pd_gains"]),
]


@pytest.mark.parametrize("module, names", PUBLIC_PATHS, ids=[m for m, _ in PUBLIC_PATHS])
def test_public_paths_still_work(module, names):
    mod = importlib.import_module(module)
    missing = [n for n in names if not hasattr(mod, n)]
    assert not missing, f"{module} lost {missing}"
    import serial_dynamics as sd
    errors = importlib.import_module("serial_dynamics.model.errors")
    for name in ("RobotDescriptionError", "ModelError", "URDFError", "HeldJointsWarning",
                 "SimulationError", "InertiaRepairWarning"):            # one class each, wherever it is imported from
        assert getattr(sd, name) is getattr(errors, name)


def test_the_top_level_keeps_only_the_entry_points():
    top = sorted(f for f in os.listdir(os.path.dirname(serial_dynamics.__file__))
                 if f.endswith(".py"))
    assert top == ["__init__.py", "cli.py", "control.py", "joints.py", "observers.py",
                   "precompile.py"], top


def _one_letter_apart(a, b):
    """True if one insertion, deletion or substitution of a letter turns ``a`` into ``b``."""
    if abs(len(a) - len(b)) > 1 or a == b:
        return False
    i = 0
    while i < min(len(a), len(b)) and a[i] == b[i]:
        i += 1
    return a[i + (len(a) >= len(b)):] == b[i + (len(b) >= len(a)):]


def test_no_two_folders_a_letter_apart():
    """Issue 50: names that say what they hold; no two folders of the package that a reader
    confuses by one letter (``robot/`` the facade and ``robots/`` the URDFs were)."""
    assert _one_letter_apart("robot", "robots") and _one_letter_apart("sim", "sin")
    assert not _one_letter_apart("robot", "ros") and not _one_letter_apart("core", "core")
    root = os.path.dirname(serial_dynamics.__file__)
    folders = sorted({d for _, dirs, _ in os.walk(root) for d in dirs if d != "__pycache__"})
    close = [(a, b) for k, a in enumerate(folders) for b in folders[k + 1:]
             if _one_letter_apart(a, b)]
    assert not close, f"folders a letter apart (rename one): {close}"


def test_test_files_have_unique_basenames():
    """pytest imports test files by basename (rootdir conftest, no packages): two files of
    one name in different test/ folders break the collection of the whole suite."""
    here = os.path.dirname(os.path.abspath(__file__))
    seen = {}
    for dirpath, _, files in os.walk(here):
        for f in files:
            if f.startswith("test_") and f.endswith(".py"):
                seen.setdefault(f, []).append(os.path.relpath(os.path.join(dirpath, f), here))
    twice = {f: paths for f, paths in seen.items() if len(paths) > 1}
    assert not twice, f"test files sharing a basename (rename one): {twice}"
