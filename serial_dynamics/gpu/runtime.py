"""The CUDA side of ``serial_dynamics.gpu``: numba-cuda imported once (guarded), the
batches moved to and from the card, the memory check and the launch.

numba-cuda is the ``[gpu]`` extra; without it this module raises an ImportError that
names the extra. ``NUMBA_ENABLE_CUDASIM=1``, in the environment when ``numba.cuda`` is
first imported, runs every kernel in numba's CUDA simulator, on the CPU, one Python thread
per CUDA thread: the tests run so on machines without a card.

numba-cuda (0.30) reads the variable through numba's own ``numba.core.config``, which numba
reads when ``numba`` itself is imported and again only when it compiles something: a
variable set after ``import numba`` (``import serial_dynamics`` imports it) would be missed
at the first import of ``numba.cuda``, which would then look for a card. So the
configuration is re-read from the environment here, just before that first import.
"""
import functools
import importlib.util
import math
import sys

import numpy as np

INSTALL = "pip install 'serial_dynamics[gpu]'"
if importlib.util.find_spec("numba_cuda") is None:
    raise ImportError(
        "serial_dynamics.gpu needs numba-cuda, numba's CUDA target, which is not installed: "
        f"{INSTALL} (on a machine without a card, numba-cuda alone runs it in numba's "
        "simulator with NUMBA_ENABLE_CUDASIM=1)")
if not hasattr(np, "row_stack"):
    # numba-cuda 0.30 overloads np.row_stack, which NumPy 2.5 removed (an alias of vstack):
    # without it, its first kernel compile fails with an AttributeError
    np.row_stack = np.vstack

if "numba.cuda" not in sys.modules:
    import numba.core.config  # noqa: E402
    numba.core.config.reload_config()    # NUMBA_ENABLE_CUDASIM as the environment has it now

from numba import cuda  # noqa: E402  (after the guards above)

# the mode numba.cuda was imported in (its jit is the simulator's or the card's), not the
# variable, which may have changed since
SIMULATOR = cuda.jit.__module__.startswith("numba.cuda.simulator")
THREADS = 128            # threads per block (one thread per state)


def free_bytes():
    """Free memory on the current card, in bytes (the simulator says inf)."""
    return cuda.current_context().get_memory_info()[0]


@functools.lru_cache(maxsize=None)
def _card_visible():
    return bool(cuda.is_available())


def require_card():
    """A RuntimeError that says what to do where neither a card nor the simulator is."""
    if not SIMULATOR and not _card_visible():
        raise RuntimeError(
            "serial_dynamics.gpu: no CUDA card is visible (numba.cuda.is_available() is "
            "False). Run on a machine with an NVIDIA GPU and its driver, or set "
            "NUMBA_ENABLE_CUDASIM=1 before the first import of numba.cuda to run the "
            "kernels in numba's simulator (slow: for tests)")


def on_device(x):
    """Whether ``x`` lives on the card: anything with ``__cuda_array_interface__`` (CuPy,
    PyTorch, numba device arrays), or a simulator device array."""
    return hasattr(x, "__cuda_array_interface__") or bool(getattr(x, "__cuda_ndarray__", False))


class Batch:
    """The state arrays of one call, checked: ``N`` states, each array (N, its width), on
    the card (``arrays``), and whether the results go back to the host (every input was a
    NumPy array) or stay on the card (some input was already there). ``named``:
    (name, array, width or a tuple of the widths it may have)."""

    def __init__(self, op, named):
        self.N = None
        checked = [(name, _checked(op, name, x, width)) for name, x, width in named]
        for name, x in checked:
            if self.N is None:
                self.N = x.shape[0]
            elif x.shape[0] != self.N:
                first = checked[0]
                raise ValueError(f"{op}: {name} has {x.shape[0]} states and {first[0]} has "
                                 f"{self.N}; give every array the same number of rows")
        self.host = not any(on_device(x) for _, x in checked)
        self._in = [x for _, x in checked]

    def to_card(self, out_numbers, op):
        """The inputs on the card (host arrays: one transfer each), after checking that they
        and the results (``out_numbers`` float64 a state) fit its free memory."""
        require_card()
        host_numbers = sum(x.shape[1] for x in self._in if not on_device(x))
        need = 8 * self.N * (host_numbers + out_numbers)
        free = free_bytes()
        if need > free:
            per_state = 8 * (host_numbers + out_numbers)
            raise MemoryError(
                f"{op}: a batch of {self.N} states needs {_size(need)} on the card "
                f"({per_state} bytes a state: inputs and results in float64) and "
                f"{_size(free)} are free; split it into batches of at most "
                f"{int(free // per_state)} states")
        return [x if on_device(x) else cuda.to_device(x) for x in self._in]

    def result(self, out):
        """The result as the inputs came: NumPy (one transfer back) or on the card."""
        return out.copy_to_host() if self.host else out


def _size(b):
    for unit, scale in (("GiB", 2**30), ("MiB", 2**20)):
        if b >= scale:
            return f"{b / scale:.1f} {unit}"
    return f"{b:.0f} bytes"


def _checked(op, name, x, width):
    widths = width if isinstance(width, tuple) else (width,)
    if on_device(x):
        if not SIMULATOR and not hasattr(x, "copy_to_host"):
            x = cuda.as_cuda_array(x)            # a view of CuPy's, PyTorch's memory: no copy
    elif not isinstance(x, np.ndarray):
        raise TypeError(f"{op}: {name} is a {type(x).__name__}; pass a NumPy array (N, "
                        f"{widths[0]}) of float64 or a device array (__cuda_array_interface__)")
    if x.dtype != np.float64:
        raise TypeError(f"{op}: {name} has dtype {x.dtype}; the kernels take float64 "
                        f"(convert once: {name}.astype(np.float64))")
    if len(x.shape) != 2 or x.shape[1] not in widths:
        shape = " or ".join(f"(N, {w})" for w in widths)
        raise ValueError(f"{op}: {name} has shape {tuple(x.shape)}; expected {shape}: "
                         f"N states of the robot's {widths[0]} coordinates")
    if not on_device(x):
        bad = ~np.isfinite(x)
        if bad.any():
            row, col = np.argwhere(bad)[0]
            raise ValueError(f"{op}: {name}[{row}, {col}] is {x[row, col]}; every entry must "
                             "be finite")
        x = np.ascontiguousarray(x)
    return x


def launch(kernel, N, *args):
    """``kernel`` over ``N`` states, one thread each, ``THREADS`` a block (one in the
    simulator: it runs a block's threads as Python threads that contend for one lock at
    every device-function call, 3 threads 30x slower than 3 blocks of one)."""
    if N == 0:
        return
    threads = 1 if SIMULATOR else min(THREADS, N)
    kernel[math.ceil(N / threads), threads](*args)
