"""The joint types of the compiled core (``core/joint.py``), each checked against the spatial
algebra it stands for (Featherstone 2008, Ch. 2 and Table 4.1): S = e_2 (revolute) or e_5
(prismatic) in a spatial vector, angular first; and the rule that nothing else in the core
or the card's kernels asks a joint's type."""
import pathlib
import re

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.algorithms import _batch, joint as ref_joint, kinematics as ref_kinematics
from serial_dynamics.core import joint
from serial_dynamics.core.layout import pack
from serial_dynamics.builtin.synthetic import chain_urdf

KINDS = {"revolute": (joint.REVOLUTE, 2), "prismatic": (joint.PRISMATIC, 5)}
rng = np.random.default_rng(7)


def S(kind):
    return np.eye(6)[2 if kind == joint.REVOLUTE else 5]


@pytest.mark.parametrize("name", KINDS)
def test_the_subspace_and_its_projection(name):
    kind, s = KINDS[name]
    x = rng.normal(size=6)
    assert joint.axis(kind) == s
    assert joint.project(kind, x[2], x[5]) == S(kind) @ x                 # S^T x
    v = rng.normal(size=6)
    assert np.array_equal(joint.add_rate(kind, v[2], v[5], 0.7), (v + 0.7 * S(kind))[[2, 5]])


@pytest.mark.parametrize("name", KINDS)
def test_momentum_and_velocity_product(name):
    kind, _ = KINDS[name]
    m, h = 2.5, rng.normal(size=3)
    A = rng.normal(size=(3, 3))
    I_O = A @ A.T + np.eye(3)
    I = _batch.rigid_body_inertia(m, h, I_O)
    F = I @ S(kind)                                                          # F = I S
    got = joint.joint_momentum(kind, m, h[0], h[1], I_O[0, 2], I_O[1, 2], I_O[2, 2])
    np.testing.assert_allclose(got[:6], F, rtol=1e-15, atol=1e-15)
    assert got[6] == pytest.approx(S(kind) @ F, rel=1e-15)                   # S^T I S
    v, dq = rng.normal(size=6), 1.3
    c = _batch.cross_motion(v) @ (S(kind) * dq)                              # c = v x (S qd)
    np.testing.assert_allclose(joint.velocity_product(kind, v[0], v[1], v[3], v[4], dq), c,
                               rtol=1e-15, atol=1e-15)


@pytest.mark.parametrize("name", KINDS)
def test_the_rate_terms_are_the_references(name):
    kind, _ = KINDS[name]
    ref = {"revolute": 0, "prismatic": 1}[name]            # joints.py: Model.kind's codes
    w, a, l = (rng.normal(size=(1, 3)) for _ in range(3))
    dq, ddq = np.array([0.8]), np.array([-1.1])
    want = np.concatenate(ref_joint.joint_rate(ref, w, a, l, dq, ddq), axis=1)[0]
    got = joint.joint_rate(kind, *w[0], *a[0], *l[0], dq[0], ddq[0])
    np.testing.assert_allclose(got, want, rtol=1e-15, atol=1e-15)
    # the other world-axes steps of the two backends
    z, r = rng.normal(size=(1, 3)), rng.normal(size=(1, 3))
    np.testing.assert_allclose(np.concatenate(ref_joint.world_column(ref, z, r), axis=1)[0],
                               joint.world_column(kind, *z[0], *r[0]), rtol=1e-15, atol=1e-15)
    v, b = rng.normal(size=(1, 3)), rng.normal(size=(1, 3))
    wr, dwr, vr, ar = ref_joint.world_joint_rate(ref, w, b, v, a, z, dq, ddq)
    got = joint.world_joint_rate(kind, *w[0], *b[0], *a[0], *z[0], *np.cross(w, z)[0], dq[0], ddq[0])
    np.testing.assert_allclose(got, np.concatenate([wr, dwr, ar], axis=1)[0], rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(ref_joint.add_rate(ref, w, v, z, dq)[1 if ref else 0],
                               (v if ref else w) + z * 0.8, rtol=1e-15)


@pytest.mark.parametrize("name", KINDS)
def test_world_axes(name):
    kind, _ = KINDS[name]
    z = rng.normal(size=3)
    z /= np.linalg.norm(z)
    r, w, v, qd, qdd = (rng.normal(size=3) for _ in range(5))
    rev = kind == joint.REVOLUTE
    column = np.concatenate([np.cross(z, r), z]) if rev else np.concatenate([z, np.zeros(3)])
    np.testing.assert_allclose(joint.world_column(kind, *z, *r), column, rtol=1e-15, atol=1e-15)
    want = np.concatenate([w + z * 0.4, v] if rev else [w, v + z * 0.4])
    np.testing.assert_allclose(joint.world_rate(kind, *w, *v, *z, 0.4), want, rtol=1e-15, atol=1e-15)
    h, b, acc = np.cross(w, z), rng.normal(size=3), rng.normal(size=3)
    want = (np.concatenate([w + z * 0.4, b + z * 0.9 + h * 0.4, acc]) if rev
            else np.concatenate([w, b, acc + z * 0.9 + 2.0 * h * 0.4]))
    got = joint.world_joint_rate(kind, *w, *b, *acc, *z, *h, 0.4, 0.9)
    np.testing.assert_allclose(got, want, rtol=1e-15, atol=1e-15)


def test_the_transforms_are_the_references_on_both_kinds():
    model = sd.load_urdf(chain_urdf(6, kinds=["revolute", "prismatic"] * 3)).model
    P = pack(model)
    q = rng.uniform(-2, 2, size=6)
    R, p = ref_kinematics.joint_transforms(model, q[None])
    for i in range(6):
        r, px, py, pz = joint.joint_transform(P, i, np.sin(q[i]), np.cos(q[i]), q[i])
        np.testing.assert_allclose(np.reshape(r, (3, 3)), R[0, i], rtol=0, atol=1e-15)
        np.testing.assert_allclose((px, py, pz), p[0, i], rtol=0, atol=1e-15)


def asking(folder, pattern, allowed=("joint.py",)):
    root = pathlib.Path(joint.__file__).parents[1]
    return [f"{f.relative_to(root)}:{k + 1}" for f in sorted((root / folder).glob("*.py"))
            if f.name not in allowed for k, line in enumerate(f.read_text().splitlines())
            if re.search(pattern, line)]


def test_no_kernel_asks_a_joint_type_but_joint_py():
    """A joint's type is asked in core/joint.py only (spatial_v2's jcalc): every other kernel
    of the core and of the card calls it; the reference's in algorithms/joint.py (the planar
    packer and the NOC's constraint rows spell the two types out, their docstrings say)."""
    assert asking("core", r"KIND\]\s*[=!]=") == []
    assert asking("gpu", r"KIND\]\s*[=!]=") == []
    assert asking("algorithms", r"PRISMATIC|REVOLUTE", ("joint.py", "planar.py", "noc.py")) == []
