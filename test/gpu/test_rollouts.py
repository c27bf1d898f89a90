"""sweep.monte_carlo(device="cuda") against the CPU's table (client="serial"): the same
columns, the same draws, every outcome within 1e-9 relative (the card fuses multiply-adds;
numba's simulator does not, and agrees to round-off), a diverged run's message word for
word; the plants built on the host as Study.plant builds them; what the card does not run,
refused by name."""
import numpy as np
import pandas as pd
import pytest

pytest.importorskip("numba_cuda")

import serial_dynamics as sd                                  # noqa: E402
from serial_dynamics import sweep                             # noqa: E402
from serial_dynamics.core import layout                       # noqa: E402
from serial_dynamics.gpu import rollouts                      # noqa: E402
from serial_dynamics.sim.equations import energy_scale_static  # noqa: E402
from serial_dynamics.sweep.robustness import Study            # noqa: E402
from serial_dynamics.trajectory import Waypoints, pick_and_place  # noqa: E402


def same_table(cpu, gpu, rtol=1e-9):
    assert list(gpu.columns) == list(cpu.columns)
    for col in cpu.columns:
        a, b = cpu[col].to_numpy(), gpu[col].to_numpy()
        if a.dtype.kind == "f":
            np.testing.assert_allclose(b, a, rtol=rtol, atol=0, err_msg=col)
        else:
            assert (a == b).all(), (col, a, b)


def short_task(robot):
    """The first 0.3 s of a move towards the pick-and-place's second waypoint (quintic)."""
    wp = pick_and_place(robot)
    q1 = wp.q[0] + 0.3 * (wp.q[1] - wp.q[0])
    zero = np.zeros_like(wp.q[:2])
    return Waypoints([0.0, 0.3], [wp.q[0], q1], zero, zero)


def test_tracking_cases_match_the_cpu_and_repeat_bit_for_bit():
    robot = sd.default_robot()
    kw = dict(cases=3, seed=1, waypoints=short_task(robot), settle=0.1, progress=False)
    cpu = sweep.monte_carlo(robot, client="serial", **kw)
    gpu = sweep.monte_carlo(robot, device="cuda", **kw)
    assert not cpu["diverged"].any() and (cpu["error"] == "").all()
    assert cpu["max_error"].max() > 1e-3                       # the loop tracks, not trivially
    same_table(cpu, gpu)
    again = sweep.monte_carlo(robot, device="cuda", **kw)
    pd.testing.assert_frame_equal(again, gpu, check_exact=True)


def test_diverged_runs_say_why_as_on_the_cpu():
    # dt = 20 ms is beyond the sampled loop's bound for the light wrist: case 0 is stopped by
    # the speed check, case 1 by the energy guard (the same messages, word for word)
    kw = dict(cases=2, seed=3, dt=0.02, settle=0.0, progress=False)
    cpu = sweep.monte_carlo(client="serial", **kw)
    gpu = sweep.monte_carlo(device="cuda", **kw)
    assert cpu["reason"].str.contains("exceeds the bound").iloc[0]
    assert cpu["reason"].str.contains("the energy grew").iloc[1]
    same_table(cpu, gpu)


@pytest.mark.parametrize("seed", [1, 2])
def test_tables_that_mix_verdicts_keep_the_cpus_columns(seed):
    # dt = 6 ms on the short task: seed 1 starts with a run whose error grew past `lost`
    # and goes on with runs the simulator stopped; seed 2 starts with a stopped run (its
    # verdict's columns come first, as sweep.run orders them) and has one that tracked
    robot = sd.default_robot()
    kw = dict(cases=4, seed=seed, waypoints=short_task(robot), settle=0.1, dt=0.006,
              progress=False)
    cpu = sweep.monte_carlo(robot, client="serial", **kw)
    gpu = sweep.monte_carlo(robot, device="cuda", **kw)
    assert cpu["reason"].iloc[0].startswith("|e| >" if seed == 1 else "simulation diverged")
    same_table(cpu, gpu)


def test_plants_on_the_host_are_study_plants():
    robot = sd.default_robot()
    st = Study(robot, None, "computed_torque", 400.0, 40.0, True, (0.01, -0.02, 0.05), 0.0,
               0.002, 1.0)
    table = sweep.draw(st.nominal, 4, 7, (0.0, 3.0), (0.8, 1.2), (0.5, 2.0), 0.05)
    Pc, beta, q0, static = rollouts.plants(st, table)
    for s, case in enumerate(table.to_dict("records")):
        plant = st.plant(case)
        np.testing.assert_allclose(Pc[s], layout.pack(plant.model), rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(beta[s], plant.dissipation.viscous, rtol=1e-15)
        assert static[s, 0] == pytest.approx(float(energy_scale_static(plant)), rel=1e-13)
    assert np.abs(q0 - st.reference[0][0]).max() <= 0.05


def test_what_the_card_does_not_run_is_refused_by_name():
    with pytest.raises(NotImplementedError, match="pd_gravity.*device='cpu'"):
        sweep.monte_carlo(cases=1, law="pd_gravity", device="cuda", progress=False)
    rough = sd.default_robot()
    rough.dissipation = rough.dissipation.override(coulomb=0.5)
    with pytest.raises(NotImplementedError, match="Coulomb"):
        sweep.monte_carlo(rough, cases=1, device="cuda", progress=False)
    with pytest.raises(ValueError, match="device = 'tpu'"):
        sweep.monte_carlo(cases=1, device="tpu", progress=False)
