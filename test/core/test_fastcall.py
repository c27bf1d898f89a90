"""core/_fastcall.c and core/cabi.py: single-state entry points called through their
numba.cfunc wrappers from C give the njit kernel's results bit for bit (every call the facade
makes on eight robots of every kind, replayed both ways: every single-state entry point),
return OTHER_TYPES for any other arguments (types, layouts, subclasses, read-only arrays,
bools) in C and in the Python check alike, a kernel that raises raises as numba raises it,
and without the extension (a build without a C compiler) the package computes the same
bits."""
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest
from numba import types

import serial_dynamics as sd
from serial_dynamics.core import cabi, dispatch
from serial_dynamics.core import flags as F
from serial_dynamics.core.dispatch import K, OTHER_TYPES, SINGLE_STATE
from serial_dynamics.core.signatures import Mat, Vec, i8

from pin_reference import erd

pytestmark = pytest.mark.skipif(os.environ.get("SERIAL_DYNAMICS_FASTCALL") == "0",
                                reason="SERIAL_DYNAMICS_FASTCALL=0: every call checked in Python")


def load(rel, tips=None, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        return sd.load_urdf(erd(rel), tip_links=tips, **kw)


def solo12(**kw):
    return load("solo_description/robots/solo12.urdf", **kw)


ROBOTS = {   # (make, a tip wrench): each kind and kernel table (chain, tree, floating chain and
    # tree, mimic, planar), with and without a tip wrench
    "ur5e": (sd.default_robot, False),
    "ur5e, tip wrench": (sd.default_robot, True),
    "planar_3r, tip wrench": (lambda: sd.builtin_robot("planar_3r"), True),
    "ur5 floating, tip wrench": (lambda: load("ur_description/urdf/ur5_robot.urdf", ["tool0"],
                                              floating_base=True), True),
    "solo12 fixed, tip wrench": (solo12, True),
    "solo12 floating": (lambda: solo12(floating_base=True), False),
    "solo12 floating, tip wrench": (lambda: solo12(floating_base=True), True),
    "panda with fingers (mimic)": (lambda: load("panda_description/urdf/panda.urdf"), False),
}


def test_the_extension_is_built_and_every_single_state_entry_point_uses_it():
    # a build without a C compiler installs without it (setup.py: optional); here it must be
    assert cabi._fastcall is not None, "core/_fastcall.c was not built: pip install -e ."
    for name in SINGLE_STATE:
        assert isinstance(getattr(K, name), cabi._fastcall.Entry), name


def _exercise(robot, wrench):
    rng = np.random.default_rng(3)
    q, qd = robot.random_state(rng, speed=1.5)
    qdd = rng.uniform(-1, 1, robot.nv)
    w = np.array([1.0, -2.0, 0.5, 0.1, 0.2, -0.3]) if wrench else None
    tau = robot.inverse_dynamics(q, qd, qdd, wrench=w)
    robot.mass_matrix(q)
    robot.forward_dynamics(q, qd, tau, wrench=w)
    robot.bias_torques(q, qd)
    robot.gravity_torques(q)
    robot.inverse_dynamics_derivatives(q, qd, qdd)
    robot.forward_dynamics_derivatives(q, qd, tau)
    robot.regressor(q, qd, qdd)
    robot.kinetic_energy_gradient(q, qd)
    for link in robot.link_names[-2:]:
        robot.forward_kinematics(q, link)
        robot.jacobian(q, link)


@pytest.fixture(scope="module")
def recorded():
    """Every call the facade made to a single-state entry point, for each robot: (name,
    the Entry, copies of its arguments)."""
    calls = []
    saved = {name: getattr(K, name) for name in SINGLE_STATE}

    def recorder(name, entry):
        def call(*args):
            calls.append((name, entry, [a.copy() if isinstance(a, np.ndarray) else a
                                        for a in args]))
            return entry(*args)
        return call
    try:
        for name, entry in saved.items():
            K.__dict__[name] = recorder(name, entry)
        for table in (dispatch.TREE,):       # the tree table holds K's entries by lookup
            table.__dict__.clear()
        for make, wrench in ROBOTS.values():
            _exercise(make(), wrench)
    finally:
        K.__dict__.update(saved)
        dispatch.TREE.__dict__.clear()
    return calls


def test_every_call_the_facade_makes_gives_the_kernels_bits(recorded):
    names = {name for name, _, _ in recorded}
    assert names == set(SINGLE_STATE), sorted(set(SINGLE_STATE) - names)   # every one reached
    for name, entry, args in recorded:
        assert isinstance(entry, cabi._fastcall.Entry), name
        python = cabi.Entry(entry.kernel, entry.spec)          # the check in Python, the njit kernel
        ours = [a.copy() if isinstance(a, np.ndarray) else a for a in args]
        theirs = [a.copy() if isinstance(a, np.ndarray) else a for a in args]
        s_ours, s_theirs = entry(*ours), python(*theirs)
        assert s_ours == s_theirs != OTHER_TYPES, name
        for a, b in zip(ours, theirs):
            if isinstance(a, np.ndarray):
                assert a.tobytes() == b.tobytes(), name      # NaN in unwritten scratch too


def outcome(f, args):
    """What a call gives: its status and the bytes of every array argument after it, or the
    type of the exception it raised."""
    args = [a.copy() if isinstance(a, np.ndarray) else a for a in args]
    try:
        status = f(*args)
    except Exception as e:        # noqa: BLE001 (the exception's type is the outcome)
        return type(e)
    return status, [a.tobytes() for a in args if isinstance(a, np.ndarray)]


class _Sub(np.ndarray):
    pass


def test_other_arguments_return_other_types_without_numba():
    robot = sd.default_robot()
    P, q, o = robot._P, np.full(6, 0.3), np.empty((6, 6))
    crba = K.crba
    python = cabi.Entry(crba.kernel, crba.spec)
    ro = q.copy()
    ro.flags.writeable = False
    swapped = q.astype(">f8")
    odd = np.zeros(6 * 8 + 1, np.uint8)[1:].view(np.float64)       # misaligned
    for args in [(P, q.astype(np.float32), o), (P, np.full(12, 0.3)[::2], o), (P, ro, o),
                 (P, list(q), o), (P, q[None], o), (P, q, np.asfortranarray(np.empty((6, 6)))),
                 (P, q.view(np.matrix), o), (P, q.view(_Sub), o), (P, swapped, o),
                 (P, odd, o), (P, q, None), (P.astype(np.float32), q, o)]:
        assert crba(*args) == python(*args) == OTHER_TYPES
    assert not odd.flags.aligned
    for args in [(P, q), (P, q, o, o)]:               # another count: a TypeError both ways
        assert outcome(crba, args) == outcome(python, args) == TypeError
    with pytest.raises(TypeError, match="takes 3 positional arguments"):
        crba(P, q, out=o)                             # keywords too
    assert crba(P, q, o) == python(P, q, o) == 0
    np.testing.assert_array_equal(robot.mass_matrix(q), o)
    rnea, v = K.rnea, np.full(6, 0.2)
    python = cabi.Entry(rnea.kernel, rnea.spec)
    for flags, status in ((np.int64(F.QD | F.QDD), 0), (F.QD | F.QDD, 0), (True, OTHER_TYPES),
                          (2**70, OTHER_TYPES), (3.0, OTHER_TYPES), (np.int32(3), OTHER_TYPES)):
        args = (P, q, v, v, flags, np.empty(6))
        assert outcome(rnea, args)[0] == outcome(python, args)[0] == status, flags
        assert outcome(rnea, args) == outcome(python, args)


def _divide(x, k, out):
    out[0] = 1.0 / x[0]      # ZeroDivisionError when x[0] == 0 (numba's error model)
    return k


def test_a_kernel_that_raises_raises_as_numba_raises_it():
    entry = cabi.entry("divide", _divide, i8(Vec, i8, Vec), cache=False)
    assert isinstance(entry, cabi._fastcall.Entry) and entry.spec == "1i1"
    out = np.empty(1)
    assert entry(np.array([4.0]), 7, out) == 7 and out[0] == 0.25
    with pytest.raises(ZeroDivisionError):
        entry(np.array([0.0]), 7, out)
    assert entry(np.array([2.0]), -7, out) == -7 and out[0] == 0.5   # and works on after


def test_the_wrapper_rebuilds_each_array_from_its_pointer_and_shape():
    assert cabi.wrapper_source("crba", "212") == (
        "def cabi_crba(data, dims, ints):\n"
        "    try:\n"
        "        return kernel(carray(data[0], (dims[0], dims[1],)), carray(data[1], (dims[2],)), "
        "carray(data[2], (dims[3], dims[4],)))\n"
        "    except Exception:\n"
        "        return RAISED\n")
    assert cabi.spec(i8(Mat, Vec, i8, Vec)) == "21i1"


def test_signatures_outside_the_c_abi_are_refused_by_name():
    A = types.Array(types.float64, 1, "A")
    R = types.Array(types.float64, 1, "C", readonly=True)
    for sig, culprit in ((i8(A, i8, Vec), "argument 0"), (i8(Vec, R), "argument 1"),
                         (i8(Vec, types.float64), "argument 1"),
                         (types.float64(Vec, i8, Vec), "returns float64")):
        with pytest.raises(ValueError, match=culprit):
            cabi.spec(sig)


def test_without_the_extension_every_call_is_checked_in_python_with_the_same_bits():
    # a build without a C compiler: importing _fastcall fails (None in sys.modules makes it)
    code = ("import sys; sys.modules['serial_dynamics.core._fastcall'] = None\n"
            "import numpy as np, serial_dynamics as sd\n"
            "from serial_dynamics.core import cabi, dispatch\n"
            "assert cabi._fastcall is None and not dispatch.FASTCALL\n"
            "assert type(dispatch.K.crba) is cabi.Entry\n"
            "r = sd.default_robot(); q = np.full(6, 0.3)\n"
            "sys.stdout.write((r.mass_matrix(q).tobytes() + r.inverse_dynamics(q, q, q).tobytes()).hex())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    robot, q = sd.default_robot(), np.full(6, 0.3)
    assert out.stdout == (robot.mass_matrix(q).tobytes()
                          + robot.inverse_dynamics(q, q, q).tobytes()).hex()


def test_an_extension_built_from_older_sources_is_not_called():
    """A ``_fastcall`` of another calling convention (an editable install not rebuilt after a
    pull: the old build called numba's internal convention) would crash on the cfunc
    addresses: cabi refuses it with a RuntimeWarning and checks the arguments in Python."""
    code = ("import sys, types, warnings\n"
            "old = types.ModuleType('serial_dynamics.core._fastcall')\n"
            "old.Entry = object\n"
            "sys.modules['serial_dynamics.core._fastcall'] = old\n"
            "with warnings.catch_warnings(record=True) as w:\n"
            "    warnings.simplefilter('always')\n"
            "    from serial_dynamics.core import cabi\n"
            "print(cabi.FASTCALL, cabi._fastcall, [str(x.message)[:80] for x in w])\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.startswith("False None ") and "built from older sources" in out, out
