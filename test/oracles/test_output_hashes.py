"""Same inputs, same bits, across refactors: a SHA-256 of every public output.

The hashes in ``output_hashes.json`` were computed on the code before the layout change
of issue 18 (commit feff973); a refactor that moves code must leave every one of them
unchanged. An intended change of numbers (a new algorithm, another summation order)
regenerates the file, and says so in its commit:

    python test/oracles/test_output_hashes.py --write

What BLAS and LAPACK compute (NumPy's QR and solves, scipy's DOP853 steps: the QR route of
forward dynamics, the NumPy symplectic step and the inverse mass matrix of mimic joints, the adaptive simulations) is bitwise
reproducible on one machine only: OpenBLAS picks its kernels by processor (the same outputs
differ in their last bits between an AMD EPYC and an Intel Xeon, measured). Those outputs
(``through_blas``) are compared with their values as computed here before the trees issue
(``output_values.npz``, from commit 902364f on an Intel Xeon) to 1e-12 of their magnitude,
but the adaptive simulations: their step sizes come from an error estimate, a small
difference of large numbers, in which the processor's last bits move the chosen steps and
so the states at the step times by ~1e-7 of their magnitude (measured on an AMD EPYC of
family 26, Zen 5, where OpenBLAS picks other kernels than on the machines of earlier runs:
the planar 3R's DOP853 run moved by 2.5e-7 and matched again with
``OPENBLAS_CORETYPE=SkylakeX``); they are compared to
``ADAPTIVE_TOL`` of their magnitude. Every other output, the compiled kernels' own
arithmetic, is compared by its hash.

Robots: the default UR5e, the UR5e with armature, a chain with mimic joints, and the
planar 3R (the planar fast path). Outputs: inverse dynamics (with and without a tip
wrench and a moving base), bias and gravity torques, the mass matrix, forward dynamics
by every method, both derivatives, the regressor, for single states and a batch; a short
simulation by an adaptive and a fixed-step method.
"""
import hashlib
import json
import os
import sys
import zlib

import numpy as np
import pytest

import serial_dynamics as sd

HERE = os.path.dirname(os.path.abspath(__file__))
HASHES = os.path.join(HERE, "output_hashes.json")
VALUES = os.path.join(HERE, "output_values.npz")
N = 37          # a batch longer than one SIMD block, with a short tail
ADAPTIVE_TOL = 1e-5   # an adaptive run's states at its step times, of their magnitude

MIMIC = (   # j3 mimics j2 (1.5 q2 + 0.2), j4 mimics j1 (-0.7 q1); tilted axes
    '<robot name="mimic"><link name="base"/>'
    + "".join(
        f'<link name="{name}"><inertial><origin xyz="{c}" rpy="0.1 0.2 0.3"/>'
        f'<mass value="{m}"/><inertia ixx="{I[0]}" iyy="{I[1]}" izz="{I[2]}" ixy="0.001" '
        'ixz="-0.002" iyz="0.0015"/></inertial></link>'
        for name, m, c, I in [("l1", 2.0, "0.1 0 0.05", (0.05, 0.06, 0.04)),
                              ("l2", 1.5, "0.2 0.01 0", (0.03, 0.05, 0.04)),
                              ("l3", 1.0, "0.05 0.02 0.1", (0.02, 0.03, 0.025)),
                              ("l4", 0.5, "0.02 0 0.03", (0.01, 0.012, 0.009))])
    + "".join(
        f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>'
        '<limit lower="-2" upper="2" effort="100" velocity="5"/>'
        f'<dynamics damping="0.3" friction="0.1"/>{extra}</joint>'
        for name, parent, child, xyz, rpy, axis, extra in [
            ("j1", "base", "l1", "0 0 0.1", "0 0 0", "0 0 1", ""),
            ("j2", "l1", "l2", "0.3 0 0", "0.3 0 0", "0 1 0", ""),
            ("j3", "l2", "l3", "0.4 0 0", "0 0.2 0", "0 0.6 0.8",
             '<mimic joint="j2" multiplier="1.5" offset="0.2"/>'),
            ("j4", "l3", "l4", "0.2 0.1 0", "0.1 0 0", "0 0 1",
             '<mimic joint="j1" multiplier="-0.7"/>')])
    + "</robot>")


def robots():
    ur5e = sd.default_robot()
    return {
        "ur5e": ur5e,
        "ur5e+armature": sd.default_robot(armature={j: 0.05 * (k + 1)
                                                    for k, j in enumerate(ur5e.joint_names)}),
        "mimic": sd.load_urdf(MIMIC),
        "planar_3r": sd.builtin_robot("planar_3r"),
    }


def outputs(name, robot):
    """{key: float64 array} of every public output on fixed states."""
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    q, qd = robot.random_state(rng, batch=N, speed=2.0)
    qdd, tau = rng.uniform(-5, 5, (N, robot.dof)), rng.uniform(-20, 20, (N, robot.dof))
    w = rng.uniform(-10, 10, 6)
    bm = sd.BaseMotion((0.1, -0.2, 0.3), (0.5, 0.1, -0.4), (0.2, 0.3, -9.0))
    calls = {
        "inverse_dynamics": lambda s: robot.inverse_dynamics(q[s], qd[s], qdd[s]),
        "inverse_dynamics+wrench": lambda s: robot.inverse_dynamics(q[s], qd[s], qdd[s], wrench=w),
        "inverse_dynamics+base_motion": lambda s: robot.inverse_dynamics(q[s], qd[s], qdd[s],
                                                                         base_motion=bm),
        "bias_torques": lambda s: robot.bias_torques(q[s], qd[s]),
        "gravity_torques": lambda s: robot.gravity_torques(q[s]),
        "mass_matrix": lambda s: robot.mass_matrix(q[s]),
        **{f"forward_dynamics[{m}]": (lambda s, m=m: robot.forward_dynamics(q[s], qd[s], tau[s],
                                                                             method=m))
           for m in ("cholesky", "aba", "qr")},
        "forward_dynamics+wrench": lambda s: robot.forward_dynamics(q[s], qd[s], tau[s], wrench=w),
        "inverse_dynamics_derivatives": lambda s: np.stack(
            robot.inverse_dynamics_derivatives(q[s], qd[s], qdd[s], wrench=w)),
        "forward_dynamics_derivatives": lambda s: np.stack(
            robot.forward_dynamics_derivatives(q[s], qd[s], tau[s])),
        "regressor": lambda s: robot.regressor(q[s], qd[s], qdd[s], friction=True),
    }
    out = {}
    for key, f in calls.items():
        out[f"{name}/{key}/single"] = np.array([f(k) for k in range(N)])
        out[f"{name}/{key}/batch"] = np.asarray(f(slice(None)))
    for method, kw in (("DOP853", dict(rtol=1e-8, atol=1e-10)),
                       ("semi_implicit_euler", dict(dt=1e-3)),
                       ("symplectic_euler", dict(dt=1e-3))):
        res = sd.simulate(robot, 0.1, q[0], qd[0], torque=tau[0] * 0.1, method=method, **kw)
        out[f"{name}/simulate[{method}]"] = np.concatenate(
            [res.t, res.q.ravel(), res.qd.ravel()])
    return out


def digest(a):
    a = np.ascontiguousarray(a, dtype=np.float64)
    return hashlib.sha256(repr(a.shape).encode() + a.tobytes()).hexdigest()[:32]


def through_blas(key):
    """The outputs computed through BLAS/LAPACK, whose last bits depend on the processor."""
    return ("[qr]" in key or "[DOP853]" in key or key == "mimic/simulate[symplectic_euler]"
            or key.startswith("mimic/forward_dynamics_derivatives"))


def all_outputs():
    return {k: v for name, robot in robots().items() for k, v in outputs(name, robot).items()}


def test_every_output_is_bitwise_what_it_was():
    with open(HASHES) as f:
        expected = json.load(f)
    got = all_outputs()
    assert sorted(got) == sorted(expected), "the set of outputs changed: regenerate on purpose"
    changed = [k for k in expected if not through_blas(k) and digest(got[k]) != expected[k]]
    assert not changed, f"{len(changed)} outputs changed bits: {changed[:20]}"


def test_the_outputs_through_blas_are_what_they_were():
    values = np.load(VALUES)
    got = all_outputs()
    keys = sorted(k for k in got if through_blas(k))
    assert keys == sorted(values.files)
    for k in keys:
        scale = np.max(np.abs(values[k])) * (ADAPTIVE_TOL if "[DOP853]" in k else 1e-12)
        np.testing.assert_allclose(got[k], values[k], rtol=0, atol=scale, err_msg=k)


if __name__ == "__main__":
    if "--write" not in sys.argv:
        sys.exit(pytest.main([__file__, "-q"]))
    got = all_outputs()
    with open(HASHES, "w") as f:
        json.dump({k: digest(v) for k, v in got.items()}, f, indent=0, sort_keys=True)
    np.savez_compressed(VALUES, **{k: v for k, v in got.items() if through_blas(k)})
    print(f"wrote {HASHES} and {VALUES}")
