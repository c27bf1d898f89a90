"""sweep.run on a real LocalCluster of two worker processes: the table equals the one
computed in this process bit for bit, a failing case is one row with its message, and a
worker killed (SIGKILL) mid-run loses no case and counts none twice."""
import os
import signal

import numpy as np
import pandas as pd
import pytest

import serial_dynamics as sd
from serial_dynamics import sweep
from serial_dynamics.sweep.run import chunks

distributed = pytest.importorskip("distributed")

ROBOT = sd.default_robot().with_payload(1.2, (0.0, 0.01, 0.04))   # travels to the workers


def dynamics(case):
    """Outputs that depend on every bit of the robot and the case; case 7 raises."""
    if case["k"] == 7:
        raise ValueError(f"case {case['k']} is refused on purpose")
    q = np.linspace(-1.0, 1.0, ROBOT.dof) * case["x"]
    qd = np.cos(q) * case["y"]
    tau = ROBOT.inverse_dynamics(q, qd, q)
    qdd = ROBOT.forward_dynamics(q, qd, tau[::-1].copy())
    out = {"tau_sum": float(np.sum(tau)), "qdd_0": qdd[0], "label": f"case-{case['k']}",
           "big": bool(abs(tau[1]) > 20)}
    out.update({f"M{i}": ROBOT.mass_matrix(q)[i, i] for i in range(ROBOT.dof)})
    return out


def dies_once(case):
    """The worker that first runs case 5 dies (SIGKILL) there; its task reruns elsewhere.
    Each run of a case leaves a file, so a case that ran twice is visible."""
    marker = os.path.join(case["folder"], "killed")
    with open(os.path.join(case["folder"], f"ran-{case['k']}-{os.getpid()}"), "w"):
        pass
    if case["k"] == 5 and not os.path.exists(marker):
        open(marker, "w").close()
        os.kill(os.getpid(), signal.SIGKILL)
    return {"square": case["k"] ** 2}


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=":0") as cluster, \
            distributed.Client(cluster) as c:
        yield c


def cases():
    rng = np.random.default_rng(5)
    return pd.DataFrame({"k": np.arange(40), "x": rng.uniform(-2, 2, 40),
                         "y": rng.uniform(-3, 3, 40)})


def assert_same_bits(a, b):
    pd.testing.assert_frame_equal(a, b, check_exact=True)
    for col in a.columns:
        if a[col].dtype == float:
            assert a[col].to_numpy().tobytes() == b[col].to_numpy().tobytes(), col


def test_cluster_table_equals_in_process_bit_for_bit(client):
    here = sweep.run(dynamics, cases(), client="serial")
    there = sweep.run(dynamics, cases(), client=client, progress=False)
    one_case_a_task = sweep.run(dynamics, cases(), client=client, progress=False, chunk_size=1)
    assert_same_bits(here, there)
    assert_same_bits(here, one_case_a_task)
    assert list(here.columns[:3]) == ["k", "x", "y"] and here.columns[-1] == "error"
    assert list(here["k"]) == list(range(40))
    # the values are the robot's: recomputed here for a case that ran on a worker
    q = np.linspace(-1.0, 1.0, 6) * here.loc[3, "x"]
    assert there.loc[3, "tau_sum"] == float(np.sum(ROBOT.inverse_dynamics(q, np.cos(q) * here.loc[3, "y"], q)))


def test_a_failing_case_is_one_row_with_its_message(client):
    table = sweep.run(dynamics, cases(), client=client, progress=False)
    failed = table[table["error"] != ""]
    assert list(failed["k"]) == [7]
    assert failed["error"].iloc[0] == "ValueError: case 7 is refused on purpose"
    assert np.isnan(failed["tau_sum"].iloc[0]) and table["tau_sum"].notna().sum() == 39
    # a function that returns no dict, or a name of a case column: the case's row says so
    bad = sweep.run(lambda case: case["k"], [{"k": 1}], client="serial")
    assert bad["error"][0] == "the sweep function returned int; it must return a dict of outputs"
    clash = sweep.run(lambda case: {"k": 2}, [{"k": 1}], client="serial")
    assert "'k', which is a case column" in clash["error"][0]


def test_a_killed_worker_loses_no_case(client, tmp_path):
    pids = set(client.run(os.getpid).values())
    table = sweep.run(dies_once, [{"k": k, "folder": str(tmp_path)} for k in range(24)],
                      client=client, progress=False, chunk_size=3)
    assert (tmp_path / "killed").exists()                       # a worker did die
    assert len(pids - set(client.run(os.getpid).values())) == 1  # and left the cluster
    assert list(table["k"]) == list(range(24))                  # every case, once, in order
    assert list(table["square"]) == [k * k for k in range(24)]
    assert (table["error"] == "").all()
    ran = [p.name.split("-") for p in tmp_path.glob("ran-*")]
    assert {int(k) for _, k, _ in ran} == set(range(24))
    # case 5's task ran twice (killed, then rerun); the table holds it once
    assert sum(int(k) == 5 for _, k, _ in ran) == 2
    client.wait_for_workers(2, timeout=60)                      # the nanny restarted it


def test_no_cases_and_bad_arguments():
    empty = sweep.run(dynamics, [], client="serial")
    assert list(empty.columns) == ["error"] and len(empty) == 0
    with pytest.raises(ValueError, match="client = 'tcp://nowhere'"):
        sweep.run(dynamics, [{"k": 1}], client="tcp://nowhere")
    with pytest.raises(ValueError, match="case 1 is of type int"):
        sweep.run(dynamics, [{"k": 1}, 2], client="serial")
    with pytest.raises(ValueError, match="chunk_size = 0"):
        chunks(10, 2, 0)
