"""Shared by the identification tests: a 'true' arm (the UR5e with perturbed inertials and
friction, written as a URDF), and recordings of it following an excitation trajectory with
realistic measurement noise."""
import numpy as np

import serial_dynamics as sd
from serial_dynamics.identification import urdf_out

# measurement noise: a 20-bit encoder (2 pi / 2^20 = 6.0e-6 rad per count) and torque noise
# of 1 N m (base, shoulder, elbow; 150 N m rated) and 0.2 N m (wrists; 28 N m rated), white
ENCODER = 2 * np.pi / 2**20
TORQUE_NOISE = np.array([1.0, 1.0, 1.0, 0.2, 0.2, 0.2])
VISCOUS = [2.0, 2.0, 1.5, 0.5, 0.5, 0.3]         # N m s/rad
COULOMB = [3.0, 3.0, 2.0, 0.8, 0.8, 0.5]         # N m


def perturbed_truth(path, seed=7):
    """The nominal UR5e and the 'true' arm: masses +-30 %, centers of mass +-2 cm (inertia
    about the center of mass scaled with the mass), friction on; written to ``path`` with
    the identification's URDF writer and loaded back."""
    nominal = sd.default_robot()
    rng = np.random.default_rng(seed)
    m = nominal.model
    phi = []
    for i in range(m.dof):
        scale = 1 + rng.choice([-0.3, 0.3])
        mass, com = m.mass[i] * scale, m.com[i] + rng.choice([-0.02, 0.02], 3)
        I_O = m.inertia[i] * scale + mass * (com @ com * np.eye(3) - np.outer(com, com))
        phi.append([mass, *(mass * com), I_O[0, 0], I_O[0, 1], I_O[1, 1], I_O[0, 2], I_O[1, 2],
                    I_O[2, 2]])
    urdf_out.write_urdf(sd.builtin_path("ur5e"), m, np.array(phi), VISCOUS, COULOMB, path)
    return nominal, sd.load_urdf(str(path))


def record(truth, ex, seed=1, noise=True):
    """Simulate ``truth`` following the excitation ``ex`` (computed torque on the true model
    with PD feedback and friction feed-forward at the reference speed; semi-implicit Euler
    with stick-slip friction, 1 kHz) and return (result, t, q, tau) as a sensor would record
    them: q quantized by the encoder, tau with white noise."""
    Kp = np.array([2500.0, 2500, 2500, 900, 900, 900])
    Kd = 2 * np.sqrt(Kp)

    def control(t, q, qd):
        qr, qdr, qddr = ex(t)
        return (truth.inverse_dynamics(q, qd, qddr + Kp * (qr - q) + Kd * (qdr - qd))
                - truth.dissipation.torque(qdr))

    res = sd.simulate(truth, ex.duration, ex(0.0)[0], None, control,
                      method="semi_implicit_euler", dt=1e-3)
    if not noise:
        return res, res.t, res.q, res.tau
    rng = np.random.default_rng(seed)
    q = np.round(res.q / ENCODER) * ENCODER
    tau = res.tau + rng.standard_normal(res.tau.shape) * TORQUE_NOISE
    return res, res.t, q, tau
