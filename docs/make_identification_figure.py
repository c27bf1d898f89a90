"""The example run of docs/identification.md, end to end, and its figure
docs/identification_fit.png:

1. a 'true' UR5e whose URDF differs from the nominal one (every mass +-30 %, every center
   of mass +-2 cm, viscous and Coulomb friction on every joint: test/ident_helpers.py);
2. ``serial-dynamics excite`` for the nominal URDF: a 20 s Fourier excitation (CSV);
3. the true arm simulated following it and a second, 10 s excitation (computed torque
   with PD feedback, stick-slip friction, 1 kHz), recorded as a sensor would (20-bit
   encoders, torque noise 1 N m / 0.2 N m): the first as the CSV ``SimulationResult.to_csv``
   writes, the second as a ROS 2 bag (MCAP);
4. ``serial-dynamics identify`` with the nominal URDF, validated on the bag, physically
   consistent, writing the corrected URDF and the fit plot;
5. the corrected URDF against the truth.

Run: .venv/bin/python docs/make_identification_figure.py   (about a minute)
"""
import os
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "test"))

import serial_dynamics as sd                                   # noqa: E402
from serial_dynamics import identification as ident           # noqa: E402
from serial_dynamics.cli import main                           # noqa: E402
from ident_helpers import perturbed_truth, record              # noqa: E402


def run():
    d = tempfile.mkdtemp(prefix="identification_example_")
    nominal, truth = perturbed_truth(os.path.join(d, "truth.urdf"))
    urdf = sd.builtin_path("ur5e")

    start = time.perf_counter()
    print("$ serial-dynamics excite ur5e.urdf --duration 20 --out traj.csv")
    main(["excite", urdf, "--duration", "20", "--out", os.path.join(d, "traj.csv"), "--quiet"])
    print(f"[{time.perf_counter() - start:.1f} s]")
    ex = ident.excitation(nominal, 20.0)                 # the same (deterministic) trajectory
    ex2 = ident.excitation(nominal, 10.0, seed=1, maxiter=3)
    res1, t1, q1, tau1 = record(truth, ex, seed=1)
    res2, t2, q2, tau2 = record(truth, ex2, seed=2)
    res1.q[:], res1.tau[:] = q1, tau1                    # what the sensors saw
    res1.to_csv(os.path.join(d, "run.csv"))
    ident.write_bag(os.path.join(d, "validation_bag"), t2, q2, None, tau2, nominal.joint_names,
                    storage="mcap")
    print(f"recorded: {t1.size} + {t2.size} samples at 1 kHz "
          f"(tracking error of the first run {np.max(np.abs(res1.q - ex(res1.t)[0])):.2g} rad)")

    start = time.perf_counter()
    out_urdf = os.path.join(d, "identified.urdf")
    print("\n$ serial-dynamics identify ur5e.urdf run.csv --validate validation_bag "
          "--method physical --out identified.urdf --plot fit.png")
    main(["identify", urdf, os.path.join(d, "run.csv"), "--validate",
          os.path.join(d, "validation_bag"), "--method", "physical", "--out", out_urdf,
          "--plot", os.path.join(HERE, "identification_fit.png")])
    print(f"[{time.perf_counter() - start:.1f} s]")

    # how close is the corrected URDF to the truth?
    rec = ident.load_recording(os.path.join(d, "run.csv"), nominal.joint_names)
    for method in ("wls", "physical"):
        r = ident.identify(nominal, rec.t, rec.q, rec.tau, rec.qd, method=method,
                           validation=(t2, q2, tau2))
        b_true = r.bp.beta(truth.inertial_parameters(friction=True))
        z = (r.beta - b_true) / r.std
        worst = int(np.argmax(np.abs(z)))
        print(f"\n{method}: |beta - beta_true| / std: max {np.abs(z).max():.2f} "
              f"({r.names[worst]}), RMS {np.sqrt(np.mean(z ** 2)):.2f}; bodies physical: "
              f"{int(np.sum(r.physical()))} of 6; validation relative error "
              f"{100 * r.validation.total:.2f} %, RMS per joint {np.round(r.validation.rms, 3)}")
    identified = sd.load_urdf(out_urdf)
    bp = ident.base_parameters(identified, friction=True)
    k = [i for i, name in enumerate(bp.names) if not name.startswith("fo")]
    dist = lambda robot: np.linalg.norm(                                   # noqa: E731
        (bp.beta(robot.inertial_parameters(friction=True)) - bp.beta(
            truth.inertial_parameters(friction=True)))[k])
    print(f"\ndistance of the base parameters to the truth: nominal URDF {dist(nominal):.3g}, "
          f"identified URDF {dist(identified):.3g}")
    print("masses (kg), nominal / true / identified URDF:")
    for i, link in enumerate(nominal.link_names):
        print(f"  {link:<15} {nominal.model.mass[i]:7.3f} {truth.model.mass[i]:7.3f} "
              f"{identified.model.mass[i]:7.3f}")
    print(f"friction viscous true {truth.dissipation.viscous.tolist()}, identified "
          f"{np.round(identified.dissipation.viscous, 3).tolist()}")
    print(f"friction Coulomb true {truth.dissipation.coulomb.tolist()}, identified "
          f"{np.round(identified.dissipation.coulomb, 3).tolist()}")


if __name__ == "__main__":
    run()
