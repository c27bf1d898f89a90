"""A single-state entry point behind one plain C ABI, called from ``_fastcall.c``.

Each single-state entry point (``dispatch.SINGLE_STATE``) has one signature of C-contiguous
writable float64 arrays and int64s. ``entry`` compiles, beside the njit kernel, a
``numba.cfunc`` wrapper (numba's documented C callback: its ``.address``, ``cache=True``)
of the one C signature every entry point shares::

    int64 f(double **data, int64 *dims, int64 *ints)

``data`` holds the arrays' data pointers in argument order, ``dims`` their shapes one after
the other, ``ints`` the int64 arguments; the wrapper rebuilds each array with
``numba.carray`` (the kernel's own types: C layout, writable) and calls the kernel. Each
wrapper's few lines are generated from the signature (``wrapper_source``) and compiled as
if they were this file's, so that numba caches them next to the kernels.

``_fastcall.Entry`` checks in C that the arguments are exactly of the signature and calls
the address; any other arguments (a list, a batch, another dtype or layout, a read-only
array, a bool or an np.int32 for an int) get ``OTHER_TYPES`` back without numba being
called, and ``Robot`` takes its general path. Without the extension (a build without a C
compiler, or ``SERIAL_DYNAMICS_FASTCALL=0``) ``Entry`` below makes the same check in Python
and calls the njit kernel: the same machine code's arithmetic, the same bits
(``test/core/test_fastcall.py`` replays every call of eight robots both ways).

Exceptions: a cfunc cannot hand a Python exception to its caller (numba prints it as
unraisable and returns garbage). So the wrapper catches any exception (numba's ``try:
... except Exception``) and returns ``RAISED``, a value no entry point returns; ``Entry``
then calls the njit kernel with the same arguments, which raises the exception as numba
raises it. (core/ raises only numba's ZeroDivisionError; the facade checks its inputs
first.)
"""
import os
import warnings
from contextlib import nullcontext

import numpy as np
from numba import carray, cfunc, njit, types

from .cache import in_folder
from .signatures import f8, i8
from .status import OTHER_TYPES

ABI = 2                      # _fastcall.c's calling convention (its module constant ABI)
try:
    from . import _fastcall
except ImportError:          # built without a C compiler: the Python Entry below
    _fastcall = None
if _fastcall is not None and getattr(_fastcall, "ABI", None) != ABI:
    # a build from older sources (an editable install not rebuilt after a pull) would call
    # the cfunc addresses by another convention and crash: the Python Entry instead
    warnings.warn("serial_dynamics.core._fastcall was built from older sources; single calls "
                  "take the slower Python check until it is rebuilt (pip install -e . again, "
                  "or python setup.py build_ext --inplace)", RuntimeWarning, stacklevel=2)
    _fastcall = None
FASTCALL = _fastcall is not None and os.environ.get("SERIAL_DYNAMICS_FASTCALL", "1") != "0"

RAISED = -(2**63)            # the wrapper's return when the kernel raised (INT64_MIN)
C_SIGNATURE = i8(types.CPointer(types.CPointer(f8)), types.CPointer(i8), types.CPointer(i8))


def spec(sig):
    """Per argument of ``sig``: "1", "2" or "3" (a C-contiguous writable float64 array of
    that ndim) or "i" (an int64). A ValueError names any other argument type."""
    out = ""
    for k, t in enumerate(sig.args):
        if t == i8:
            out += "i"
        elif (isinstance(t, types.Array) and t.dtype == f8 and t.layout == "C" and t.mutable
              and t.aligned and 1 <= t.ndim <= 3):
            out += str(t.ndim)
        else:
            raise ValueError(f"core.cabi: argument {k} of {sig} is {t}; an entry point takes "
                             "C-contiguous writable float64 arrays (1 to 3 dimensions) and int64s")
    if sig.return_type != i8:
        raise ValueError(f"core.cabi: {sig} returns {sig.return_type}; an entry point returns int64")
    return out


def wrapper_source(name, spec):
    """The Python source of ``name``'s cfunc wrapper for the argument ``spec``."""
    args, d, a, i = [], 0, 0, 0
    for c in spec:
        if c == "i":
            args.append(f"ints[{i}]")
            i += 1
        else:
            shape = ", ".join(f"dims[{d + j}]" for j in range(int(c)))
            args.append(f"carray(data[{a}], ({shape},))")
            d, a = d + int(c), a + 1
    return (f"def cabi_{name}(data, dims, ints):\n"
            f"    try:\n"
            f"        return kernel({', '.join(args)})\n"
            f"    except Exception:\n"
            f"        return RAISED\n")


def wrapper(name, kernel, spec, cache=True):
    """The compiled cfunc wrapper of ``kernel`` (``.address``: its C function)."""
    scope = {"__name__": __name__, "kernel": kernel, "carray": carray, "RAISED": RAISED}
    exec(compile(wrapper_source(name, spec), __file__, "exec"), scope)   # noqa: S102
    return cfunc(C_SIGNATURE, cache=cache)(scope[f"cabi_{name}"])


def entry(name, func, sig, nogil=False, cache=True, folder="core"):
    """Entry point ``name``: ``func`` compiled for ``sig`` (the njit kernel) and called
    through its cfunc wrapper when the arguments are exactly of ``sig``'s types; OTHER_TYPES
    otherwise. A ``_fastcall.Entry`` with the extension, else the Python ``Entry``.
    With ``cache=True`` both are cached in ``cache.folder(folder)`` ("core" for core/'s
    functions, "contacts" for contacts/'): a folder keyed on the sources they include."""
    kind = spec(sig)
    with in_folder(folder) if cache else nullcontext():
        kernel = njit(cache=cache, nogil=nogil)(func)      # compiled for sig by the wrapper
        if not FASTCALL:
            kernel.compile(sig)
            return Entry(kernel, kind)
        return _fastcall.Entry(kernel, wrapper(name, kernel, kind, cache).address, kind)


class Entry:
    """``_fastcall.Entry``'s checks in Python: ``kernel(*args)`` when ``args`` are exactly
    of the signature ``spec``, else OTHER_TYPES (without the extension)."""

    def __init__(self, kernel, spec):
        self.kernel, self.spec = kernel, spec

    def __call__(self, *args):
        if len(args) != len(self.spec):
            raise TypeError(f"{self.kernel.__name__} takes {len(self.spec)} arguments "
                            f"({len(args)} given)")
        for x, c in zip(args, self.spec):
            if not (_int64(x) if c == "i" else _array(x, int(c))):
                return OTHER_TYPES
        return self.kernel(*args)

    def __repr__(self):
        return f"<cabi.Entry {self.spec} of {self.kernel!r}>"


def _array(x, ndim):
    """Whether ``x`` is an ndarray (not a subclass) of float64, in native byte order,
    C-contiguous, aligned, writable and of ``ndim`` dimensions."""
    return (type(x) is np.ndarray and x.dtype == np.float64 and x.dtype.isnative
            and x.ndim == ndim and x.flags.c_contiguous and x.flags.aligned
            and x.flags.writeable)


def _int64(x):
    """Whether ``x`` is a Python int (not a bool) or an np.int64 that fits an int64."""
    return (type(x) is int and -2**63 <= x < 2**63) or type(x) is np.int64
