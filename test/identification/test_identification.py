"""Identification closing the loop: a 'true' UR5e (perturbed masses, centers of mass,
friction) simulated along an excitation trajectory, recorded with encoder quantization and
torque noise, identified from the nominal URDF; the base parameters are recovered within
three standard deviations and the validation torques within the noise level. Plus the
excitation's guarantees, the physically consistent fit, the URDF written back, and the
messages on bad data."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics import identification as ident
from serial_dynamics.identification import estimate, urdf_out

from ident_helpers import TORQUE_NOISE, perturbed_truth, record


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    path = tmp_path_factory.mktemp("ident") / "truth.urdf"
    nominal, truth = perturbed_truth(path)
    ex = ident.excitation(nominal, duration=8, harmonics=3, maxiter=1, seed=0)
    ex2 = ident.excitation(nominal, duration=6, harmonics=3, maxiter=0, seed=5)
    _, t, q, tau = record(truth, ex, seed=1)
    _, t2, q2, tau2 = record(truth, ex2, seed=2)
    wls = ident.identify(nominal, t, q, tau, method="wls", validation=(t2, q2, tau2),
                         source=sd.builtin_path("ur5e"))
    phys = ident.identify(nominal, t, q, tau, method="physical", validation=(t2, q2, tau2),
                          source=sd.builtin_path("ur5e"))
    ols = ident.identify(nominal, t, q, tau, method="ols")
    return dict(nominal=nominal, truth=truth, ex=ex, wls=wls, phys=phys, ols=ols, path=path,
                data=(t, q, tau), data2=(t2, q2, tau2))


def test_the_excitation_starts_and_ends_at_rest_within_the_limits(run):
    ex, robot = run["ex"], run["nominal"]
    for t in (0.0, ex.duration):
        q, qd, qdd = ex(t)
        assert np.max(np.abs(qd)) < 1e-12 and np.max(np.abs(qdd)) < 1e-12
    t, q, qd, qdd = ex.sample(0.002)
    h = t[1] - t[0]                                 # derivatives are consistent
    assert np.max(np.abs(np.gradient(q, h, axis=0) - qd)[1:-1]) < 1e-4
    assert np.max(np.abs(np.gradient(qd, h, axis=0) - qdd)[1:-1]) < 1e-3
    assert np.all(np.abs(qd) <= 0.8 * robot.velocity_limit + 1e-9)
    assert np.all(np.abs(qdd) <= 0.8 * robot.velocity_limit + 1e-9)    # default: 1/s of it
    tau = robot.inverse_dynamics(q, qd, qdd) - robot.dissipation.torque(qd)
    assert np.all(np.abs(tau) <= 0.8 * robot.effort_limit + 1e-6)
    assert np.all((q >= robot.lower) & (q <= robot.upper))
    # the reported condition number is that of the base regressor along the trajectory
    tt = np.arange(100) * (ex.period / 100)
    bp = ident.base_parameters(robot, friction=True)
    W = bp.project(robot.regressor(*ex(tt), friction=True)).reshape(-1, bp.count)
    assert np.isclose(np.linalg.cond(W), ex.condition_number, rtol=1e-6)
    assert ex.condition_number <= 1.01 * ex.initial_condition_number


@pytest.mark.parametrize("method", ["ols", "wls", "phys"])
def test_base_parameters_recovered_within_three_standard_deviations(run, method):
    res, truth = run[method], run["truth"]
    beta_true = res.bp.beta(truth.inertial_parameters(friction=True))
    z = (res.beta - beta_true) / res.std
    worst = int(np.argmax(np.abs(z)))
    assert np.max(np.abs(z)) < 3, (res.names[worst], res.beta[worst], beta_true[worst])
    assert 0.5 < np.sqrt(np.mean(z ** 2)) < 1.5         # the standard deviations are honest
    # and the URDF's (nominal) values are far off for the masses that were perturbed
    z_nominal = (res.beta - res.beta_urdf) / res.std
    assert np.max(np.abs(z_nominal)) > 50


def test_validation_torques_within_the_noise_level(run):
    """On a second recording (another trajectory, other noise), the identified model's
    torques are within the torque sensor's noise level; the URDF's are not."""
    for res in (run["wls"], run["phys"]):
        v = res.validation
        assert np.all(v.rms < TORQUE_NOISE), (res.method, v.rms)
        assert v.total < 0.05
        s = v.samples
        Y = res.bp.project(res.robot.regressor(s.q, s.qd, s.qdd, friction=True))
        nominal_rms = np.sqrt(np.mean((s.tau - Y @ res.beta_urdf) ** 2, axis=0))
        assert np.all(nominal_rms[:3] > 3 * v.rms[:3]), (nominal_rms, v.rms)


def test_the_physically_consistent_fit_keeps_every_inertia_valid(run):
    ols, phys = run["ols"], run["phys"]
    assert ols.unphysical                      # the closest standard parameters to the URDF
    assert np.all(ols.physical())              # ... so the consistent ones closest to the fit
    assert np.all(phys.physical())
    phi = phys.standard_parameters()
    for i in range(6):
        J = estimate.pseudo_inertia(phi[10 * i:10 * i + 10])
        assert np.linalg.eigvalsh(J)[0] > 0    # positive definite pseudo-inertia
    names = phys.bp.standard_names
    for k, name in enumerate(names):
        if name[:2] in ("fv", "fc"):
            assert phi[k] >= 0
    assert np.allclose(phys.bp.beta(phi), phys.beta)


def test_log_cholesky_round_trip():
    robot = sd.default_robot()
    phi = robot.inertial_parameters()
    for i in range(6):
        body = phi[10 * i:10 * i + 10]
        theta = estimate.to_log_cholesky(body, floor=0.0)
        assert np.allclose(estimate.from_log_cholesky(theta), body, rtol=1e-10, atol=1e-14)


def test_the_identified_urdf_loads_with_exactly_the_identified_parameters(run, tmp_path):
    phys = run["phys"]
    out = tmp_path / "identified.urdf"
    phys.write_urdf(out)
    robot = sd.load_urdf(str(out))
    phi = phys.standard_parameters()
    got = robot.inertial_parameters(friction=True)
    names = phys.bp.standard_names
    rigid = [k for k, nm in enumerate(names) if not nm.startswith("fo")]
    assert np.allclose(got[rigid], phi[rigid], rtol=1e-9, atol=1e-12)
    # the loaded robot predicts the validation torques as the identified model does
    s = phys.validation.samples
    fo = phi[[names.index(f"fo{j + 1}") for j in range(6)]]
    tau = robot.inverse_dynamics(s.q, s.qd, s.qdd) - robot.dissipation.torque(s.qd) + fo
    assert np.allclose(tau, phys.predict(s.q, s.qd, s.qdd), rtol=1e-9, atol=1e-9)


def test_write_urdf_keeps_fixed_links_lumped_consistently(tmp_path):
    """A tool fixed to the last link keeps its own inertial; the wrist link gets the rest,
    and the reloaded chain has the identified body."""
    base = open(sd.builtin_path("ur5e")).read()
    tool = ('<link name="gripper"><inertial><origin xyz="0.01 0 0.05" rpy="0.3 0 0"/>'
            '<mass value="0.8"/><inertia ixx="0.002" ixy="0" ixz="0" iyy="0.003" iyz="0" '
            'izz="0.001"/></inertial></link><joint name="tool0-gripper" type="fixed">'
            '<parent link="tool0"/><child link="gripper"/><origin xyz="0 0 0.02"/></joint>')
    src = base.replace("</robot>", tool + "</robot>")
    robot = sd.load_urdf(src)
    phi = robot.inertial_parameters().reshape(6, 10) * 1.1          # heavier: consistent
    urdf_out.write_urdf(src, robot.model, phi, np.ones(6), np.zeros(6), tmp_path / "a.urdf")
    back = sd.load_urdf(str(tmp_path / "a.urdf"))
    assert np.allclose(back.inertial_parameters(), phi.ravel(), rtol=1e-9, atol=1e-13)
    assert 'name="gripper"' in (tmp_path / "a.urdf").read_text()
    assert "0.8" in (tmp_path / "a.urdf").read_text().split('name="gripper"')[1][:300]
    light = phi.copy()
    light[5, 0] = 0.5                                  # lighter than the gripper alone
    light[5, 1:4] = light[5, 0] * np.array([0.0, 0.0, 0.1])
    with pytest.warns(UserWarning, match="lighter than the links attached"):
        urdf_out.write_urdf(src, robot.model, light, np.ones(6), np.zeros(6), tmp_path / "b.urdf")
    back = sd.load_urdf(str(tmp_path / "b.urdf"))
    assert np.allclose(back.inertial_parameters(), light.ravel(), rtol=1e-9, atol=1e-13)



def test_bad_data_is_named(run):
    robot = run["nominal"]
    t, q, tau = (x.copy() for x in run["data"])
    q[1234, 2] = np.nan
    with pytest.raises(ValueError, match=r"q_elbow_joint is nan at t = 1.234 s \(sample 1234"):
        ident.identify(robot, t, q, tau)
    with pytest.raises(ValueError, match="too few.*need at least"):
        ident.identify(robot, t[:5], run["data"][1][:5], tau[:5])
    # a trajectory that leaves the last joint at rest does not excite its parameters
    q = run["data"][1].copy()
    q[:, 5] = q[0, 5]
    with pytest.raises(ValueError, match=r"does not excite base parameters .*(fv6|fc6|6).*"
                                         r"wrist_3_joint.* do not move"):
        ident.identify(robot, t, q, tau)
    # a joint at constant speed: its viscous, Coulomb and offset columns are collinear
    ex = run["ex"]
    t, q, qd, qdd = ex.sample(0.002)
    q[:, 5], qd[:, 5], qdd[:, 5] = 0.3 * t, 0.3, 0.0
    tau = robot.inverse_dynamics(q, qd, qdd)
    with pytest.raises(ValueError, match=r"does not excite base parameters \[.*\] apart "
                                         r"from each other \(condition number") as info:
        ident.identify(robot, t, q, tau, qd, qdd, cutoff=np.inf)
    named = str(info.value).split("[")[1].split("]")[0]
    assert "'fv6'" in named and "'fo6'" in named
    with pytest.raises(ValueError, match="method 'lasso' unknown"):
        ident.identify(robot, t, run["data"][1], tau, method="lasso")


def test_excitation_is_deterministic_and_checks_its_arguments():
    robot = sd.builtin_robot("spatial_3r")
    a = ident.excitation(robot, duration=4, harmonics=2, maxiter=1, seed=3,
                           acceleration_limit=5.0)
    b = ident.excitation(robot, duration=4, harmonics=2, maxiter=1, seed=3,
                           acceleration_limit=5.0)
    assert np.array_equal(a.a, b.a) and np.array_equal(a.b, b.b)
    with pytest.raises(ValueError, match="harmonics = 1"):
        ident.excitation(robot, harmonics=1)


@pytest.mark.parametrize("method", ["ols", "wls", "physical"])
def test_noise_free_data_with_exact_derivatives_gives_the_parameters_exactly(method):
    """No filter (cutoff=inf), exact qd and qdd: the base parameters of the model itself."""
    robot = sd.builtin_robot("spatial_3r")
    ex = ident.excitation(robot, duration=4, harmonics=3, maxiter=0)
    t, q, qd, qdd = ex.sample(0.004)
    tau = robot.inverse_dynamics(q, qd, qdd)
    res = ident.identify(robot, t, q, tau, qd, qdd, friction=False, cutoff=np.inf,
                         method=method)
    assert np.allclose(res.beta, res.beta_urdf, rtol=1e-8, atol=1e-10)
