"""The core library never imports rclpy; config/*.yaml list the nodes' real defaults."""
import os
import subprocess
import sys

import pytest
import yaml

from serial_dynamics.ros import (computed_torque_controller, dynamics, external_torque_observer,
                                 inverse_dynamics, parameters, simulator)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_core_library_does_not_import_rclpy():
    code = ("import sys, numpy as np, serial_dynamics as sd, serial_dynamics.cli, "
            "serial_dynamics.sim.driver, serial_dynamics.trajectory\n"
            "r = sd.default_robot(); r.warmup(); r.inverse_dynamics(np.zeros(6), np.zeros(6), np.zeros(6))\n"
            "bad = sorted(m for m in sys.modules if m.startswith(('rclpy', 'rcl_', 'std_msgs', 'sensor_msgs')))\n"
            "assert not bad, bad")
    subprocess.run([sys.executable, "-c", code], check=True)


def _flatten(d, prefix=""):
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flatten(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


@pytest.mark.parametrize("module", [simulator, dynamics, inverse_dynamics,
                                    computed_torque_controller, external_torque_observer])
def test_config_files_list_every_parameter_with_its_default(module):
    name = module.__name__.rsplit(".", 1)[1]
    with open(os.path.join(ROOT, "config", f"{name}.yaml")) as fh:
        listed = _flatten(yaml.safe_load(fh)[name]["ros__parameters"])
    expected = {k: ([] if v is None else v) for k, v in parameters.defaults(module.PARAMETERS).items()}
    assert listed == expected
