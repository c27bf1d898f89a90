"""Every kernel compiles for the CUDA target itself, not only in the simulator (which runs
the Python source): PTX for an H100 (sm_90) through NVVM, in a process without the
simulator. Needs NVVM and NVRTC (the [gpu] extra's toolkit, or the nvidia-nvvm and
nvidia-cuda-nvrtc wheels), not a card: skipped where they are missing."""
import os
import subprocess
import sys

import pytest

pytest.importorskip("numba_cuda")
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

PROBE = r"""
import sys, types
from numba import cuda, float64, int64
try:
    cuda.compile_ptx(lambda x: x + 1.0, (float64,), device=True, cc=(9, 0))
except Exception as exc:            # no NVVM or NVRTC here
    print("NO TOOLKIT:", type(exc).__name__, exc); sys.exit(77)
if not cuda.is_available():         # device functions ask the current card for its
    import numba.cuda.dispatcher as d     # compute capability: say sm_90
    d.get_current_device = lambda: types.SimpleNamespace(compute_capability=(9, 0))
from serial_dynamics.gpu import crba, derivatives, forward, rnea, rollouts
A1, A2, A3, I1 = float64[::1], float64[:, ::1], float64[:, :, ::1], int64[::1]
for mod, outs in ((rnea, (A2, A2, A2, A2)), (crba, (A2, A3)), (forward, (A2, A2, A2, A2))):
    # a 3-joint chain; a tree of 4 joints with mimic joints (3 coordinates); a floating
    # base's instantaneous chain (6 + 2 bodies): every branch of the specializations
    # compiled once (few joints: NVVM unrolls the loops over them)
    for key in ((3, 3, True, False, False), (4, 3, False, True, False), (8, 8, True, False, True)):
        ptx, _ = cuda.compile_ptx(mod.kernel(*key).py_func, (A2, I1, I1, A1, A1, A2) + outs,
                                  cc=(9, 0))
        assert ".entry" in ptx and "sm_90" in ptx
        print(mod.__name__, key, "ok")
for key in ((3, 3, False), (4, 2, True)):      # chains only
    ptx, _ = cuda.compile_ptx(derivatives.kernel(*key).py_func,
                              (A2, I1, I1, A1, A1, A2, A2, A2, A3, A3), cc=(9, 0))
    assert ".entry" in ptx
    print("derivatives", key, "ok")
for key in ((3, True, "computed_torque", 7), (4, False, "gravity_compensation", 1)):
    ptx, _ = cuda.compile_ptx(rollouts.kernel(*key).py_func,
                              (A2, I1, A3) + (A2,) * 6 + (A1,) * 5 + (A2, float64, int64)
                              + (A2,) * 3, cc=(9, 0))
    assert ".entry" in ptx
    print("rollouts", key, "ok")
"""


def test_every_kernel_compiles_to_ptx():
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="0",
               PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True,
                       timeout=300, env=env, cwd=ROOT)
    if p.returncode == 77:
        pytest.skip(p.stdout.strip())
    assert p.returncode == 0, p.stdout + p.stderr[-3000:]
    assert p.stdout.count(" ok") == 13
