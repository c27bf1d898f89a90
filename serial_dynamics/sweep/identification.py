"""``sweep.identify_recordings``: identification over many recordings (a fleet's arms, many
runs of one arm) through ``sweep.run``, one row per recording.

Each recording (a CSV file as ``SimulationResult.to_csv`` writes it, or a ROS 2 bag) is cut
in time: ``identification.identify`` fits the first ``1 - holdout`` of it and validates
the identified model on the rest (torques predicted against measured, filtered alike).
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..identification import identify, load_recording
from .run import run

SUFFIXES = (".csv", ".mcap", ".db3")


def identify_recordings(robot, recordings, *, holdout=0.3, method="wls", friction=True,
                        topic="/joint_states", client=None, progress=True, workers=None):
    """A table, one row per recording: ``recording`` (its path), ``samples``,
    ``condition_number`` of the base regressor, ``fit_rms`` (N m, the fit's residual),
    ``validation_error`` (relative, all joints; ``Validation.total``) and
    ``validation_rms_<joint>`` (N m), and ``error`` for a recording that could not be
    identified. recordings: a folder (its .csv, .mcap and .db3 files and bag directories,
    by name) or a list of paths. client, progress, workers: as ``sweep.run``."""
    job = Identification(robot, holdout, method, friction, topic)
    return run(job, [{"recording": p} for p in find_recordings(recordings)], client, progress,
               workers=workers)


def find_recordings(recordings):
    """The recordings' paths, sorted by name for a folder."""
    if isinstance(recordings, (str, os.PathLike)):
        folder = Path(recordings)
        if not folder.is_dir():
            raise ValueError(f"recordings {os.fspath(recordings)!r} is not a folder; give a "
                             "folder of .csv files or ROS 2 bags, or a list of paths")
        paths = sorted(p for p in folder.iterdir() if p.suffix.lower() in SUFFIXES
                       or (p.is_dir() and (p / "metadata.yaml").exists()))
        if not paths:
            raise ValueError(f"folder {os.fspath(folder)!r} holds no recording (.csv, .mcap, "
                             ".db3, or a bag directory with metadata.yaml)")
        return [os.fspath(p) for p in paths]
    return [os.fspath(p) for p in recordings]


class Identification:
    """One recording: ``Identification(...)(case) -> dict`` (picklable)."""

    def __init__(self, robot, holdout, method, friction, topic):
        if not 0 < holdout < 1:
            raise ValueError(f"holdout = {holdout!r}; give the fraction of each recording kept "
                             "for validation, between 0 and 1")
        self.robot, self.holdout, self.method = robot, float(holdout), method
        self.friction, self.topic = bool(friction), topic

    def __call__(self, case):
        rec = load_recording(case["recording"], self.robot.joint_names, self.topic)
        k = int(round(rec.t.size * (1.0 - self.holdout)))
        qd = (None, None) if rec.qd is None else (rec.qd[:k], rec.qd[k:])
        res = identify(self.robot, rec.t[:k], rec.q[:k], rec.tau[:k], qd[0],
                       friction=self.friction, method=self.method,
                       validation=(rec.t[k:], rec.q[k:], rec.tau[k:], qd[1]))
        out = {"samples": int(rec.t.size), "condition_number": float(res.condition_number),
               "fit_rms": float(np.sqrt(np.mean(res.residual**2))),
               "validation_error": float(res.validation.total)}
        for name, rms in zip(self.robot.joint_names, res.validation.rms):
            out[f"validation_rms_{name}"] = float(rms)
        return out
