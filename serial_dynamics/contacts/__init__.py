"""Contacts: bilateral constrained dynamics (feet, hands, closed loops) and contact inverse
dynamics for whole-body control, in NumPy on the facade's public methods (mass matrix,
bias torques, link poses, Jacobians and bias accelerations); docs/contacts.md.

- ``contact.py``: ``Contact`` (a point or a frame of a link, or a loop between two links)
  and the checks of a set of them;
- ``collision.py``: ``contact_points``, from the URDF's ``<collision>`` spheres and boxes;
- ``jacobians.py``: the stacked contact Jacobian, its J-dot v and the position errors;
- ``constrained.py``: the KKT system by its Delassus matrix, proximal iterations;
- ``dense.py``: M's Cholesky factor inverted (the solves as products, on one thread);
- ``inverse.py`` and ``friction.py``: contact inverse dynamics, minimum-norm forces or
  forces in the friction cones (a second-order cone program, Clarabel);
- ``states.py``: the checks of the states and settings;
- ``ground.py`` and ``stepping.py``: ``Ground`` and unilateral frictional contacts with it
  in simulation (velocity-level time stepping, projected Gauss-Seidel; the NumPy reference);
  ``compiled_step.py``: the same step in one compiled call, and a whole run of them;
  ``stepper.py``: the step one at a time (the simulator node) and ``sd.simulate``'s run.
"""
from .collision import contact_points
from .constrained import constrained_forward_dynamics
from .contact import Contact
from .ground import Ground
from .inverse import contact_inverse_dynamics

__all__ = ["Contact", "Ground", "contact_points", "constrained_forward_dynamics",
           "contact_inverse_dynamics"]
