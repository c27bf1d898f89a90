"""A newcomer's first run compiles only what it runs (issue 22, item 7): ``Robot.warmup()``
(the nodes') loads the single-state kernels, ``warmup(batch=True)`` the batch ones too; the
demo precompiles ``robot.kernels()`` on two cores with progress lines while it waits;
``python -m serial_dynamics.precompile`` still compiles everything. (Cold first-run
times: bench/BENCHMARKS.md, *Cold first run of the demo*.)"""
import subprocess
import sys
import time

import serial_dynamics as sd
from serial_dynamics import precompile
from serial_dynamics.robot.facade import BATCH_KERNELS, SINGLE_KERNELS


def loaded_after(code):
    """The kernels a fresh process has compiled or loaded after ``code``."""
    out = subprocess.run([sys.executable, "-c", "import serial_dynamics as sd\n"
                          "from serial_dynamics import core\n" + code
                          + "\nprint(' '.join(sorted(vars(core.K))))"],
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return set(out.stdout.split())


def test_warmup_loads_only_the_single_state_kernels():
    assert loaded_after("sd.default_robot().warmup()") == set(SINGLE_KERNELS)
    assert loaded_after("sd.builtin_robot('planar_3r').warmup(batch=True)") == set(
        sd.builtin_robot("planar_3r").kernels(batch=True))


def test_warmup_with_kinematics_loads_the_frame_kernels_too():
    frames = {"frame_pose", "frame_jacobian", "frame_acceleration", "frame_pose_one",
              "frame_jacobian_one"}
    assert loaded_after("sd.default_robot().warmup(kinematics=True)") == set(SINGLE_KERNELS) | frames
    floating = loaded_after("sd.load_urdf(sd.builtin_path(), floating_base=True)"
                            ".warmup(batch=True, kinematics=True)")
    assert frames <= floating and "floating_rnea_batch" in floating and "rnea" not in floating


def test_the_kernels_of_a_robot():
    robot = sd.default_robot()
    assert robot.kernels() == SINGLE_KERNELS
    assert robot.kernels(batch=True) == SINGLE_KERNELS + BATCH_KERNELS
    assert robot.kernels(kinematics=True)[-5:] == ("frame_pose", "frame_jacobian",
                                                   "frame_acceleration", "frame_pose_one",
                                                   "frame_jacobian_one")
    planar = sd.builtin_robot("planar_3r").kernels()
    assert "planar_rnea" in planar and not any(k.endswith("batch") for k in planar)
    assert sd.Robot(robot.model, backend="numpy").kernels() == ()


def test_precompile_of_some_kernels_splits_them_as_the_whole(monkeypatch):
    started, loaded = [], []

    class Helper:
        def __init__(self, argv):
            started.append(argv[-1].split(","))

        def wait(self):
            return 0

    monkeypatch.setattr(precompile.subprocess, "Popen", Helper)
    monkeypatch.setattr(precompile, "load", lambda names: loaded.append(list(names)))
    precompile.precompile(jobs=2, names=SINGLE_KERNELS)
    assert started == [["fd"]] and loaded == [["rnea", "rnea_wrench", "crba"], ["fd"]]
    started.clear(), loaded.clear()
    precompile.precompile(jobs=2)                         # everything: the two halves
    assert started == [list(precompile.HALVES[0])]
    assert loaded == [list(precompile.HALVES[1]), list(precompile.HALVES[0])]


def test_ticking_says_how_long_it_waits_and_nothing_when_quick():
    said = []
    with precompile.ticking(said.append, "compiling", first=0.05, every=0.05):
        time.sleep(0.3)
    assert len(said) >= 2 and said[0].startswith("compiling: ") and said[0].endswith(" s ...")
    said.clear()
    with precompile.ticking(said.append, "compiling", first=0.5):
        pass
    assert said == []
