"""Small helpers shared by the algorithms: batching and 3-vector algebra on stacks."""
import numpy as np


def as_batch(model, *states):
    """Return (single, arrays...) with every state as an (N, n) float array.

    ``None`` becomes zeros. Raises ValueError naming the argument on a wrong length or a
    NaN/Inf entry.
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
        if not np.all(np.isfinite(a)):
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
