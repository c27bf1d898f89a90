"""serial_dynamics.gpu's refusals and its import: bad arrays, a batch too large for the
card, a floating base; numba-cuda missing; no card and no simulator; importing
serial_dynamics loads no numba.cuda, and the simulator's variable set after it holds."""
import glob
import os
import subprocess
import sys

import numpy as np
import pytest

import serial_dynamics as sd

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _run(code, **env_vars):
    """``code`` in a fresh interpreter; NUMBA_ENABLE_CUDASIM only as ``env_vars`` say."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_ENABLE_CUDASIM"}
    env.update(env_vars, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, env=env, cwd=ROOT)


def test_importing_serial_dynamics_loads_no_numba_cuda_and_the_simulator_variable_holds():
    """Importing the package loads numba but not numba.cuda. numba-cuda reads
    NUMBA_ENABLE_CUDASIM through numba's config, read at ``import numba``: set after it (here
    after ``import serial_dynamics``) and before the first import of numba.cuda, it must
    still choose the simulator (the whole suite imports numba before it collects test/gpu:
    issue 27's 13 failures on numba's driver error)."""
    p = _run("import os, sys, numpy as np, serial_dynamics as sd, serial_dynamics.sweep, "
             "serial_dynamics.sim; print('numba' in sys.modules, 'numba.cuda' in sys.modules); "
             "import importlib.util as u; u.find_spec('numba_cuda') or sys.exit(0); "
             "os.environ['NUMBA_ENABLE_CUDASIM'] = '1'; "
             "from serial_dynamics import gpu; r = sd.default_robot(); "
             "print(gpu.SIMULATOR, gpu.mass_matrix(r, np.zeros((1, r.dof))).shape)")
    assert p.returncode == 0, p.stderr[-3000:]
    lines = p.stdout.splitlines()
    assert lines[0] == "True False"                     # numba, not numba.cuda
    if len(lines) > 1:                                  # with numba-cuda: the simulator
        assert lines[1] == "True (1, 6, 6)"


def test_without_numba_cuda_the_import_error_names_the_extra():
    p = _run("import importlib.util as u; find = u.find_spec; "
             "u.find_spec = lambda name, *a: None if name == 'numba_cuda' else find(name, *a); "
             "from serial_dynamics import gpu")
    assert p.returncode != 0
    assert "ImportError: serial_dynamics.gpu needs numba-cuda" in p.stderr
    assert "pip install 'serial_dynamics[gpu]'" in p.stderr


pytest.importorskip("numba_cuda")
from serial_dynamics import gpu  # noqa: E402
from serial_dynamics.gpu import runtime  # noqa: E402


@pytest.mark.skipif(bool(glob.glob("/dev/nvidia[0-9]*")), reason="a card is here")
def test_without_a_card_or_the_simulator_the_error_says_what_to_do():
    p = _run("import numpy as np, serial_dynamics as sd; from serial_dynamics import gpu; "
             "r = sd.default_robot(); gpu.inverse_dynamics(r, *np.zeros((3, 2, r.dof)))",
             NUMBA_ENABLE_CUDASIM="0")
    assert p.returncode != 0
    assert "RuntimeError: serial_dynamics.gpu: no CUDA card is visible" in p.stderr, p.stderr[-3000:]
    assert "NUMBA_ENABLE_CUDASIM=1" in p.stderr


ROBOT = sd.load_urdf(sd.builtin.ur5e_urdf())
Q, QD = ROBOT.random_state(0, batch=3)


@pytest.mark.parametrize("bad, exc, words", [
    (Q.astype(np.float32), TypeError, "QD has dtype float32; the kernels take float64 "
                                      "(convert once: QD.astype(np.float64))"),
    (Q.astype(np.int64), TypeError, "QD has dtype int64"),
    (Q.tolist(), TypeError, "QD is a list; pass a NumPy array (N, 6) of float64"),
    (Q[:, :5], ValueError, "QD has shape (3, 5); expected (N, 6)"),
    (Q[0], ValueError, "QD has shape (6,); expected (N, 6)"),
    (Q[:2], ValueError, "QD has 2 states and Q has 3"),
    (np.where(np.arange(6) == 4, np.nan, Q), ValueError, "QD[0, 4] is nan; every entry must be finite"),
])
def test_bad_arrays_are_refused_by_name(bad, exc, words):
    with pytest.raises(exc) as e:
        gpu.inverse_dynamics(ROBOT, Q, bad, Q)
    assert words in str(e.value)


def test_a_batch_too_large_for_the_card_names_its_size(monkeypatch):
    monkeypatch.setattr(runtime, "free_bytes", lambda: 1000.0)
    with pytest.raises(MemoryError) as e:
        gpu.mass_matrix(ROBOT, Q)
    # 3 states x (6 inputs + 36 results) x 8 bytes = 1008 bytes > 1000 free
    msg = str(e.value)
    assert "a batch of 3 states needs 1008 bytes on the card" in msg and "336 bytes a state" in msg
    assert "split it into batches of at most 2 states" in msg
    monkeypatch.setattr(runtime, "free_bytes", lambda: 1008.0)
    assert gpu.mass_matrix(ROBOT, Q).shape == (3, 6, 6)


def test_a_floating_base_takes_its_own_widths():
    robot = sd.load_urdf(sd.builtin.ur5e_urdf(), floating_base=True)
    with pytest.raises(ValueError, match=r"Q has shape \(1, 12\); expected \(N, 13\)"):
        gpu.mass_matrix(robot, np.zeros((1, robot.nv)))
    with pytest.raises(ValueError, match=r"TAU has shape \(1, 5\); expected \(N, 12\) or "
                                         r"\(N, 6\)"):
        gpu.forward_dynamics(robot, np.zeros((1, robot.nq)), np.zeros((1, robot.nv)),
                             np.zeros((1, 5)))


def test_an_empty_batch_gives_an_empty_result():
    assert gpu.inverse_dynamics(ROBOT, Q[:0], Q[:0], Q[:0]).shape == (0, 6)


def test_a_device_array_of_another_dtype_is_refused():
    from numba import cuda
    with pytest.raises(TypeError, match="QDD has dtype float32"):
        gpu.inverse_dynamics(ROBOT, cuda.to_device(Q), cuda.to_device(QD),
                             cuda.to_device(Q.astype(np.float32)))
