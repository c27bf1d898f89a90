"""A chain with mimic joints is checked in O(n) like one without (issue 22, item 10: one
mimic joint made the load quadratic, 1,000 joints in 14 s, since the singular-mass-matrix
check ran the dense NumPy CRBA three times). Load times: bench/bench_load.py."""
import re

import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.builtin.synthetic import chain_urdf, mimic_chain_urdf
from serial_dynamics.urdf import mass_matrix as check_module   # the loader's mass-matrix check


@pytest.fixture
def dense_calls(monkeypatch):
    calls = []
    dense = check_module.mass_matrix
    monkeypatch.setattr(check_module, "mass_matrix", lambda *a: calls.append(1) or dense(*a))
    return calls


def test_a_long_chain_with_a_mimic_joint_loads_without_the_dense_check(dense_calls):
    robot = sd.load_urdf(mimic_chain_urdf(300, follower=150))
    assert robot.dof == 299 and robot.model.dof == 300 and not dense_calls
    # and it is the reduced system: M = G^T M_all G
    full = sd.load_urdf(chain_urdf(300))
    G, o = robot.model.mimic_matrix
    q = np.random.default_rng(0).uniform(-1, 1, 299)
    np.testing.assert_allclose(robot.mass_matrix(q), G.T @ full.mass_matrix(G @ q + o) @ G,
                               rtol=1e-12, atol=1e-12)


def test_a_singular_mimic_chain_is_still_refused_by_the_dense_check(dense_calls):
    """joint 8 mimics joint 7 about the same axis through the same point, and link 7 is
    massless: joint 7 alone moves no mass (the O(n) check of the whole chain fails), and in
    the reduced system the two together move link 8: regular, so the dense check decides."""
    xml = chain_urdf(12)
    xml = re.sub(r'<link name="link7">.*?</link>', '<link name="link7"/>', xml, flags=re.S)
    xml = re.sub(r'(<joint name="joint8".*?<origin xyz=")[^"]*(")', r"\g<1>0 0 0\2", xml,
                 flags=re.S)
    axis7 = re.search(r'<joint name="joint7".*?<axis xyz="([^"]*)"', xml, re.S).group(1)
    xml = re.sub(r'(<joint name="joint8".*?<axis xyz=")[^"]*(")', rf"\g<1>{axis7}\2", xml,
                 flags=re.S)
    with pytest.raises(sd.ModelError, match="'joint7'"):
        sd.load_urdf(xml)                                    # without the mimic: singular
    start = xml.index('<joint name="joint8"')
    end = xml.index("</joint>", start)
    robot = sd.load_urdf(xml[:end] + '<mimic joint="joint7" multiplier="1"/>' + xml[end:])
    assert robot.dof == 11 and dense_calls                  # loads: the dense check passed it
