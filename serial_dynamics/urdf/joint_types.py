"""URDF joint types as the model's joints: the one place that knows them.

The model and every algorithm know two elementary joints, each with one coordinate along
or about one axis of its frame (``joints.py``: REVOLUTE, PRISMATIC; Featherstone 2008,
Table 4.1). A URDF joint type is a sequence of them, the first at the joint's <origin>,
each next one at the previous one's frame, the last one's body being the child link:

    revolute, continuous   one revolute joint about <axis>  (continuous: no position limits)
    prismatic              one prismatic joint along <axis>
    planar                 motion in the plane normal to <axis> (URDF): <name>/x and
                           <name>/y, prismatic along the plane's axes e_x, e_y, then
                           <name>/theta, continuous about <axis>; no position limits

A planar joint's coordinates are those of MoveIt's planar virtual joint: x, y in the
parent's plane axes and the angle theta (q = [x, y, theta], qd = [xd, yd, thetad]);
Pinocchio's ``JointModelPlanar`` has q = [x, y, cos theta, sin theta] and v = [R(theta)^T
(xd, yd), thetad] (test/urdf/test_planar_joint.py maps one to the other). The plane's
axes: e_x the URDF frame's x (its y where the axis is within 25 degrees of x) made
normal to the axis, e_y = axis x e_x; e_x, e_y = x, y for <axis xyz="0 0 1">.

``ELEMENTARY`` maps each type to the function that lists its elementary joints, so a URDF
type is added here alone: the loader asks this table, and the recursions, batches,
derivatives, the GPU and the nodes see elementary joints only (docs/architecture.md,
"Add a joint type").
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Elementary(NamedTuple):
    """One elementary joint of a URDF joint: its name suffix ('' for a one-coordinate
    type), its model type ('revolute', 'continuous' or 'prismatic'), its unit axis in the
    URDF joint's frame, and whether the URDF's <limit lower/upper> bound it."""
    suffix: str
    type: str
    axis: np.ndarray
    limited: bool


def _one(joint_type):
    """A one-coordinate type: itself, about or along the URDF's axis."""
    return lambda axis: [Elementary("", joint_type, axis, joint_type != "continuous")]


def _planar(n):
    """x, y along the plane's axes e_x, e_y = n x e_x, then theta about n."""
    seed = np.eye(3)[0 if abs(n[0]) < 0.9 else 1]
    ex = seed - (seed @ n) * n
    ex /= np.linalg.norm(ex)
    return [Elementary("/x", "prismatic", ex, False),
            Elementary("/y", "prismatic", np.cross(n, ex), False),
            Elementary("/theta", "continuous", n, False)]


ELEMENTARY = {
    "revolute": _one("revolute"),
    "continuous": _one("continuous"),
    "prismatic": _one("prismatic"),
    "planar": _planar,
}
MOVABLE = tuple(ELEMENTARY)          # the URDF types the model can hold


def elementary_joints(joint_type, axis):
    """The elementary joints of a URDF joint of ``joint_type`` whose <axis> is the unit
    vector ``axis``."""
    return ELEMENTARY[joint_type](np.asarray(axis, dtype=float))
