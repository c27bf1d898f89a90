"""python -m serial_dynamics.core: compile (or load) every kernel once, filling the cache."""
import time

from serial_dynamics.core import ENTRY_POINTS, K

t0 = time.perf_counter()
K.load_all()
print(f"compiled or loaded {len(ENTRY_POINTS)} kernels in {time.perf_counter() - t0:.1f} s")
