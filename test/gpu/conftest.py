"""The gpu tests run on a card when the machine has one, else in numba's CUDA simulator.

numba reads NUMBA_ENABLE_CUDASIM once, when ``numba.cuda`` is first imported. This conftest
is imported when pytest collects this folder, before any of its test modules, and nothing
the rest of the suite imports loads ``numba.cuda`` (the package never does; only
``serial_dynamics.gpu`` does): so setting the variable here holds for the whole pytest
process. Set NUMBA_ENABLE_CUDASIM yourself to choose (0: the card).
"""
import glob
import os
import sys

HAVE_CARD = bool(glob.glob("/dev/nvidia[0-9]*"))

if "NUMBA_ENABLE_CUDASIM" not in os.environ and not HAVE_CARD:
    if "numba.cuda" in sys.modules:
        raise RuntimeError(
            "test/gpu: numba.cuda was imported before this folder's conftest set "
            "NUMBA_ENABLE_CUDASIM=1, and there is no card: whatever imported it must not, or "
            "run pytest with NUMBA_ENABLE_CUDASIM=1 in the environment")
    os.environ["NUMBA_ENABLE_CUDASIM"] = "1"
