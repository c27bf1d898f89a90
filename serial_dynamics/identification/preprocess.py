"""From a recording to the samples identification uses: checks (NaN, shapes, too few
samples), a uniform time grid, zero-phase low-pass filtering, derivatives, decimation.

Filtering (Gautier, "Dynamic identification of robots with power model", ICRA 1997;
Gautier & Poignet 2001, "parallel filtering"): q is low-passed by a Butterworth filter run
forward and backward (scipy.signal.filtfilt: zero phase, so no delay between q and tau),
then differentiated by central differences (np.gradient): qd = dq/dt, qdd = dqd/dt. A
given qd is filtered the same way and qdd taken from it. The regressor Y(q, qd, qdd) is
formed at every sample, and then tau *and every column of Y* pass through the same filter
(parallel filtering: F(tau) = F(Y) phi holds exactly for the linear filter F, also for
the Coulomb column sign(qd), whose steps the filter rounds on both sides alike); then
every ``decimate``-th sample is kept, by default down to twice the cutoff: the filter
removed what that rate would alias, and the kept samples' noise is then nearly
uncorrelated, which the standard deviations of least squares assume (at 4 times the
cutoff they came out 1.5 times too small in the closed-loop test).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, filtfilt


@dataclass(frozen=True, eq=False)
class Samples:
    """Samples: t (N,), q, qd, qdd, tau (N, n) (``prepare``: every sample, tau not yet
    filtered; ``regression``: filtered, decimated); and the filter."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    rate: float            # Hz of the recording (after any resampling)
    cutoff: float          # Hz of the low-pass filter (inf: none)
    decimate: int
    resampled: bool
    low: object = None     # the zero-phase filter, x (N, ...) -> x (N, ...)
    edge: int = 0          # samples dropped at each end (the filter's transients)


def check_recording(t, q, tau, qd, qdd, joint_names):
    """Arrays as float, shapes checked, NaN/Inf named by column and time."""
    n = len(joint_names)
    t = np.asarray(t, dtype=float).reshape(-1)
    out = {}
    for name, x in (("q", q), ("tau", tau), ("qd", qd), ("qdd", qdd)):
        if x is None:
            out[name] = None
            continue
        x = np.asarray(x, dtype=float)
        if x.ndim != 2 or x.shape != (t.size, n):
            raise ValueError(f"{name} has shape {x.shape}; give ({t.size}, {n}): one row per "
                             f"time sample, one column per joint {list(joint_names)}")
        out[name] = x
    if not np.all(np.isfinite(t)):
        k = int(np.flatnonzero(~np.isfinite(t))[0])
        raise ValueError(f"time sample {k} is {t[k]}; remove that sample (or fix the clock)")
    for name, x in out.items():
        if x is not None and not np.all(np.isfinite(x)):
            k, j = np.argwhere(~np.isfinite(x))[0]
            bad = int(np.count_nonzero(~np.all(np.isfinite(x), axis=1)))
            raise ValueError(f"{name}_{joint_names[j]} is {x[k, j]} at t = {t[k]:.6g} s "
                             f"(sample {k}; {bad} samples have a NaN or Inf); drop or "
                             "interpolate those samples before identifying")
    if t.size > 1 and np.any(np.diff(t) <= 0):
        k = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise ValueError(f"times must increase: t[{k + 1}] = {t[k + 1]:.6g} s follows "
                         f"t[{k}] = {t[k]:.6g} s; sort the samples and drop duplicates")
    return t, out["q"], out["tau"], out["qd"], out["qdd"]


def prepare(t, q, tau, qd=None, qdd=None, cutoff=None, decimate=None, order=4):
    """Samples for identification (module docstring). ``cutoff``: Hz of the low-pass filter
    (default: a fifth of the sampling rate, at most 10 Hz; ``np.inf``: no filter, for data
    that is already smooth and comes with qd and qdd); ``decimate``: keep every k-th sample
    (default: down to twice the cutoff). Non-uniform times are first resampled
    (linear interpolation) onto a uniform grid at the median step."""
    dt = np.diff(t)
    h = float(np.median(dt))
    resampled = bool(np.max(np.abs(dt - h)) > 0.01 * h)
    if resampled:
        grid = t[0] + h * np.arange(int(np.floor((t[-1] - t[0]) / h + 1e-9)) + 1)
        interp = lambda x: None if x is None else np.column_stack(   # noqa: E731
            [np.interp(grid, t, x[:, j]) for j in range(x.shape[1])])
        t, q, tau, qd, qdd = grid, interp(q), interp(tau), interp(qd), interp(qdd)
    rate = 1.0 / h
    cutoff = min(10.0, rate / 5) if cutoff is None else float(cutoff)
    if np.isfinite(cutoff):
        if not 0 < cutoff < 0.5 * rate:
            raise ValueError(f"cutoff = {cutoff:g} Hz; give 0 < cutoff < {0.5 * rate:g} Hz "
                             f"(half the sampling rate, {rate:g} Hz)")
        b, a = butter(order, cutoff / (0.5 * rate))
        pad = 3 * max(len(a), len(b))
        if t.size <= pad:
            raise ValueError(f"{t.size} samples are too few to filter; record at least "
                             f"{pad + 1}")
        low = lambda x: filtfilt(b, a, x, axis=0)                    # noqa: E731
    else:
        low = lambda x: x                                            # noqa: E731
    if qdd is not None and qd is not None and not np.isfinite(cutoff):
        qf, qdf, qddf = q, qd, qdd
    else:
        qf = low(q)
        qdf = low(qd) if qd is not None else np.gradient(qf, h, axis=0)
        qddf = low(qdd) if qdd is not None else np.gradient(qdf, h, axis=0)
    if decimate is None:
        decimate = max(1, int(round(rate / (2 * cutoff)))) if np.isfinite(cutoff) else 1
    decimate = int(decimate)
    if decimate < 1:
        raise ValueError(f"decimate = {decimate}; give an integer >= 1")
    # the filter's start and end transients: one period of the cutoff at each end
    edge = int(np.ceil(rate / cutoff)) if np.isfinite(cutoff) else 0
    return Samples(t, qf, qdf, qddf, tau, rate, cutoff, decimate, resampled, low, edge)


def regression(robot, s, friction):
    """(samples, Y): tau and the regressor Y (N, n, p) at the samples ``s`` (``prepare``),
    both filtered by the same zero-phase filter, the ends dropped, decimated."""
    Y = robot.regressor(s.q, s.qd, s.qdd, friction=friction)
    N = s.t.size
    keep = slice(s.edge, N - s.edge, s.decimate)
    if N - 2 * s.edge <= 0:
        raise ValueError(f"{N} samples are too few to filter at {s.cutoff:g} Hz: its start "
                         f"and end transients take {s.edge} samples each; record longer")
    Yf = s.low(Y.reshape(N, -1)).reshape(Y.shape)[keep]
    out = Samples(s.t[keep], s.q[keep], s.qd[keep], s.qdd[keep], s.low(s.tau)[keep], s.rate,
                  s.cutoff, s.decimate, s.resampled, s.low, s.edge)
    return out, Yf
