"""``sweep.monte_carlo``: the robustness of a controller under model uncertainty (a
Monte-Carlo study).

Each case draws a plant -- the nominal robot with a payload on its tip, every body's mass
and inertia scaled, the joint friction scaled, a start off the trajectory -- and runs the
controller built on the NOMINAL model (one of the library's laws, ``control.py``, at the
rate 1/dt, a zero-order hold between samples; torques clipped at the effort limits as a
drive does) along the trajectory (the built-in pick-and-place by default, then ``settle``
seconds of holding the last point). The plant moves by the library's simulator (fixed step
dt, semi-implicit Euler with stick-slip friction). Per case: the tracking error e = q_d - q
(RMS and max per joint, rad or m), the peak commanded torque over the limit, the time
some joint spends saturated, and whether the run diverged (the simulator stopped on a
``SimulationError``, or |e| exceeded ``lost`` somewhere).

The draws come from one ``numpy.random.Generator`` seeded with ``seed`` (``draw``), so
a study is its seed and its ranges; ``Study`` runs one case; ``summary`` and ``plot`` read
the table.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from .. import SimulationError, control, default_robot, simulate
from ..trajectory import Waypoints, pick_and_place
from .run import ERROR, run

# nominal friction when the URDF gives none (the built-in UR5e's carries none): viscous and
# Coulomb torques per joint as fractions of the joint's effort limit (rated torque), N m s/rad
# and N m. Coulomb is off by default: its stick-slip makes a simulated case 2-3 times slower
# (measured: 0.46 s against 0.16 s per pick-and-place case); give the robot a dissipation
# with Coulomb friction to study it.
NOMINAL_VISCOUS, NOMINAL_COULOMB = 0.005, 0.0


def monte_carlo(robot=None, cases=1000, *, seed=0, payload=(0.0, 3.0), payload_com=(0.0, 0.0, 0.05),
                link_mass_scale=(0.9, 1.1), friction_scale=(0.5, 2.0), start_offset=0.05,
                law="computed_torque", kp=400.0, kd=40.0, compensate_friction=True,
                waypoints=None, settle=0.5, dt=0.002, lost=1.0, client=None, progress=True,
                workers=None, device="cpu") -> pd.DataFrame:
    """A Monte-Carlo study of ``cases`` plants (see the module docstring); the table of
    ``sweep.run``: the draws, then the outcomes, one row per case.

    robot: the nominal ``Robot`` (default: the built-in UR5e); its dissipation is the
        nominal friction (when it has none: ``NOMINAL_VISCOUS``, ``NOMINAL_COULOMB`` times
        the effort limits). payload: (low, high) kg, at ``payload_com`` (m, tip frame).
        link_mass_scale: (low, high), one factor per body (mass and inertia). friction_scale:
        (low, high), one factor for every joint's viscous and Coulomb friction.
        start_offset: the start is q_d(0) + U(-start_offset, start_offset) per joint.
    law: a ``control.MODES`` law; kp, kd: its gains (computed_torque: 1/s^2, 1/s;
        pd_gravity: times the diagonal of M(0)), scalars or one per joint.
        compensate_friction: the controller adds the nominal friction torque at the desired
        velocity (feed-forward: no positive feedback of the measured velocity).
    waypoints: a ``trajectory.Waypoints`` (default ``pick_and_place(robot)``).
    dt: the control period and simulation step (s). lost: |e| (rad or m) beyond which a
        run counts as diverged. client, progress, workers: as ``sweep.run``.
    device: "cpu" (the cases on Dask, ``sweep.run``) or "cuda" (every case one thread of
        one batched simulation on the card, ``gpu/rollouts.py``; the ``[gpu]`` extra; client
        and workers unused): the same table, each outcome within 1e-9 relative.
    """
    study = Study(robot, waypoints, law, kp, kd, compensate_friction, payload_com, settle, dt,
                  lost)
    table = draw(study.nominal, cases, seed, payload, link_mass_scale, friction_scale,
                 start_offset)
    if device == "cuda":
        from ..gpu.rollouts import run_study
        out = run_study(study, table, progress).set_index(table.index)
        return pd.concat([table, out.assign(**{ERROR: ""})], axis=1)
    if device != "cpu":
        raise ValueError(f"device = {device!r}; use 'cpu' (Dask) or 'cuda' (one NVIDIA card)")
    return run(study, table, client, progress, workers=workers)


def _range(name, value):
    lo, hi = (float(v) for v in np.broadcast_to(np.asarray(value, dtype=float), (2,)))
    if not (np.isfinite(lo) and np.isfinite(hi) and lo <= hi):
        raise ValueError(f"{name} = {value!r}; give a range (low, high) with low <= high")
    return lo, hi


def draw(robot, cases, seed, payload, link_mass_scale, friction_scale, start_offset):
    """The table of draws: case, payload (kg), mass_scale_<link> per body, friction_scale,
    offset_<joint> (rad or m) per joint; uniform within the ranges, from ``seed``."""
    if not (isinstance(cases, (int, np.integer)) and cases >= 1):
        raise ValueError(f"cases = {cases!r}; give a whole number of cases >= 1")
    rng = np.random.default_rng(seed)
    m = _range("payload", payload)
    if m[0] < 0:
        raise ValueError(f"payload = {payload!r}; masses are >= 0 kg")
    s = _range("link_mass_scale", link_mass_scale)
    f = _range("friction_scale", friction_scale)
    if s[0] <= 0 or f[0] < 0:
        raise ValueError("link_mass_scale must be > 0 and friction_scale >= 0; got "
                         f"{link_mass_scale!r}, {friction_scale!r}")
    d = float(start_offset)
    if not d >= 0:
        raise ValueError(f"start_offset = {start_offset!r}; give a half-width >= 0")
    columns = {"case": np.arange(cases), "payload": rng.uniform(*m, cases)}
    for link in robot.model.link_names:
        columns[f"mass_scale_{link}"] = rng.uniform(*s, cases)
    columns["friction_scale"] = rng.uniform(*f, cases)
    for joint in robot.joint_names:
        columns[f"offset_{joint}"] = rng.uniform(-d, d, cases)
    return pd.DataFrame(columns)


class Study:
    """One case of the study: ``Study(...)(case) -> dict`` of outcomes (picklable: the
    nominal robot travels as its model data)."""

    def __init__(self, robot, waypoints, law, kp, kd, compensate, payload_com, settle, dt,
                 lost):
        robot = default_robot() if robot is None else robot
        if law not in control.MODES:
            raise ValueError(f"law {law!r} unknown; use one of {', '.join(control.MODES)}")
        if not (dt > 0 and settle >= 0 and lost > 0):
            raise ValueError(f"dt = {dt!r}, settle = {settle!r}, lost = {lost!r}: give dt > 0 "
                             "s, settle >= 0 s and lost > 0")
        if not robot.dissipation.enabled:          # the nominal friction
            lim = np.where(np.isfinite(robot.effort_limit), robot.effort_limit, 0.0)
            robot = type(robot)(robot.model, robot.dissipation.override(
                viscous=NOMINAL_VISCOUS * lim, coulomb=NOMINAL_COULOMB * lim), robot.backend)
        self.nominal, self.law = robot, law
        self.kp = np.broadcast_to(np.asarray(kp, dtype=float), (robot.dof,)).copy()
        self.kd = np.broadcast_to(np.asarray(kd, dtype=float), (robot.dof,)).copy()
        self.waypoints = pick_and_place(robot) if waypoints is None else waypoints
        if not isinstance(self.waypoints, Waypoints):
            raise ValueError("waypoints must be a serial_dynamics.trajectory.Waypoints")
        self.payload_com, self.dt, self.lost = tuple(payload_com), float(dt), float(lost)
        steps = int(round((self.waypoints.duration + settle) / dt))
        self.t = np.arange(steps + 1) * dt
        self.reference = self.waypoints.sample(self.t)           # q_d, qd_d, qdd_d per step
        qd_d = self.reference[1]                                 # the friction feed-forward:
        self.friction = robot.dissipation.torque(qd_d) if compensate else np.zeros_like(qd_d)

    def plant(self, case):
        """The case's robot: masses scaled per body, friction scaled, the payload on."""
        nominal, model = self.nominal, self.nominal.model
        s = np.array([case[f"mass_scale_{link}"] for link in model.link_names])
        scaled = dataclasses.replace(model, **{k: getattr(model, k) * s.reshape((-1,) + (1,) * (
            getattr(model, k).ndim - 1)) for k in ("mass", "inertia", "h", "I_c", "I_O")})
        f = case["friction_scale"]
        diss = nominal.dissipation.override(viscous=nominal.dissipation.viscous * f,
                                            coulomb=nominal.dissipation.coulomb * f)
        robot = type(nominal)(scaled, diss, nominal.backend)
        return robot.with_payload(case["payload"], self.payload_com) if case["payload"] else robot

    def __call__(self, case):
        nominal, dt, (q_d, qd_d, qdd_d) = self.nominal, self.dt, self.reference
        limit, friction = nominal.effort_limit, self.friction
        commanded = np.zeros_like(q_d)                 # the controller's torque at each step
        last = len(self.t) - 1

        def controller(t, q, qd):
            k = min(int(round(t / dt)), last)
            kp, kd = (control.pd_gains(nominal, q, self.kp, self.kd)  # as the node's default
                      if self.law == "pd_gravity" else (self.kp, self.kd))
            tau = control.torque(nominal, self.law, q, qd, q_d[k] - q, qd_d[k] - qd, qdd_d[k],
                                 kp, kd) - friction[k]
            commanded[k] = tau
            return np.clip(tau, -limit, limit)

        q0 = q_d[0] + np.array([case[f"offset_{j}"] for j in nominal.joint_names])
        try:
            res = simulate(self.plant(case), self.t[-1], q0, np.zeros(nominal.dof),
                           torque=controller, method="semi_implicit_euler", dt=dt)
        except SimulationError as exc:    # the simulator's verdict that the run diverged
            return {"diverged": True, "diverged_at": exc.t, "reason": str(exc)}
        e = np.abs(q_d - res.q)
        out = {"rms_error": float(np.sqrt(np.mean(e**2))), "max_error": float(e.max())}
        for j, name in enumerate(nominal.joint_names):
            out[f"rms_{name}"] = float(np.sqrt(np.mean(e[:, j]**2)))
            out[f"max_{name}"] = float(e[:, j].max())
        ratio = np.abs(commanded) / limit
        out["peak_torque_ratio"] = float(ratio.max())
        out["saturation_time"] = float(np.count_nonzero(np.any(ratio > 1.0, axis=1)) * dt)
        out["diverged"] = bool(out["max_error"] > self.lost)
        out["diverged_at"] = float(self.t[np.argmax(np.any(e > self.lost, axis=1))]) \
            if out["diverged"] else np.nan
        out["reason"] = f"|e| > {self.lost:g}" if out["diverged"] else ""
        return out


PERCENTILES = (0.5, 0.9, 0.99, 1.0)


def summary(table, worst=5):
    """(percentiles of the outcomes, the ``worst`` cases by max error): two DataFrames."""
    ran = table[table["error"] == ""]
    cols = ["rms_error", "max_error", "peak_torque_ratio", "saturation_time"]
    p = ran[cols].quantile(list(PERCENTILES))
    p.index = [f"p{100 * x:g}" for x in PERCENTILES]
    p.loc["diverged (fraction)"] = [ran["diverged"].mean()] + [np.nan] * (len(cols) - 1)
    keep = ["case", "payload", "friction_scale"] + cols + ["diverged"]
    return p, ran.sort_values("max_error", ascending=False).head(worst)[keep]


def plot(table, path=None):
    """The max tracking error (colour, log scale) against payload and friction scale."""
    import matplotlib
    if path is not None:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm
    ran = table[table["error"] == ""]
    fig, ax = plt.subplots(figsize=(7, 5))
    sc = ax.scatter(ran["payload"], ran["friction_scale"], c=ran["max_error"], s=6,
                    cmap="viridis", norm=LogNorm())
    bad = ran[ran["diverged"]]
    ax.scatter(bad["payload"], bad["friction_scale"], marker="x", c="red", s=12,
               label=f"diverged ({len(bad)})")
    fig.colorbar(sc, ax=ax, label="max tracking error (rad)")
    ax.set_xlabel("payload (kg)")
    ax.set_ylabel("friction scale (x nominal)")
    ax.set_title(f"Monte Carlo: {len(ran)} cases")
    ax.legend(loc="upper right")
    if path is not None:
        fig.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(fig)
    return fig
