"""core.dispatch: the entry points as explicit attributes of K, the named status codes, the
numba pin, and numba through its documented interfaces only."""
import os

import numba
import numpy as np

import serial_dynamics as sd
from serial_dynamics.core import dispatch
from serial_dynamics.core import flags as F
from serial_dynamics.core.dispatch import (BAD_LENGTH, ENTRY_POINTS, K, NOT_FINITE, NUMBA_SUPPORTED,
                                           OK, OTHER_TYPES)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_every_entry_point_is_an_attribute_of_the_class():
    declared = {k for k, v in vars(type(K)).items() if isinstance(v, dispatch._EntryPoint)}
    assert declared == set(ENTRY_POINTS)


def test_status_codes_are_distinct_and_returned_by_name():
    assert len({OK, NOT_FINITE, BAD_LENGTH, OTHER_TYPES, dispatch.NOT_CONVERGED}) == 5
    robot = sd.default_robot()
    P, q, o = robot._P, np.full(6, 0.3), np.empty(6)
    assert K.rnea(P, q, q, q, F.QD | F.QDD, o) == OK
    np.testing.assert_array_equal(o, robot.inverse_dynamics(q, q, q))
    assert K.rnea(P, np.r_[q[:5], np.nan], q, q, F.QD | F.QDD, o) == NOT_FINITE
    assert K.rnea(P, q, q, q, F.QD | F.QDD, np.empty(5)) == BAD_LENGTH
    assert K.rnea(P, list(q), q, q, F.QD | F.QDD, o) == OTHER_TYPES


def test_numba_pinned_to_the_supported_range():
    with open(os.path.join(ROOT, "setup.py")) as f:
        assert f'"numba{NUMBA_SUPPORTED}"' in f.read()
    low, high = (tuple(int(x) for x in b.lstrip("<>=").split(".")) for b in NUMBA_SUPPORTED.split(","))
    assert low <= tuple(int(x) for x in numba.__version__.split(".")[:2]) < high


# what the core used to read of numba's internals (its dispatcher's compile results, its
# calling convention, a replaced private method); none of it may come back
INTERNALS = ("overloads[", "call_conv", "fndesc", "_compile_for_args", "get_pointer_to_function")


def test_the_core_uses_no_numba_internals():
    core = os.path.join(ROOT, "serial_dynamics", "core")
    for name in sorted(os.listdir(core)):
        if name.endswith((".py", ".c")):
            with open(os.path.join(core, name)) as f:
                text = f.read()
            assert [w for w in INTERNALS if w in text] == [], name
