"""The integration methods by family, their default tolerances and step, and the error a
diverging run raises (``SimulationError``, with advice that depends on the method)."""
from __future__ import annotations

from ..model.errors import SimulationError  # noqa: F401  (documented here; defined with the others)

ADAPTIVE = ("RK45", "DOP853", "Radau", "BDF", "LSODA")
FIXED_STEP = ("semi_implicit_euler", "symplectic_euler", "rk4", "implicit_midpoint")
METHODS = ADAPTIVE + FIXED_STEP
IMPLICIT = ("Radau", "BDF", "LSODA", "implicit_midpoint")
DEFAULT_RTOL, DEFAULT_ATOL, DEFAULT_DT = 1e-6, 1e-9, 1e-3


def on_a_group(robot) -> bool:
    """Whether q has coordinates beyond v's (nq > nv: a floating base's unit quaternion), so
    that q moves on a Lie group, in the robot's chart (``group.py``), not as q + dt v: what sim/
    asks of the configuration space instead of the kind of robot."""
    return robot.nq != robot.nv


def advice(method, dt=None):
    """What to try when ``method`` (with step ``dt``) diverged or failed."""
    if method in FIXED_STEP:
        smaller = f"a smaller step (dt = {dt / 10:.3g} s)" if dt else "a smaller step"
        alt = ("'Radau' or a smaller step" if method == "implicit_midpoint"
               else "the implicit method 'implicit_midpoint' (or 'Radau')")
        return f"Try {smaller} or {alt}."
    if method in ("RK45", "DOP853"):
        return "Try a tighter tolerance (rtol) or an implicit method ('Radau', 'BDF', 'LSODA')."
    return "Try a tighter tolerance (rtol) or a smaller max_step."
