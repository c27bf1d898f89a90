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
from .estimate import (closest_standard, joint_weights, least_squares_fit, physical_bodies,
                       physical_fit)
from .preprocess import check_recording, prepare, regression
from .result import IdentificationResult

METHODS = ("ols", "wls", "physical")
# a column-scaled base regressor worse conditioned than this does not see some parameter
MAX_CONDITION = 1e7
# evaluations of the physically consistent fit that replaces an OLS/WLS fit which is not
# physical, started from that fit: the torque residual is then within 1 % of the plain fit's
# (UR5e, 20 s, 0.05 N m noise: RMS per joint -0.1 .. +0.5 % of the WLS fit's after 200
# evaluations, -0.1 .. +0.6 % after 50; the unlimited fit stops at its limit, 2000)
CONSISTENT_NFEV = 200


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
    validate on. ``source``: the URDF (path or XML) ``result.write_urdf`` starts from
    (default: the one ``robot`` was loaded from, ``robot.model.source``). When an OLS or
    WLS fit is not physically consistent, ``result.standard`` holds the physically
    consistent parameters closest to it (``result.unphysical`` names the bodies), which
    ``write_urdf`` writes. ``progress``: callable(message)."""
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
    phi, unphysical, consistent_rms = None, (), None
    if method in ("wls", "physical"):
        beta, cov, r = least_squares_fit(W, s.tau, weights)
    phi_urdf = robot.inertial_parameters(friction=friction)
    bodies = robot.model.dof
    # the standard parameters of the fit closest to the URDF's (K phi = beta)
    closest = closest_standard(phi_urdf, bp.K, beta)
    if method == "physical":
        say("physically consistent fit (log-Cholesky, scipy.optimize.least_squares) ...")
        start = closest.copy()         # the URDF's inertias, friction (and armature) of WLS
        start[:10 * bodies] = phi_urdf[:10 * bodies]
        phi, fit = physical_fit(Y, s.tau, weights, start, bp.standard_names, bodies)
        beta = bp.beta(phi)
        r = s.tau - W @ beta
        say(f"  {fit.nfev} evaluations" + ("" if fit.status > 0 else
            " (the evaluation limit: the directions the data do not see converge slowly)"))
    elif not np.all(ok := physical_bodies(closest, bodies)):
        # a URDF must hold physical bodies: the physically consistent parameters closest to
        # the plain fit in its own metric (|A phi - y|^2 = |A (phi - phi_fit)|^2 + its
        # residual), from the fit itself; beta, its statistics and predictions stay the fit's
        unphysical = tuple(robot.model.link_names[i] for i in np.flatnonzero(~ok))
        say(f"the {method} fit is not physically consistent for {list(unphysical)}: the "
            "physically consistent parameters closest to it, for the URDF ...")
        phi, fit = physical_fit(Y, s.tau, weights if method == "wls" else np.ones(robot.dof),
                                closest, bp.standard_names, bodies, max_nfev=CONSISTENT_NFEV)
        consistent_rms = np.sqrt(np.mean((s.tau - W @ bp.beta(phi)) ** 2, axis=0))
    result = IdentificationResult(robot=robot, method=method, friction=friction, bp=bp,
                                  beta=beta, std=np.sqrt(np.maximum(np.diag(cov), 0.0)),
                                  cov=cov, standard=phi, samples=s, residual=r,
                                  condition_number=cond, source=source, unphysical=unphysical,
                                  consistent_rms=consistent_rms)
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
