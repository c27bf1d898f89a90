"""The facade users call: ``Robot`` and its kinds, each overriding what it changes.

    facade.py       Robot: inputs checked, calls sent to the compiled core or the reference;
                    its kinds (FloatingRobot, MimicRobot, PlanarRobot, FloatingMimicRobot)
                    and kind_of, the one place that chooses the kind a model needs
    mimic.py        Mimic: what MimicRobot overrides (the reduced system of mimic joints)
    planar.py       Planar: what PlanarRobot overrides (the planar fast path)
    floating.py     Floating: what FloatingRobot overrides (a free-floating base)
    common.py       what they share: kernel flags, forward-dynamics methods, out=
    base_motion.py  BaseMotion: a base with known motion (a per-call input)
    batches.py      what every batch call shares (kernel rows, the split over the cores)
    regressor.py    Robot.regressor / inertial_parameters: batching, kernels, column names
    derivatives.py  Robot's dynamics derivatives: batching and kernels
    kinematics.py   frame poses, Jacobians and accelerations, center of mass, momentum,
                    the Coriolis matrix: the compiled kernels' calls for every kind
    task_space.py   Lambda, J-bar (Khatib; every backend) and the NumPy backend's frame
                    acceleration
    wrenches.py     wrenches on any links: the sum of J_k^T w_k
    charts.py       the configuration space's chart for integrators (robot.chart): R^n,
                    and SE(3) x R^n of a floating base
"""
from .base_motion import BaseMotion
from .facade import FloatingMimicRobot, FloatingRobot, MimicRobot, PlanarRobot, Robot, kind_of

__all__ = ["Robot", "FloatingRobot", "MimicRobot", "PlanarRobot", "FloatingMimicRobot", "BaseMotion",
           "kind_of"]
