"""The result of a run: ``SimulationResult`` (the motion, torques, energies and works;
energy balance, CSV, plot) and ``SolverStats`` (the work the run took); ``finish``
assembles a result from the samples of a run loop."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class SolverStats:
    """Work done by a run. ``nfev``: right-hand-side evaluations (for the fixed-step
    methods: stage evaluations; a batched Jacobian call counts once in ``njev``);
    ``dynamics_states``: every state the dynamics was evaluated at (a Jacobian over 2n+1
    perturbed states counts 2n+1): the honest cost. ``rejected``: rejected step attempts
    (exact for RK45/DOP853; for Radau/BDF/LSODA, the accepted steps that were shorter
    than the solver had proposed, a lower bound)."""

    method: str
    steps: int = 0
    nfev: int = 0
    njev: int = 0
    nlu: int = 0
    rejected: int = 0
    newton_iterations: int = 0
    dynamics_calls: int = 0
    dynamics_states: int = 0
    wall_time: float = 0.0
    message: str = ""


@dataclass
class SimulationResult:
    """A simulated motion. Arrays over the output times ``t`` (K,):

    q, qd, qdd (K, n); tau (applied torques), delta (dissipative torques, holding torques
    of stuck joints included) (K, n); kinetic, potential (K,) J; work_actuators
    int tau.qd, work_dissipation int delta.qd (<= 0), work_external int (J^T w).qd (K,) J
    (with a ground, its contacts' work too). ``stats``: a ``SolverStats``. Simulated with a
    ground (``contacts/stepping.py``): ``contact_forces`` (K, k, 3), the force on each contact
    over the step from each sample, world axes, N, and ``contact_active`` (K, k), whether it
    pushes; None otherwise."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    delta: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    work_actuators: np.ndarray
    work_dissipation: np.ndarray
    work_external: np.ndarray
    stats: SolverStats
    joint_names: list = field(default_factory=list)
    base_names: tuple = ((), ())     # q's and qd's coordinates before the joints (robot.chart)
    contact_forces: np.ndarray | None = None     # (K, k, 3) with a ground
    contact_active: np.ndarray | None = None     # (K, k) with a ground

    method = property(lambda self: self.stats.method)

    @property
    def energy(self):
        """Total mechanical energy T + V (J)."""
        return self.kinetic + self.potential

    @property
    def energy_dissipated(self):
        """Energy taken out by the dissipation so far, -int delta.qd dt >= 0 (J)."""
        return -self.work_dissipation

    @property
    def energy_balance_error(self):
        """E(t) - E(0) - W_act - W_diss - W_ext: zero for an exact solution (J)."""
        e = self.energy
        return e - e[0] - self.work_actuators - self.work_dissipation - self.work_external

    def energy_scale(self):
        """A scale for relative energy errors: the largest of the kinetic energy, the
        potential-energy swing and the works over the run (J)."""
        v = self.potential
        return max(np.max(self.kinetic), np.ptp(v), np.max(np.abs(self.work_actuators)),
                   np.max(np.abs(self.work_dissipation)), np.max(np.abs(self.work_external)),
                   1e-300)

    def relative_energy_error(self):
        """max |energy balance error| / energy_scale() over the run."""
        return float(np.max(np.abs(self.energy_balance_error)) / self.energy_scale())

    def columns(self):
        """(header, table) with t, q_*, qd_*, tau_*, delta_*, energies and works."""
        names = self._names()
        q_names, v_names = (list(b) for b in self.base_names)
        head = (["t"] + [f"q_{j}" for j in q_names + names]
                + [f"qd_{j}" for j in v_names + names]
                + [f"tau_{j}" for j in names] + [f"delta_{j}" for j in names]
                + ["kinetic", "potential", "energy", "work_actuators", "work_dissipation",
                   "work_external"])
        table = np.column_stack([self.t, self.q, self.qd, self.tau, self.delta, self.kinetic,
                                 self.potential, self.energy, self.work_actuators,
                                 self.work_dissipation, self.work_external])
        return head, table

    def _names(self):
        return self.joint_names or [f"j{i}" for i in range(self.tau.shape[1])]

    def to_csv(self, path):
        head, table = self.columns()
        np.savetxt(path, table, delimiter=",", header=",".join(head), comments="", fmt="%.10g")

    def plot(self, path=None, title=None):
        """Figure with q(t), tau(t) and the energies; saved to ``path`` when given."""
        import matplotlib
        if path is not None:
            matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt
        names, nqb = self._names(), len(self.base_names[0])
        fig, ax = plt.subplots(3, 1, figsize=(9, 9), sharex=True)
        for j, name in enumerate(names):                  # the joints (after a base's pose)
            line, = ax[0].plot(self.t, self.q[:, nqb + j], label=name)
            ax[1].plot(self.t, self.tau[:, j], color=line.get_color(), label=f"tau {name}")
            if np.any(self.delta[:, j]):
                ax[1].plot(self.t, self.delta[:, j], color=line.get_color(), ls="--", lw=0.8)
        ax[0].set_ylabel("q (rad, m)")
        ax[0].legend(fontsize=7, ncol=3, loc="best")
        ax[1].set_ylabel("torque (N m, N)")
        quiet = not (np.any(self.tau) or np.any(self.delta))
        ax[1].set_title("no applied or dissipative torque (free motion)" if quiet else
                        "applied (solid), dissipative (dashed)", fontsize=8)
        e0 = self.energy[0]
        ax[2].plot(self.t, self.kinetic, label="kinetic T")
        ax[2].plot(self.t, self.potential - self.potential[0], label="potential V - V(0)")
        ax[2].plot(self.t, self.energy - e0, label="E - E(0)", lw=2)
        ax[2].plot(self.t, self.work_actuators + self.work_dissipation + self.work_external,
                   "k:", label="W_act + W_diss + W_ext")
        ax[2].set_ylabel("energy (J)")
        ax[2].set_xlabel("t (s)")
        ax[2].legend(fontsize=7, loc="best")
        s = self.stats
        fig.suptitle(title or f"{s.method}: {s.steps} steps, {s.nfev} RHS evaluations, "
                     f"{s.wall_time:.2f} s wall; energy balance error "
                     f"{self.relative_energy_error():.1e} (relative)", fontsize=9)
        fig.tight_layout()
        if path is not None:
            fig.savefig(path, dpi=110)
            plt.close(fig)
        return fig


def finish(eq, ts, Q, QD, QDD, TAU, DELTA, W, stats, names):
    """A ``SimulationResult`` from the samples of a run (lists or arrays), with the
    energies at the samples and the dynamics calls counted by ``eq`` (an ``Equations``)."""
    robot = eq.robot
    Q, QD = np.asarray(Q), np.asarray(QD)
    kinetic = np.asarray(robot.kinetic_energy(Q, QD), dtype=float).reshape(-1)
    potential = np.asarray(robot.potential_energy(Q), dtype=float).reshape(-1)
    W = np.asarray(W).reshape(-1, 3)
    stats.dynamics_calls, stats.dynamics_states = eq.calls, eq.states
    return SimulationResult(np.asarray(ts), Q, QD, np.asarray(QDD), np.asarray(TAU),
                            np.asarray(DELTA), kinetic, potential, W[:, 0], W[:, 1], W[:, 2],
                            stats, list(names), robot.chart.base_names)
