"""Recordings for identification, in the formats users have.

- CSV with a header ``t, q_<joint>..., qd_<joint>..., tau_<joint>...`` (any other column is
  ignored): what ``SimulationResult.to_csv`` writes.
- A ROS 2 bag (a directory with ``metadata.yaml``, sqlite3 ``.db3`` or ``.mcap`` storage,
  or one ``.mcap`` file) of ``sensor_msgs/msg/JointState`` (position, velocity, effort),
  read with the ``rosbags`` library from PyPI (no ROS install needed); joints are matched
  by name, so the message may list them in any order and carry others.

Every reader returns a ``Recording`` whose columns follow the robot's joint order.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

JOINT_STATE = "sensor_msgs/msg/JointState"


@dataclass(frozen=True, eq=False)
class Recording:
    """Samples of a run: t (N,), q, tau (N, n), qd (N, n) or None; joint_names (n)."""

    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    qd: np.ndarray | None
    joint_names: tuple
    source: str = ""


def load_recording(path, joint_names, topic="/joint_states") -> Recording:
    """A CSV file or a ROS 2 bag (by its path), columns in ``joint_names`` order."""
    p = Path(path)
    if not p.exists():
        raise ValueError(f"recording {os.fspath(path)!r} not found; give a .csv file or a "
                         "ROS 2 bag (its directory, or a .mcap/.db3 file)")
    if p.suffix.lower() == ".csv":
        return read_csv(p, joint_names)
    if p.is_dir() or p.suffix.lower() in (".mcap", ".db3"):
        return read_bag(p, joint_names, topic)
    raise ValueError(f"{os.fspath(path)!r}: give a .csv file (t, q_<joint>, qd_<joint>, "
                     "tau_<joint>) or a ROS 2 bag (its directory, or a .mcap/.db3 file)")


def read_csv(path, joint_names) -> Recording:
    """A CSV as ``SimulationResult.to_csv`` writes it (t, q_*, qd_*, tau_*)."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ValueError(f"recording {path!r} not found")
    with open(path) as f:
        head = [h.strip() for h in f.readline().lstrip("#").split(",")]
    table = np.genfromtxt(path, delimiter=",", skip_header=1, dtype=float, ndmin=2)
    if table.size == 0:
        raise ValueError(f"{path!r} has no samples below its header")
    column = {h: k for k, h in enumerate(head)}
    if "t" not in column:
        raise ValueError(f"{path!r} has no column 't' (time, s); its columns are {head}")

    def block(prefix, required=True):
        missing = [f"{prefix}{j}" for j in joint_names if f"{prefix}{j}" not in column]
        if missing:
            if not required:
                return None
            raise ValueError(f"{path!r} has no column {missing[0]!r} (nor {missing[1:]}); "
                             f"identification needs t, q_<joint> and tau_<joint> for the joints "
                             f"{list(joint_names)}; its columns are {head}")
        return table[:, [column[f"{prefix}{j}"] for j in joint_names]]

    return Recording(table[:, column["t"]], block("q_"), block("tau_"), block("qd_", False),
                     tuple(joint_names), path)


def read_bag(path, joint_names, topic="/joint_states") -> Recording:
    """JointState messages on ``topic`` of a ROS 2 bag (sqlite3 or MCAP). Times are the
    messages' header stamps (the bag's receive times where a stamp is zero), from the first
    one, in seconds (computed in integer nanoseconds: no rounding of 1.7e9 s stamps)."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    path = Path(path)
    bag = path.parent if path.is_file() and path.suffix == ".db3" else path
    if not bag.exists():
        raise ValueError(f"bag {os.fspath(path)!r} not found")
    with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        conns = [c for c in reader.connections if c.topic == topic]
        if not conns:
            topics = sorted({f"{c.topic} ({c.msgtype})" for c in reader.connections})
            raise ValueError(f"bag {os.fspath(path)!r} has no topic {topic!r}; it has {topics}")
        if conns[0].msgtype != JOINT_STATE:
            raise ValueError(f"topic {topic!r} of bag {os.fspath(path)!r} carries "
                             f"{conns[0].msgtype}, not {JOINT_STATE}")
        t, q, qd, tau = [], [], [], []
        for conn, stamp, raw in reader.messages(connections=conns):
            msg = reader.deserialize(raw, conn.msgtype)
            index = {name: k for k, name in enumerate(msg.name)}
            if any(j not in index for j in joint_names):
                continue                       # another group's joint states
            k = [index[j] for j in joint_names]
            ns = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec   # exact integers
            t.append(ns if ns > 0 else stamp)
            q.append(_field(msg.position, k))
            qd.append(_field(msg.velocity, k))
            tau.append(_field(msg.effort, k))
    where = f"topic {topic!r} of bag {os.fspath(path)!r}"
    if not t:
        raise ValueError(f"{where} has no JointState naming all of the joints {list(joint_names)}")
    for name, values in (("position", q), ("effort", tau)):
        if any(v is None for v in values):
            raise ValueError(f"{where}: messages without {name} for the joints; identification "
                             "needs position and effort")
    t = np.asarray(t, dtype=np.int64)
    order = np.argsort(t, kind="stable")
    qd = None if any(v is None for v in qd) else np.asarray(qd)[order]
    return Recording(1e-9 * (t[order] - t[order][0]), np.asarray(q)[order],
                     np.asarray(tau)[order], qd, tuple(joint_names), os.fspath(path))


def _field(values, k):
    values = np.asarray(values, dtype=float)
    return values[k] if values.size else None


def write_bag(path, t, q, qd, tau, joint_names, topic="/joint_states", storage="sqlite3",
              t0=1_700_000_000):
    """Write sensor_msgs/JointState samples to a new ROS 2 bag directory ``path``
    (``storage`` "sqlite3" or "mcap"), stamped ``t0 + t`` (``t0`` whole seconds)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_JAZZY)
    JointState, Header = ts.types[JOINT_STATE], ts.types["std_msgs/msg/Header"]
    Time = ts.types["builtin_interfaces/msg/Time"]
    plugin = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}[storage]
    empty = np.zeros(0)
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        conn = writer.add_connection(topic, JOINT_STATE, typestore=ts)
        for k, tk in enumerate(np.asarray(t, dtype=float)):
            ns = int(t0) * 10**9 + int(round(tk * 1e9))         # exact integers
            row = lambda x: np.ascontiguousarray(x[k], dtype=float)   # noqa: E731
            msg = JointState(Header(Time(ns // 10**9, ns % 10**9), ""), list(joint_names),
                             row(q), empty if qd is None else row(qd), row(tau))
            writer.write(conn, ns, ts.serialize_cdr(msg, JOINT_STATE))
