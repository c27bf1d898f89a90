"""Small helpers shared by the algorithms: batching, and 3-vector and spatial (6-vector)
algebra on stacks of arrays."""
import numpy as np



def as_batch(model, *states, finite=True):
    """Return (single, arrays...) with every state as an (N, n) float array.

    ``None`` becomes zeros. Raises ValueError naming the argument on a wrong length or (with
    ``finite``) a NaN/Inf entry. A caller whose kernel reports a NaN/Inf itself passes
    ``finite=False`` and calls again with it on that report, for the error.
    """
    n = model.dof
    single = None
    out = []
    N = 1
    for name, x in states:
        if x is None:
            out.append(None)
            continue
        a = np.asarray(x, dtype=float)
        if a.ndim == 1 and a.shape[0] == n:
            s = True
            a = a[None, :]
        elif a.ndim == 2 and a.shape[1] == n:
            s = False
        else:
            raise ValueError(f"{name} has shape {a.shape}; expected ({n},) or (N, {n}) "
                             f"for the {n} joints {list(model.joint_names)}")
        if finite and not np.all(np.isfinite(a)):
            j = np.argwhere(~np.isfinite(a))[0][-1]
            raise ValueError(f"{name} has a NaN or Inf entry (joint {model.joint_names[j]!r}); "
                             "states must be finite numbers")
        single = s if single is None else (single and s)
        N = max(N, a.shape[0])
        out.append(a)
    N_set = {a.shape[0] for a in out if a is not None} - {1}
    if len(N_set) > 1:
        raise ValueError(f"batch sizes differ: {sorted(N_set)}; give states with the same N")
    out = [np.zeros((N, n)) if a is None else np.broadcast_to(a, (N, n)) for a in out]
    return (True if single is None else single), out


def require_chain(model, what):
    """Raise NotImplementedError for ``what`` on a tree: the algorithms written for chains
    only (the Coriolis matrix, the regressor, the derivatives, dT/dq) name themselves."""
    if not model.is_chain:
        forks = sorted({int(l) for l in model.parent if np.sum(model.parent == l) > 1})
        at = [model.base_link if l < 0 else model.link_names[l] for l in forks]
        raise NotImplementedError(
            f"{what} is computed for chains only so far, and this model is a tree (its joints "
            f"branch at {at}); load one chain with tip_link=... for it (a simulation: "
            "jacobian='finite_differences' for the implicit methods, another method for "
            "symplectic_euler)")


def unbatch(single, x):
    return x[0] if single else x


def mv(R, v):
    """R @ v over stacks: R (..., 3, 3), v (..., 3)."""
    return np.einsum("...ij,...j->...i", R, v)


def mtv(R, v):
    """R.T @ v over stacks."""
    return np.einsum("...ji,...j->...i", R, v)


def skew(v):
    """[v]x over stacks: (..., 3) -> (..., 3, 3)."""
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S


def rotation_about(axis, angle):
    """Rotation by ``angle`` (N,) about the unit ``axis`` (3,): Rodrigues' formula
    R = 1 + sin(a) [k]x + (1 - cos(a)) [k]x^2."""
    K = skew(np.asarray(axis, dtype=float))
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def rot_z(angle):
    """Rz(q) (N, 3, 3): rotation by ``angle`` (N,) about e_z, a revolute joint's motion."""
    c, s = np.cos(angle), np.sin(angle)
    R = np.zeros(np.shape(angle) + (3, 3))
    R[..., 0, 0], R[..., 0, 1], R[..., 1, 0], R[..., 1, 1] = c, -s, s, c
    R[..., 2, 2] = 1.0
    return R


# -- spatial algebra (Featherstone 2008, Ch. 2): angular part first, about the frame origin
def rigid_body_inertia(mass, h, I_O):
    """6x6 rigid-body inertia about the body origin from the mass m, first moment h = m c
    and rotational inertia I_O about the origin: [[I_O, [h]x], [[h]x^T, m 1]] (eq. 2.63)."""
    H = skew(np.asarray(h, dtype=float))
    m = np.asarray(mass, dtype=float)[..., None, None]
    out = np.zeros(np.shape(mass) + (6, 6))
    out[..., :3, :3] = I_O
    out[..., :3, 3:] = H
    out[..., 3:, :3] = np.swapaxes(H, -1, -2)
    out[..., 3:, 3:] = m * np.eye(3)
    return out


def motion_transform(R, p):
    """X carrying motion vectors from the parent frame into the child frame, for the child
    rotation R and origin p given in the parent: [[R^T, 0], [-R^T [p]x, R^T]] (Sec. 2.8)."""
    Rt = np.swapaxes(R, -1, -2)
    X = np.zeros(R.shape[:-2] + (6, 6))
    X[..., :3, :3] = Rt
    X[..., 3:, 3:] = Rt
    X[..., 3:, :3] = -Rt @ skew(p)
    return X


def cross_motion(v):
    """[v]x of a spatial motion vector v = (omega, u): [[omega x, 0], [u x, omega x]], Sec. 2.9."""
    out = np.zeros(v.shape[:-1] + (6, 6))
    W, U = skew(v[..., :3]), skew(v[..., 3:])
    out[..., :3, :3] = W
    out[..., 3:, 3:] = W
    out[..., 3:, :3] = U
    return out
