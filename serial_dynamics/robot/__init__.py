"""The facade users call: ``Robot`` and its kinds, each overriding what it changes.

    facade.py       Robot: inputs checked, calls sent to the compiled core or the reference
    mimic.py        MimicRobot: the reduced system of a chain with mimic joints
    planar.py       PlanarRobot: a planar chain on the planar fast path
    base_motion.py  BaseMotion: a base with known motion (a per-call input)
    batches.py      what every batch call shares (kernel rows, the split over the cores)
    regressor.py    Robot.regressor / inertial_parameters: batching, kernels, column names
    derivatives.py  Robot's dynamics derivatives: batching and kernels
"""
from .base_motion import BaseMotion
from .facade import Robot
from .mimic import MimicRobot
from .planar import PlanarRobot

__all__ = ["Robot", "MimicRobot", "PlanarRobot", "BaseMotion"]
