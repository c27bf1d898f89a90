"""sweep.monte_carlo's pieces, in this process (sweep.run's cluster is test_run.py's): the
draws, the plants, and the outcomes of cases whose answer is known."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics import sweep
from serial_dynamics.sweep.robustness import NOMINAL_VISCOUS, Study


def study(law="computed_torque", kp=400.0, dt=0.002, lost=1.0):
    return Study(None, None, law, kp, 40.0, True, (0.0, 0.0, 0.05), 0.5, dt, lost)


def nominal_case(st, **changes):
    case = {"case": 0, "payload": 0.0, "friction_scale": 1.0}
    case.update({f"mass_scale_{link}": 1.0 for link in st.nominal.model.link_names})
    case.update({f"offset_{j}": 0.0 for j in st.nominal.joint_names})
    return {**case, **changes}


def test_draws_are_the_seed_and_the_ranges():
    robot = sd.default_robot()
    a = sweep.draw(robot, 500, 3, (0.5, 2.0), (0.9, 1.1), (0.5, 2.0), 0.05)
    assert a.equals(sweep.draw(robot, 500, 3, (0.5, 2.0), (0.9, 1.1), (0.5, 2.0), 0.05))
    assert not a.equals(sweep.draw(robot, 500, 4, (0.5, 2.0), (0.9, 1.1), (0.5, 2.0), 0.05))
    assert a["payload"].between(0.5, 2.0).all() and a["payload"].std() > 0.3
    assert a.filter(like="offset_").abs().max().max() <= 0.05
    assert a.filter(like="mass_scale_").shape[1] == robot.model.dof
    with pytest.raises(ValueError, match="payload"):
        sweep.draw(robot, 5, 0, (2.0, 1.0), (0.9, 1.1), (0.5, 2.0), 0.05)


def test_plants_scale_the_nominal_model():
    st = study()
    robot = st.nominal
    q, qd = robot.random_state(0)
    same = st.plant(nominal_case(st))
    assert same.inverse_dynamics(q, qd, q).tobytes() == robot.inverse_dynamics(q, qd, q).tobytes()
    # every body's mass and inertia times s: M(q) and g(q) times s
    s = 1.07
    heavy = st.plant(nominal_case(st, **{f"mass_scale_{k}": s for k in robot.model.link_names}))
    np.testing.assert_allclose(heavy.mass_matrix(q), s * robot.mass_matrix(q), rtol=1e-12)
    np.testing.assert_allclose(heavy.gravity_torques(q), s * robot.gravity_torques(q), rtol=1e-12,
                               atol=1e-12)
    # the nominal friction (the URDF has none): a fraction of the rated torque, scaled per case
    np.testing.assert_allclose(robot.dissipation.viscous, NOMINAL_VISCOUS * robot.effort_limit)
    rough = st.plant(nominal_case(st, friction_scale=1.8, payload=2.5))
    np.testing.assert_allclose(rough.dissipation.viscous, 1.8 * robot.dissipation.viscous)
    assert rough.payload.mass == 2.5 and rough.payload.com == (0.0, 0.0, 0.05)


def test_computed_torque_on_the_exact_model_tracks_to_first_order_in_dt():
    # the plant is the nominal model: only the zero-order hold and the Euler step leave an
    # error, which halves with the step
    coarse, fine = study(dt=0.002), study(dt=0.001)
    a, b = coarse(nominal_case(coarse)), fine(nominal_case(fine))
    assert a["max_error"] < 3e-3 and not a["diverged"] and a["saturation_time"] == 0.0
    assert 1.8 < a["max_error"] / b["max_error"] < 2.2
    assert 0.2 < a["peak_torque_ratio"] < 1.0
    # an unknown 3 kg payload, or twice the friction: the error grows by two orders
    heavy = coarse(nominal_case(coarse, payload=3.0))
    assert heavy["max_error"] > 50 * a["max_error"]
    assert heavy["rms_wrist_1_joint"] > heavy["rms_shoulder_pan_joint"]


def test_saturation_and_divergence_are_reported():
    stiff = study(kp=1e6)           # commands far beyond the limits from the first step
    r = stiff(nominal_case(stiff, offset_elbow_joint=0.01))
    assert r["peak_torque_ratio"] > 10 and r["saturation_time"] > 1.0
    strict = study(lost=0.1)
    r = strict(nominal_case(strict, payload=3.0))
    assert r["diverged"] and r["reason"] == "|e| > 0.1" and 0 < r["diverged_at"] < 5.3


def test_summary_reads_the_table():
    table = sweep.monte_carlo(cases=3, seed=2, client="serial", payload=(0.0, 0.5))
    assert list(table["case"]) == [0, 1, 2] and (table["error"] == "").all()
    p, worst = sweep.summary(table, worst=2)
    assert p.loc["p100", "max_error"] == table["max_error"].max()
    assert list(worst["case"]) == list(table.sort_values("max_error", ascending=False)["case"][:2])
