"""The gpu tests run on a card when the machine has one, else in numba's CUDA simulator.

The top-level test/conftest.py sets NUMBA_ENABLE_CUDASIM=1 where there is no card, when it
is loaded: before anything imports numba. It cannot be set here: pytest loads this file
while it collects this folder, after pytest_sessionstart has imported numba, and numba-cuda
reads the variable through numba's own config, read when numba is imported
(serial_dynamics.gpu.runtime re-reads it before its first import of numba.cuda, but a
numba.cuda imported earlier by something else keeps its mode). Set NUMBA_ENABLE_CUDASIM
yourself to choose (0: the card; bench/gpu_on_card.sh).

Here only a check: where there is no card and numba.cuda is already loaded for a card, say
so at collection rather than fail every test on numba's driver error.
"""
import glob
import os
import sys

HAVE_CARD = bool(glob.glob("/dev/nvidia[0-9]*"))

_cuda = sys.modules.get("numba.cuda")
if (not HAVE_CARD and os.environ.get("NUMBA_ENABLE_CUDASIM") != "0" and _cuda is not None
        and not _cuda.jit.__module__.startswith("numba.cuda.simulator")):
    raise RuntimeError(
        "test/gpu: there is no card and numba.cuda was imported for a card, not for numba's "
        "simulator: something imported numba.cuda before NUMBA_ENABLE_CUDASIM=1 was set (the "
        "top-level test/conftest.py sets it). Run pytest with NUMBA_ENABLE_CUDASIM=1 in the "
        "environment, or find what imports numba.cuda first")
