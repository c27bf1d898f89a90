"""The dynamics node (``dynamics.py``: services and the inverse-dynamics topic pair) under
its old name, ``inverse_dynamics``, for the launch files and scripts that use it.

    python -m serial_dynamics.ros.inverse_dynamics
    ros2 run serial_dynamics inverse_dynamics
"""
from __future__ import annotations

from . import common
from .dynamics import PARAMETERS, Dynamics

__all__ = ["PARAMETERS", "InverseDynamics", "main"]


class InverseDynamics(Dynamics):
    NAME = "inverse_dynamics"


def main(args=None):
    return common.run(InverseDynamics, args, events=True)


if __name__ == "__main__":
    raise SystemExit(main())
