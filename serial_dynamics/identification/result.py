"""``IdentificationResult``: the identified base parameters with their standard
deviations, the fit, its validation on a second recording, the summary table, the fit
plot and the corrected URDF."""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from .preprocess import Samples, check_recording, prepare, regression
from .estimate import closest_standard, physical_bodies
from .urdf_out import write_urdf


@dataclass(frozen=True, eq=False)
class Validation:
    """Torques predicted on another recording against the measured ones: ``rms`` (n,)
    N m of the error per joint, ``relative`` (n,) |error| / |measured| per joint, ``total``
    the relative error over all joints; the samples used (filtered like the fit)."""

    rms: np.ndarray
    relative: np.ndarray
    total: float
    samples: Samples
    predicted: np.ndarray


@dataclass(eq=False)
class IdentificationResult:
    """What ``identify`` found. ``beta`` (b,) the base parameters, ``std`` (b,) their
    standard deviations, ``cov`` (b, b); ``names`` their expressions in the standard
    parameters; ``standard`` (p,) physically consistent standard parameters (method
    "physical"; or, when an OLS/WLS fit is not physically consistent, the consistent ones
    closest to it, with ``unphysical`` the links of the bodies the fit left inconsistent and
    ``consistent_rms`` (n,) their torque residual), else None; ``residual`` (N, n) the
    fit's torque residual on ``samples``; ``validation`` once ``validate`` ran."""

    robot: object
    method: str
    friction: bool
    bp: object
    beta: np.ndarray
    std: np.ndarray
    cov: np.ndarray
    standard: np.ndarray | None
    samples: Samples
    residual: np.ndarray
    condition_number: float
    source: object = None
    unphysical: tuple = ()
    consistent_rms: np.ndarray | None = None
    validation: Validation | None = None
    _closest: np.ndarray | None = field(default=None, repr=False)

    names = property(lambda self: list(self.bp.names))

    @property
    def beta_urdf(self):
        """The base parameters of the robot as loaded (its URDF and dissipation)."""
        return self.bp.beta(self.robot.inertial_parameters(friction=self.friction))

    @property
    def rms(self):
        """RMS of the fit's torque residual per joint (N m or N)."""
        return np.sqrt(np.mean(self.residual**2, axis=0))

    def predict(self, q, qd, qdd):
        """Torques of the identified model, (N, n): W(q, qd, qdd) beta."""
        return self.bp.project(self.robot.regressor(q, qd, qdd, friction=self.friction)) @ self.beta

    def validate(self, t, q, tau, qd=None, qdd=None) -> Validation:
        """Predict the torques of a second recording (filtered as the fit's) and compare."""
        t, q, tau, qd, qdd = check_recording(t, q, tau, qd, qdd, self.robot.joint_names)
        s, Y = regression(self.robot, prepare(t, q, tau, qd, qdd, self.samples.cutoff,
                                              self.samples.decimate), self.friction)
        pred = self.bp.project(Y) @ self.beta
        err = s.tau - pred
        rms = np.sqrt(np.mean(err**2, axis=0))
        rel = np.linalg.norm(err, axis=0) / np.maximum(np.linalg.norm(s.tau, axis=0), 1e-300)
        total = float(np.linalg.norm(err) / max(np.linalg.norm(s.tau), 1e-300))
        self.validation = Validation(rms, rel, total, s, pred)
        return self.validation

    # ----------------------------------------------------------- standard parameters
    def standard_parameters(self):
        """Standard parameters phi (p,) for the URDF: the physically consistent ones
        (``standard``), or (an OLS/WLS fit that is physical) the ones closest to the URDF's
        that reproduce ``beta``, phi = phi_urdf + K^+ (beta - K phi_urdf)."""
        if self.standard is not None:
            return self.standard
        if self._closest is None:
            self._closest = closest_standard(
                self.robot.inertial_parameters(friction=self.friction), self.bp.K, self.beta)
        return self._closest

    def write_urdf(self, path, source=None):
        """Write the URDF (``source``, default the one given to ``identify``, else the one
        the robot was loaded from, ``robot.model.source``) with the identified
        ``<inertial>`` of every body and ``<dynamics damping friction>`` of every joint
        (``urdf_out.write_urdf``); ``sd.load_urdf(path)`` loads the identified robot (every
        body written is physically consistent: ``standard_parameters``)."""
        source = next((s for s in (source, self.source, self.robot.model.source)
                       if s is not None), None)
        if source is None:
            raise ValueError("write_urdf needs the original URDF, and this robot was built "
                             "by hand, not loaded from one: give identify(..., source=path) "
                             "or write_urdf(path, source=urdf_path)")
        phi = self.standard_parameters()
        model = self.robot.model
        n = model.dof
        names = list(self.bp.standard_names)
        body = phi[:10 * n].reshape(n, 10)
        fv, fc = np.array(model.damping), np.array(model.friction)   # every joint of the chain
        if self.friction:           # the independent joints' (mimic joints keep the URDF's)
            fv[model.independent] = phi[[names.index(f"fv{i + 1}") for i in range(self.robot.dof)]]
            fc[model.independent] = phi[[names.index(f"fc{i + 1}") for i in range(self.robot.dof)]]
        negative = [f"{w}{i + 1}" for w, v in (("fv", fv), ("fc", fc))
                    for i in np.flatnonzero(v < 0)]
        if negative:
            warnings.warn(f"identified friction {negative} is negative; written as 0",
                          UserWarning, stacklevel=2)
        return write_urdf(source, model, body, fv, fc, path)

    def physical(self):
        """(n,) bool: each body's standard parameters (those written) are physically
        consistent."""
        return physical_bodies(self.standard_parameters(), self.robot.model.dof)

    # ----------------------------------------------------------- reports
    def summary(self) -> str:
        """Table: base parameter, value, standard deviation (and % of the value), the
        URDF's value and the change relative to it; then the fit and validation errors."""
        urdf = self.beta_urdf
        width = max(12, max(len(nm) for nm in self.names))
        lines = [f"{'parameter':<{width}}  {'value':>12}  {'std':>10}  {'std %':>7}  "
                 f"{'URDF':>12}  {'change %':>9}"]
        for nm, v, s, u in zip(self.names, self.beta, self.std, urdf):
            pct = 100 * s / abs(v) if v else np.inf
            ch = 100 * (v - u) / abs(u) if abs(u) > 1e-12 else np.nan
            lines.append(f"{nm:<{width}}  {v:>12.5g}  {s:>10.3g}  {pct:>7.1f}  {u:>12.5g}  "
                         + (f"{ch:>9.1f}" if np.isfinite(ch) else f"{'-':>9}"))
        joints = self.robot.joint_names
        lines.append(f"method {self.method}; {self.samples.t.size} samples; condition number "
                     f"{self.condition_number:.4g}")
        lines.append("fit torque RMS per joint: " + ", ".join(
            f"{j} {r:.3g}" for j, r in zip(joints, self.rms)))
        if self.validation is not None:
            v = self.validation
            lines.append("validation torque RMS per joint: " + ", ".join(
                f"{j} {r:.3g}" for j, r in zip(joints, v.rms)))
            lines.append(f"validation relative error: {100 * v.total:.2f} % (per joint "
                         + ", ".join(f"{100 * e:.1f}" for e in v.relative) + " %)")
        if self.unphysical:
            lines.append(
                f"the {self.method} fit is not physically consistent for "
                f"{list(self.unphysical)}; write_urdf writes the physically consistent "
                "parameters closest to it (their fit torque RMS per joint: " + ", ".join(
                    f"{j} {r:.3g}" for j, r in zip(joints, self.consistent_rms)) + ")")
        else:
            lines.append("every body physically consistent")
        return "\n".join(lines)

    def plot(self, path=None, title=None):
        """Measured and predicted torques per joint (fit; and validation when there is
        one), with the residual; saved to ``path`` when given."""
        import matplotlib
        if path is not None:
            matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt
        runs = [("fit", self.samples, self.samples.tau - self.residual)]
        if self.validation is not None:
            runs.append(("validation", self.validation.samples, self.validation.predicted))
        n = self.robot.dof
        fig, ax = plt.subplots(n, len(runs), figsize=(6 * len(runs), 1.7 * n + 0.8),
                               sharex="col", squeeze=False)
        for c, (label, s, pred) in enumerate(runs):
            for j, name in enumerate(self.robot.joint_names):
                a = ax[j, c]
                a.plot(s.t, s.tau[:, j], "k", lw=1.0, label="measured")
                a.plot(s.t, pred[:, j], "C1--", lw=1.0, label="identified model")
                a.plot(s.t, s.tau[:, j] - pred[:, j], "C3", lw=0.7, label="error")
                rms = np.sqrt(np.mean((s.tau[:, j] - pred[:, j]) ** 2))
                a.set_ylabel(f"{name}\n(N m)", fontsize=7)
                a.set_title(f"{label}: RMS error {rms:.3g}", fontsize=7, loc="right")
                a.tick_params(labelsize=7)
            ax[0, c].legend(fontsize=7, loc="upper left", ncol=3)
            ax[-1, c].set_xlabel("t (s)")
        fig.suptitle(title or f"identification ({self.method}): measured vs identified "
                     "torques", fontsize=9)
        fig.tight_layout()
        if path is not None:
            fig.savefig(path, dpi=100)
            plt.close(fig)
        return fig
