"""The command line as a new user meets it: help text, warnings, what `info` shows."""
import subprocess
import sys
import warnings

import pytest

from pin_reference import erd

import serial_dynamics as sd
from serial_dynamics.cli import main


def run(*args):
    return subprocess.run([sys.executable, "-m", "serial_dynamics.cli", *args],
                          capture_output=True, text=True, timeout=300)


def test_help_is_plain_text_and_names_every_option():
    out = run("--help").stdout
    assert "``" not in out and "info" in out and "simulate" in out
    sub = run("info", "--help").stdout
    assert "--base-link LINK" in sub and "first link of the model" in sub
    assert "--tip-link LINK" in sub and "last link of one chain" in sub


def test_a_held_joint_warning_is_one_clean_line():
    path = erd("panda_description/urdf/panda.urdf")
    out = run("info", path, "--base-link", "panda_link0", "--tip-link", "panda_link8")
    assert out.returncode == 0, out.stderr
    lines = [x for x in out.stderr.splitlines() if x.strip()]
    assert len(lines) == 1 and lines[0].startswith("serial-dynamics: HeldJointsWarning: ")
    assert "panda_finger_joint1" in lines[0] and "warnings.warn" not in out.stderr


def test_info_names_the_real_arm_terms(capsys):
    assert main(["info", sd.builtin_path("planar_3r")]) == 0
    assert "planar chain" in capsys.readouterr().out
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert main(["info"]) == 0
    out = capsys.readouterr().out
    assert "Robot('ur5e'" in out and "planar" not in out and "armature" not in out


@pytest.mark.parametrize("bad", [["info", "/nonexistent.urdf"]])
def test_errors_are_one_line_with_status_2(bad):
    out = run(*bad)
    assert out.returncode == 2 and out.stderr.startswith("serial-dynamics: error:")
    assert "Traceback" not in out.stderr
