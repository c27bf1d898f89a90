"""Dynamics algorithms: pure functions of (model, state), one module each.

Every function accepts a single state, shape ``(n,)``, or a batch ``(N, n)``, and
returns results with the matching leading shape. These NumPy implementations are
the readable reference and the test oracle.

One frame convention for all of them: the **joint frames** that ``serial_dynamics/model/model.py``
derives (``Xtree_R``, ``Xtree_p``, ``h``, ``c``, ``I_O``, ``I_c``, ``Xtip_R``, ``Xtip_p``,
``jframes``; docs/conventions.md). Joint frame i is body i's frame, with its origin at joint
i and z along the joint axis, so every motion subspace is S = e_z; spatial vectors are
(angular, linear) about the body origin in the body's frame (Featherstone 2008). The URDF
link-frame fields (``R_parent``, ``axis``, ``com``, ``inertia``, ``tip_*``, ``frames``) are
never read here. Results at the boundary (joint torques, mass matrix, poses of links,
Jacobians, the NOC's base-frame twists) do not depend on that choice.

    joint       the joint types, said once: X_J(q), S, S^T f, the rate, world-axes columns
    rnea        inverse dynamics, bias and gravity torques (Newton-Euler in 3-vectors)
    crba        mass matrix (composite rigid bodies, Featherstone Table 6.2)
    aba         forward dynamics (articulated bodies, Featherstone Table 7.1)
    forward     forward dynamics by Cholesky or QR (Angeles)
    kinematics  joint transforms, body and link poses, Jacobians
    noc         the natural orthogonal complement (Angeles & Lee): base-frame twists, the
                twist-shaping matrix T and its rate, the Coriolis matrix; the textbook's
                formulation, which forward, energy and floating build on
    energy      kinetic and potential energy
    task_space  frame acceleration, J-dot qd (Lambda and J-bar: robot/task_space.py)
    regressor   the torque regressor Y (tau = Y phi)
    derivatives derivatives of inverse and forward dynamics
    floating    a free-floating base: Newton-Euler, CRBA, ABA through a 6-DoF root, SE(3)
    planar      planar chains in planar 3-vectors (on core/planar_layout.py's Q)
    _batch      batching, 3-vector and spatial helpers

``serial_dynamics/core/`` holds the compiled equivalents, in the same frames and under
the same names; the ``Robot`` facade uses them for speed and the tests compare the two.
"""
