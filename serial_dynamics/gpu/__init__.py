"""Batches on a GPU through numba's CUDA target (the ``[gpu]`` extra: numba-cuda).

    from serial_dynamics import gpu
    tau = gpu.inverse_dynamics(robot, Q, QD, QDD)   # (N, dof) each
    M   = gpu.mass_matrix(robot, Q)                 # (N, dof, dof)
    qdd = gpu.forward_dynamics(robot, Q, QD, TAU)   # Cholesky
    dq, dqd = gpu.inverse_dynamics_derivatives(robot, Q, QD, QDD)   # (N, dof, dof) each

One CUDA thread per state. NumPy arrays in give NumPy arrays out (one transfer each way);
device arrays in (anything with ``__cuda_array_interface__``: CuPy, PyTorch, numba) give
device arrays out, without copies. float64 only. Every fixed-base kind: armature, payload,
planar (through the general recursions), mimic joints, trees; a free-floating base (Q of
nq numbers) for inverse dynamics, the mass matrix and forward dynamics. Importing
``serial_dynamics`` never imports this package (nor numba.cuda); without numba-cuda,
importing it raises an ImportError naming the extra. ``NUMBA_ENABLE_CUDASIM=1``, set before
numba.cuda is first imported, runs the kernels in numba's simulator (slow; the tests use it
on machines without a card). ``sweep.monte_carlo(..., device="cuda")`` runs a whole
Monte-Carlo study here (``rollouts.py``). docs/scale.md.
"""
from .crba import mass_matrix
from .derivatives import inverse_dynamics_derivatives
from .forward import forward_dynamics
from .rnea import inverse_dynamics
from .runtime import SIMULATOR

__all__ = ["inverse_dynamics", "mass_matrix", "forward_dynamics", "inverse_dynamics_derivatives",
           "SIMULATOR"]
