"""Study specs and ``serial-dynamics sweep``: a bad field is refused before any work starts,
naming the field; the command runs against a scheduler and workers started with the
``dask`` command (127.0.0.1 only) and writes Parquet that pandas reads back, equal bit for
bit to the study run in this process."""
import json
import os
import subprocess
import sys
import time

import pandas as pd
import pytest
import yaml

from serial_dynamics import cli, sweep
from serial_dynamics.sweep import robustness as mc_module
from serial_dynamics.sweep import spec

pytest.importorskip("distributed")
EXAMPLE = os.path.join(os.path.dirname(__file__), "..", "..", "config", "sweep_example.yaml")


def write(tmp_path, **fields):
    with open(EXAMPLE) as f:
        data = {**yaml.safe_load(f), **fields}
    path = tmp_path / "spec.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


@pytest.mark.parametrize("fields, named", [
    ({"paylod": [0.0, 3.0]}, "'paylod' is not a field of study 'monte_carlo'"),
    ({"kp": "stiff"}, "'kp' = 'stiff'; give a number"),
    ({"payload": [0.0, 1.0, 2.0]}, "'payload' = [0.0, 1.0, 2.0]; give a list of 2 numbers"),
    ({"cases": 2.5}, "'cases' = 2.5; give a whole number"),
    ({"study": "fatigue"}, "'study' = 'fatigue'"),
    ({"robot": "no_such_arm"}, "'robot' = 'no_such_arm'"),
    ({"payload": [3.0, 1.0]}, "payload = [3.0, 1.0]; give a range"),
    ({"law": "bang_bang"}, "law 'bang_bang' unknown"),
])
def test_a_bad_field_is_refused_before_any_work(tmp_path, monkeypatch, capsys, fields, named):
    def no_work(*args, **kwargs):
        raise AssertionError("the sweep started")
    monkeypatch.setattr(mc_module, "run", no_work)
    out = tmp_path / "out.parquet"
    assert cli.main(["sweep", write(tmp_path, **fields), "--out", str(out)]) == 2
    assert named in capsys.readouterr().err
    assert not out.exists()


def test_identification_spec_needs_its_recordings():
    with pytest.raises(ValueError, match="needs the field 'recordings'"):
        spec.check({"study": "identification", "robot": "ur5e"})


def _scheduler_address(path, proc, timeout):
    """The address in the scheduler's file, once the file is written whole: it exists, empty,
    before the scheduler writes it (a loaded machine read it in between)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and proc.poll() is None:
        try:
            return json.loads(path.read_text())["address"]
        except (FileNotFoundError, json.JSONDecodeError, KeyError):
            time.sleep(0.2)
    raise AssertionError(f"no scheduler address in {path} after {timeout} s "
                         f"(scheduler exit code {proc.poll()})")


def test_cli_on_a_dask_scheduler_and_workers(tmp_path):
    dask = os.path.join(os.path.dirname(sys.executable), "dask")
    address_file = tmp_path / "scheduler.json"
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", "0",
                               "--no-dashboard", "--scheduler-file", str(address_file)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)]
    try:
        address = _scheduler_address(address_file, procs[0], timeout=120)
        procs.append(subprocess.Popen([dask, "worker", address, "--nworkers", "2",
                                       "--nthreads", "1", "--host", "127.0.0.1",
                                       "--no-dashboard"],
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        path, out = write(tmp_path, cases=4, seed=11), tmp_path / "results.parquet"
        assert cli.main(["sweep", path, "--scheduler", address, "--out", str(out),
                         "--quiet"]) == 0
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in reversed(procs):
            p.wait(timeout=30)
    table = pd.read_parquet(out)
    study, kwargs = spec.load(path)
    here = study(**kwargs, client="serial")
    pd.testing.assert_frame_equal(table, here, check_exact=True)
    assert table["max_error"].to_numpy().tobytes() == here["max_error"].to_numpy().tobytes()
    assert list(table["case"]) == [0, 1, 2, 3] and (table["error"] == "").all()
