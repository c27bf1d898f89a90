"""One set of links for every call that takes one (model/links.py): on a two-arm robot
whose hands are links fixed to the forearms (bodies of no joint of their own), every link
the model keeps, as a body or as a frame of one, is accepted by the kinematics, the task
space, the wrenches and the payload, each placing the hand where the forward kinematics
does; an unknown link is refused by all of them in the same words."""
import numpy as np
import pytest

import serial_dynamics as sd
from serial_dynamics.model.links import moving_links
from test_trees import two_arms

ROBOT = sd.load_urdf(two_arms())
Q = np.linspace(-0.6, 0.6, ROBOT.dof)
QD = np.linspace(0.5, -0.3, ROBOT.dof)


def calls(robot):
    """Each call that takes a link, as f(link)."""
    return {
        "forward_kinematics": lambda link: robot.forward_kinematics(Q, link),
        "jacobian": lambda link: robot.jacobian(Q, link),
        "frame_acceleration": lambda link: robot.frame_acceleration(Q, QD, QD, link),
        "jacobian_dot_qd": lambda link: robot.jacobian_dot_qd(Q, QD, link),
        "operational_space_inertia": lambda link: robot.operational_space_inertia(Q, link, 0.1),
        "dynamically_consistent_inverse":
            lambda link: robot.dynamically_consistent_inverse(Q, link, 0.1),
        "wrenches": lambda link: robot.inverse_dynamics(Q, QD, QD, wrenches={link: np.ones(6)}),
    }


def test_the_hands_are_frames_not_bodies():
    assert "l_hand" not in ROBOT.link_names and "l_hand" in ROBOT.model.frames
    assert ROBOT.model.frames["l_hand"][0] == ROBOT.link_names.index("l_fore")
    assert moving_links(ROBOT.model) == sorted(set(ROBOT.model.frames) - {"base_link"})


@pytest.mark.parametrize("backend", ["numba", "numpy"])
def test_every_call_takes_every_link_the_model_keeps(backend):
    robot = sd.Robot(ROBOT.model, backend=backend)
    for link in ROBOT.model.frames:
        for name, call in calls(robot).items():
            assert np.all(np.isfinite(call(link))), (name, link)
    # the hand where the kinematics put it: its Jacobian's columns are the forearm's
    # joints' (and none of the other arm's), its wrench the torques J^T w
    X = robot.forward_kinematics(Q, "l_hand")
    J = robot.jacobian(Q, "l_hand")
    h = 1e-6
    for j in range(robot.dof):
        e = np.zeros(robot.dof)
        e[j] = h
        v = (robot.forward_kinematics(Q + e, "l_hand")[:3, 3]
             - robot.forward_kinematics(Q - e, "l_hand")[:3, 3]) / (2 * h)
        np.testing.assert_allclose(J[:3, j], v, atol=1e-8)
    assert not np.any(J[:, [robot.joint_names.index(x) for x in ("r_shoulder", "r_elbow")]])
    w = np.array([1.0, -2.0, 0.5, 0.1, 0.2, -0.3])
    pushed = robot.inverse_dynamics(Q, QD, QD, wrenches={"l_hand": w})
    np.testing.assert_allclose(robot.inverse_dynamics(Q, QD, QD) - pushed, J.T @ w, atol=1e-12)
    T = np.eye(4)                  # the hand in the forearm's link frame, as loaded
    T[:3, :3], T[:3, 3] = ROBOT.model.frames["l_hand"][1:]
    np.testing.assert_allclose(X, robot.forward_kinematics(Q, "l_fore") @ T, atol=1e-12)
    assert not np.allclose(T, np.eye(4))
    # a payload on the hand is the same body on the forearm, placed where the hand is
    held = robot.with_payload(1.5, (0.0, 0.0, 0.05), link="l_hand")
    R, p = ROBOT.model.frames["l_hand"][1:]
    on_fore = robot.with_payload(1.5, R @ [0.0, 0.0, 0.05] + p, link="l_fore")
    np.testing.assert_allclose(held.inverse_dynamics(Q, QD, QD),
                               on_fore.inverse_dynamics(Q, QD, QD), rtol=1e-12, atol=1e-12)


def test_an_unknown_link_is_refused_by_every_call_alike():
    for name, call in calls(ROBOT).items():
        with pytest.raises(ValueError, match=r"link 'nose' is not a link of the model; its "
                                             r"links are \[.*'l_hand'.*\]"):
            call("nose")
    with pytest.raises(ValueError, match="payload link 'nose' is not a link of the model"):
        ROBOT.with_payload(1.0, link="nose")
    with pytest.raises(ValueError, match="payload link 'base_link' does not move: it is the "
                                         r"base or fixed to the base.*\['l_finger_a'"):
        ROBOT.with_payload(1.0, link="base_link")
