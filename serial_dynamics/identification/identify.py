"""``identify``: base parameters (and, when asked, physically consistent standard
parameters) of a robot from one recording of positions and torques.

    tau = Y(q, qd, qdd) phi = W(q, qd, qdd) beta,   W = Y[:, independent], beta = K phi

(``base_parameters``: the b identifiable combinations beta of the p standard parameters
phi). Steps: checks -> ``preprocess.prepare`` (filter, derivatives) ->
``preprocess.regression`` (the regressor at every sample, filtered like tau, decimated)
-> the excitation check (every base parameter seen) -> ``estimate`` (OLS, WLS,
physically consistent) -> ``IdentificationResult``.
"""
from __future__ import annotations

import numpy as np

from .base_parameters import base_parameters
from .estimate import joint_weights, least_squares_fit, physical_fit
from .preprocess import check_recording, prepare, regression
from .result import IdentificationResult

METHODS = ("ols", "wls", "physical")
# a column-scaled base regressor worse conditioned than this does not see some parameter
MAX_CONDITION = 1e7


def identify(robot, t, q, tau, qd=None, qdd=None, friction=True, method="wls", cutoff=None,
             decimate=None, validation=None, source=None, progress=None
             ) -> IdentificationResult:
    """Identify ``robot``'s base parameters from a recording: times t (N,), positions q and
    actuator torques tau (N, n) (joints in ``robot.joint_names`` order), optionally qd and
    qdd (otherwise by zero-phase filtering and differentiation, ``preprocess.prepare``
    with ``cutoff`` Hz and ``decimate``). ``friction``: identify viscous, Coulomb and offset
    friction per joint too. ``method``: "ols", "wls" (weighted per joint) or "physical"
    (every body physically consistent; ``estimate.physical_fit``). ``validation``: a second
    recording ``(t, q, tau)`` or ``(t, q, tau, qd, qdd)`` (or a ``data.Recording``) to
    validate on. ``source``: the URDF (path or XML) ``result.write_urdf`` starts from.
    ``progress``: callable(message)."""
    say = progress or (lambda message: None)
    if method not in METHODS:
        raise ValueError(f"method {method!r} unknown; use one of {list(METHODS)}")
    names = tuple(robot.joint_names)
    t, q, tau, qd, qdd = check_recording(t, q, tau, qd, qdd, names)
    bp = base_parameters(robot, friction=friction)
    need = -(-(bp.count + 1) // robot.dof)
    if t.size < need:
        raise ValueError(f"{t.size} samples are too few: {bp.count} base parameters need at "
                         f"least {need} samples of {robot.dof} joints (in practice a few "
                         "hundred, spread over an excitation trajectory)")
    s, Y = regression(robot, prepare(t, q, tau, qd, qdd, cutoff, decimate), friction)
    grid = " (resampled onto a uniform grid)" if s.resampled else ""
    say(f"{t.size} samples at {s.rate:.4g} Hz{grid}; low-pass {s.cutoff:.3g} Hz, every "
        f"{s.decimate}th kept: {s.t.size} samples")
    if s.t.size * robot.dof <= bp.count:
        raise ValueError(f"{s.t.size} samples remain after filtering and decimation; "
                         f"{bp.count} base parameters need more than {bp.count // robot.dof} "
                         "(record longer, or lower decimate)")
    W = bp.project(Y)                                              # (N, n, b)
    cond = check_excitation(W, bp.names, names, s.qd)
    say(f"{bp.count} base parameters; condition number of the base regressor {cond:.4g}")
    beta, cov, r = least_squares_fit(W, s.tau)
    weights = joint_weights(r, bp.count)
    phi = None
    if method in ("wls", "physical"):
        beta, cov, r = least_squares_fit(W, s.tau, weights)
    if method == "physical":
        say("physically consistent fit (log-Cholesky, scipy.optimize.least_squares) ...")
        phi_urdf = robot.inertial_parameters(friction=friction)
        bodies = robot.model.dof
        # start: the URDF's inertias, friction (and armature) from the WLS fit
        start = phi_urdf + np.linalg.pinv(bp.K) @ (beta - bp.K @ phi_urdf)
        start[:10 * bodies] = phi_urdf[:10 * bodies]
        phi, fit = physical_fit(Y, s.tau, weights, start, bp.standard_names, bodies)
        beta = bp.beta(phi)
        r = s.tau - W @ beta
        say(f"  {fit.nfev} evaluations" + ("" if fit.status > 0 else
            " (the evaluation limit: the directions the data do not see converge slowly)"))
    result = IdentificationResult(robot=robot, method=method, friction=friction, bp=bp,
                                  beta=beta, std=np.sqrt(np.maximum(np.diag(cov), 0.0)),
                                  cov=cov, standard=phi, samples=s, residual=r,
                                  condition_number=cond, source=source)
    if validation is not None:
        result.validate(*_unpack(validation))
    return result


def _unpack(recording):
    if hasattr(recording, "tau"):
        return recording.t, recording.q, recording.tau, recording.qd
    return tuple(recording)


def check_excitation(W, base_names, joint_names, qd):
    """Condition number of the column-scaled base regressor; a ValueError naming the base
    parameters the recording does not excite when some column is zero or the columns are
    dependent (condition number above ``MAX_CONDITION``)."""
    A = W.reshape(-1, W.shape[-1])
    norms = np.linalg.norm(A, axis=0)
    still = [j for j, v in zip(joint_names, np.max(np.abs(qd), axis=0)) if v < 1e-3]
    hint = (f" Joints {still} do not move (|qd| < 1e-3 rad/s throughout)." if still else "")
    dead = np.flatnonzero(norms <= 1e-9 * max(norms.max(), 1e-300))
    if dead.size:
        raise ValueError(f"the recording does not excite base parameters "
                         f"{[base_names[k] for k in dead]} (their regressor columns are zero)."
                         f"{hint} Record an excitation trajectory (serial-dynamics excite) "
                         "that moves every joint")
    sv, V = np.linalg.svd(A / norms, full_matrices=False)[1:]
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else np.inf
    if cond > MAX_CONDITION:
        v = np.abs(V[-1])
        worst = [base_names[k] for k in np.argsort(-v) if v[k] > 0.3 * v.max()]
        raise ValueError(f"the recording does not excite base parameters {worst} apart from "
                         f"each other (condition number {cond:.3g} of the column-scaled base "
                         f"regressor, above {MAX_CONDITION:.0e}).{hint} Record an excitation "
                         "trajectory (serial-dynamics excite) that moves every joint back and "
                         "forth at varying speeds")
    s = np.linalg.svd(A, compute_uv=False)
    return float(s[0] / s[-1])
