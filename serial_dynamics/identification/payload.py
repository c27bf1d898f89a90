"""``estimate_payload``: the mass, center of mass and inertia of what a link holds, from one
recording, the arm's own inertial parameters known.

With the payload's standard parameters phi_P (m, m c, I_O: 10 numbers, ``link``'s frame,
inertia about its origin) the torques are linear in them (the regressor; Atkeson, An and
Hollerbach, "Estimation of inertial parameters of manipulator loads and links", IJRR 5(3),
1986; Khalil and Dombre, *Modeling, Identification and Control of Robots*, Sec. 13.3):

    tau - Y_arm phi_arm = Y_b T phi_P + Y_f phi_f

Y_b: the 10 columns of the body b that ``link`` belongs to, T: ``link``'s frame into b's link
frame (the pseudo-inertia moves as T J T^T), Y_f: viscous, Coulomb and offset friction per
joint, fitted too (an arm's friction is rarely known, and is well excited). Steps as
``identify``: the recording filtered and differentiated (``preprocess``), the regressor
filtered alike, the excitation of the payload's columns checked (their condition number,
column-scaled; refused with the parameters it cannot tell apart), weighted least squares
(``estimate``), and, when that fit is no real body, the physically consistent fit
(``estimate.physical_fit``: positive mass, triangle inequality). Standard deviations: the
least-squares covariance carried to (mass, com, inertia about the com) to first order.

No payload: a mass that the weighted least-squares fit does not put above ``DETECT_SIGMAS``
of its standard deviations (a one-sided test: a negative mass is none either), or one
below ``MIN_MASS_FRACTION`` of the arm's own moving mass, is no payload detected: a body
of no mass has no center of mass or inertia to report, so the estimate gives the mass and
its standard deviation and no center of mass (``detected`` False).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.links import resolve_link
from .estimate import joint_weights, least_squares_fit, physical_fit, pseudo_inertia
from .preprocess import check_recording, prepare, regression
from .urdf_out import body_inertia, is_physical

NAMES = ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
# a column-scaled payload regressor worse conditioned than this does not tell the payload's
# parameters apart: an excitation trajectory of the UR5e gives about 4, one joint moving
# alone 5e8 (test/identification/test_estimate_payload.py)
MAX_CONDITION = 1e4
DEAD = 1e-6      # a column this small against the largest is not seen
DETECT_SIGMAS = 3.0   # a payload: the least-squares mass above this many standard deviations
# ... and above this fraction of the arm's moving mass: far under any URDF's precision on
# its masses, far over round-off (exact data of Solo12 swinging unloaded fits 6e-17 kg)
MIN_MASS_FRACTION = 1e-6


@dataclass(frozen=True, eq=False)
class PayloadEstimate:
    """What ``link`` holds: ``mass`` kg, ``com`` (3,) m in ``link``'s frame, ``inertia``
    (ixx, iyy, izz, ixy, ixz, iyz) kg m^2 about the center of mass, ``link``'s axes (as
    ``robot.with_payload`` takes them), each with its standard deviation (``*_std``);
    ``detected``: False when the recording shows no payload (module docstring): then
    ``mass`` and ``mass_std`` are the least-squares fit's, and ``com``, ``inertia`` and
    their standard deviations are None;
    ``condition_number``: of the column-scaled payload columns along the recording (the
    excitation verdict; refused above ``MAX_CONDITION``); ``constrained``: the least-squares
    fit was no real body and the physically consistent fit replaced it; ``friction``:
    {"viscous", "coulomb", "offset"} per joint; ``residual_rms`` (n,) N m;
    ``samples``: the samples fitted (after filtering and decimation)."""

    link: str
    mass: float
    com: np.ndarray
    inertia: np.ndarray
    mass_std: float
    com_std: np.ndarray
    inertia_std: np.ndarray
    condition_number: float
    constrained: bool
    friction: dict
    residual_rms: np.ndarray
    samples: int
    parameters: np.ndarray          # phi_P (10,): m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz
    detected: bool = True

    def attach(self, robot):
        """``robot.with_payload`` of this estimate (no payload detected: ``robot`` without
        one)."""
        if not self.detected:
            return robot.without_payload()
        return robot.with_payload(self.mass, self.com, self.inertia, self.link)

    def summary(self) -> str:
        if not self.detected:
            why = (f"not above {DETECT_SIGMAS:g} standard deviations"
                   if self.mass <= DETECT_SIGMAS * self.mass_std else
                   f"under {MIN_MASS_FRACTION:g} of the arm's own mass")
            if self.mass < -DETECT_SIGMAS * self.mass_std:     # a sign or a model amiss
                why += ("; negative beyond them: the torques are not the model's (efforts of "
                        "another sign or scale, forces the model lacks, or a motion faster "
                        "than the filter's cutoff)")
            return (f"no payload detected on {self.link!r} (mass {self.mass:.3g} +- "
                    f"{self.mass_std:.2g} kg, {why}): no center of mass or inertia to "
                    f"give; condition number {self.condition_number:.3g}")
        c, s = np.round(self.com, 4).tolist(), np.round(self.com_std, 4).tolist()
        return (f"payload on {self.link!r}: mass {self.mass:.4g} +- {self.mass_std:.2g} kg, "
                f"com {c} +- {s} m, inertia (ixx iyy izz ixy ixz iyz) "
                f"{np.round(self.inertia, 5).tolist()} +- "
                f"{np.round(self.inertia_std, 5).tolist()} kg m^2; condition number "
                f"{self.condition_number:.3g}" + (" (physically consistent fit)"
                                                  if self.constrained else ""))


def estimate_payload(robot, t, q, tau, qd=None, qdd=None, link=None, cutoff=None,
                     decimate=None) -> PayloadEstimate:
    """The payload ``link`` (default: the tip link) holds, from times t (N,), positions q and
    actuator torques tau (N, n) (``robot.joint_names`` order; qd, qdd optional, as
    ``identify``) along a motion that excites it; ``robot``'s own parameters are taken as
    known (any payload attached to it is ignored: the estimate replaces it). ``cutoff``,
    ``decimate``: the filter, as ``identify``. Module docstring for the method."""
    if robot.is_floating:
        raise NotImplementedError("estimate_payload is for a fixed base: it fits the joints' "
                                  "measured torques, and a floating base's own six rows "
                                  "carry none (load the arm with a fixed base)")
    arm = robot.without_payload()
    link = resolve_link(arm.model, link, moving=True)
    b, R, p = arm.model.frames[link]
    names = tuple(arm.joint_names)
    t, q, tau, qd, qdd = check_recording(t, q, tau, qd, qdd, names)
    n = arm.dof
    if t.size * n <= 10 + 3 * n:
        raise ValueError(f"{t.size} samples are too few for 10 payload and {3 * n} friction "
                         "parameters; record a few seconds of an excitation trajectory")
    s, Y = regression(arm, prepare(t, q, tau, qd, qdd, cutoff, decimate), True)
    p_all = Y.shape[-1]
    rigid = p_all - 3 * n                       # bodies (and armature), then fv, fc, fo
    phi_arm = arm.inertial_parameters(friction=True)[:rigid]
    y = s.tau - Y[..., :rigid] @ phi_arm
    Yp = Y[..., 10 * b:10 * b + 10] @ link_to_body(R, p)      # the payload's columns
    A = np.concatenate([Yp, Y[..., rigid:]], axis=-1)        # (N, n, 10 + 3n)
    cond = check_excitation(Yp, s.qd, names, link)
    beta, cov, r = least_squares_fit(A, y)
    weights = joint_weights(r, A.shape[-1])
    beta, cov, r = least_squares_fit(A, y, weights)
    phi, mass_std = beta[:10], float(np.sqrt(max(cov[0, 0], 0.0)))
    common = dict(link=link, condition_number=cond, samples=int(s.t.size))
    if not is_detected(phi[0], mass_std, np.sum(arm.model.mass)):
        return PayloadEstimate(
            mass=float(phi[0]), com=None, inertia=None, mass_std=mass_std, com_std=None,
            inertia_std=None, constrained=False, friction=_friction(beta, n),
            residual_rms=np.sqrt(np.mean(r ** 2, axis=0)), parameters=phi, detected=False,
            **common)
    constrained = not is_physical(*body_inertia(phi))
    if constrained:
        names_all = list(NAMES) + [f"{k}{j + 1}" for k in ("fv", "fc", "fo") for j in range(n)]
        start = beta.copy()
        start[:10] = _nearest_body(phi)
        start[10:10 + 2 * n] = np.maximum(start[10:10 + 2 * n], 0.0)
        beta, _ = physical_fit(A, y, weights, start, names_all, 1)
        phi = beta[:10]
        r = y - A @ beta
    mass, com, inertia = to_payload(phi)
    G = _jacobian(phi)
    std = np.sqrt(np.maximum(np.diag(G @ cov[:10, :10] @ G.T), 0.0))
    return PayloadEstimate(
        mass=mass, com=com, inertia=inertia, mass_std=float(std[0]), com_std=std[1:4],
        inertia_std=std[4:], constrained=constrained, friction=_friction(beta, n),
        residual_rms=np.sqrt(np.mean(r ** 2, axis=0)), parameters=phi, **common)


def is_detected(mass, mass_std, arm_mass):
    """A payload is there: the least-squares mass above ``DETECT_SIGMAS`` standard
    deviations (one-sided) and above ``MIN_MASS_FRACTION`` of the arm's moving mass."""
    return mass > DETECT_SIGMAS * mass_std and mass >= MIN_MASS_FRACTION * arm_mass


def _friction(beta, n):
    """The friction fitted along: {"viscous", "coulomb", "offset"}, (n,) each."""
    return {"viscous": beta[10:10 + n], "coulomb": beta[10 + n:10 + 2 * n],
            "offset": beta[10 + 2 * n:]}


def check_excitation(Yp, qd, joint_names, link):
    """The condition number of the column-scaled payload columns; a ValueError naming the
    parameters the recording does not tell apart when above ``MAX_CONDITION``."""
    A = Yp.reshape(-1, 10)
    norms = np.linalg.norm(A, axis=0)
    still = [j for j, v in zip(joint_names, np.max(np.abs(qd), axis=0)) if v < 1e-3]
    hint = f" Joints {still} do not move (|qd| < 1e-3 rad/s throughout)." if still else ""
    # zero but for the round-off of filtering and differentiation (~1e-8 of the largest)
    dead = np.flatnonzero(norms <= DEAD * max(norms.max(), 1e-300))
    if dead.size:
        raise ValueError(f"too little excitation: the recording does not see the payload's "
                         f"{[NAMES[k] for k in dead]} on {link!r} (their regressor columns "
                         f"are zero).{hint} Move the payload through an excitation trajectory "
                         "(identification.excitation) that turns it about every axis")
    sv, V = np.linalg.svd(A / norms, full_matrices=False)[1:]
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else np.inf
    if cond > MAX_CONDITION:
        v = np.abs(V[-1])
        worst = [NAMES[k] for k in np.argsort(-v) if v[k] > 0.3 * v.max()]
        raise ValueError(f"too little excitation: the recording does not tell the payload's "
                         f"{worst} on {link!r} apart (condition number {cond:.3g} of its "
                         f"column-scaled regressor, above {MAX_CONDITION:.0e}).{hint} Move "
                         "the payload through an excitation trajectory "
                         "(identification.excitation) that turns it about every axis at "
                         "varying speeds")
    return cond


def link_to_body(R, p):
    """T (10, 10): a body's standard parameters in the frame (R, p) (placed in the body's
    link frame) -> the same body's in the body's link frame (J' = X J X^T, X = [[R, p],
    [0, 1]], on the pseudo-inertia; linear)."""
    X = np.eye(4)
    X[:3, :3], X[:3, 3] = R, p
    T = np.empty((10, 10))
    for k in range(10):
        e = np.zeros(10)
        e[k] = 1.0
        T[:, k] = from_pseudo(X @ pseudo_inertia(e) @ X.T)
    return T


def from_pseudo(J):
    """The 10 standard parameters of a pseudo-inertia J = [[Sigma, h], [h^T, m]]."""
    S = J[:3, :3]
    I = np.trace(S) * np.eye(3) - S
    return np.array([J[3, 3], *J[:3, 3], I[0, 0], I[0, 1], I[1, 1], I[0, 2], I[1, 2], I[2, 2]])


def to_payload(phi):
    """(mass, com (3,), inertia (ixx, iyy, izz, ixy, ixz, iyz) about the com) of phi."""
    m, h, I_O = body_inertia(phi)
    c = h / m if m != 0 else np.zeros(3)
    Ic = I_O - m * (c @ c * np.eye(3) - np.outer(c, c))       # parallel axes
    return float(m), c, np.array([Ic[0, 0], Ic[1, 1], Ic[2, 2], Ic[0, 1], Ic[0, 2], Ic[1, 2]])


def _jacobian(phi, h=1e-7):
    """d (mass, com, inertia) / d phi (10, 10) by central differences."""
    flat = lambda x: np.r_[to_payload(x)[0], to_payload(x)[1], to_payload(x)[2]]   # noqa: E731
    G = np.empty((10, 10))
    for k in range(10):
        e = np.zeros(10)
        e[k] = h * max(abs(phi[k]), 1e-3)
        G[:, k] = (flat(phi + e) - flat(phi - e)) / (2 * e[k])
    return G


def _nearest_body(phi):
    """A real body near phi: its pseudo-inertia's eigenvalues floored at a small positive
    value (the physically consistent fit's starting point)."""
    J = pseudo_inertia(phi)
    w, V = np.linalg.eigh(J)
    floor = 1e-4 * max(abs(w).max(), 1e-6)
    return from_pseudo((V * np.maximum(w, floor)) @ V.T)
