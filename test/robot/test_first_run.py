"""A newcomer's first run compiles only what it runs (issue 22, item 7): ``Robot.warmup()``
(the nodes') loads the single-state kernels, ``warmup(batch=True)`` the batch ones too; the
demo precompiles ``robot.kernels()`` on two cores with progress lines while it waits;
``python -m serial_dynamics.precompile`` still compiles everything. (Cold first-run
times: bench/BENCHMARKS.md, *Cold first run of the demo*.)"""
import os
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


def test_precompile_splits_the_kernels_by_claims_from_both_ends(monkeypatch):
    """The second process walks the list from the front, this one from the back; a kernel is
    compiled by the one process that claimed it, and everything is loaded here after."""
    loaded, took = [], []

    class Helper:                 # the second process: it has claimed its first two already
        def __init__(self, argv):
            assert argv[1:4] == ["-m", "serial_dynamics.precompile", "--claim"], argv
            for name in argv[5].split(",")[:2]:
                open(os.path.join(argv[4], name), "x").close()
                took.append(name)

        def wait(self):
            return 0

    monkeypatch.setattr(precompile.subprocess, "Popen", Helper)
    monkeypatch.setattr(precompile, "load", lambda names: loaded.append(list(names)))
    precompile.precompile(jobs=2, names=SINGLE_KERNELS)
    order = [k for k in precompile.ORDER if k in SINGLE_KERNELS]
    assert sorted(order) == sorted(SINGLE_KERNELS) and took == order[:2]
    assert loaded == [[order[3]], [order[2]], order]      # from the back, then all
    assert sorted(precompile.ORDER) == sorted(set(precompile.ENTRY_POINTS) | {"compiled_euler"}
                                             | set(precompile.CONTACTS))


def test_two_walkers_from_both_ends_compile_each_kernel_once(tmp_path, monkeypatch):
    """Claims are exclusive (O_EXCL) whatever the timing: two threads walking 60 names from
    the two ends, at random speeds, compile each exactly once between them."""
    import random
    import threading
    names = [f"k{i}" for i in range(60)]
    done = []
    monkeypatch.setattr(precompile, "load",
                        lambda ks: (time.sleep(random.random() * 2e-3), done.extend(ks)))
    mine = {}
    threads = [threading.Thread(target=lambda w, ns: mine.__setitem__(w, precompile.claim_and_load(
        ns, str(tmp_path))), args=(w, ns)) for w, ns in (("front", names), ("back", names[::-1]))]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(done) == sorted(names)
    assert sorted(mine["front"] + mine["back"]) == sorted(names)
    assert mine["front"] == names[:len(mine["front"])]     # each took a run from its own end
    assert mine["back"] == names[::-1][:len(mine["back"])]


def test_ticking_says_how_long_it_waits_and_nothing_when_quick():
    said = []
    with precompile.ticking(said.append, "compiling", first=0.05, every=0.05):
        time.sleep(0.3)
    assert len(said) >= 2 and said[0].startswith("compiling: ") and said[0].endswith(" s ...")
    said.clear()
    with precompile.ticking(said.append, "compiling", first=0.5):
        pass
    assert said == []
