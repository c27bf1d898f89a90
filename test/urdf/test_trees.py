"""A branched URDF is a tree (issue 25): the whole tree of movable joints by default, one
chain with ``tip_link``, the subtree to ``tip_links``; bodies parents first."""
import dataclasses
import warnings

import numpy as np
import pytest

import serial_dynamics as sd
from test_errors import joint, link, raises, urdf


def two_arms():
    """Two 2-joint arms on one torso, each with a hand holding two prismatic fingers."""
    parts = dict(base=link("base_link", mass=None))
    for side in ("l", "r"):
        parts.update({
            f"{side}1": link(f"{side}_upper"), f"{side}2": link(f"{side}_fore"),
            f"{side}f": link(f"{side}_flange", mass=None), f"{side}h": link(f"{side}_hand"),
            f"{side}a": link(f"{side}_finger_a", mass="0.1"),
            f"{side}b": link(f"{side}_finger_b", mass="0.1"),
            f"j{side}1": joint(f"{side}_shoulder", "base_link", f"{side}_upper", axis="0 0 1",
                               xyz=f"0 {0.3 if side == 'l' else -0.3} 0.5"),
            f"j{side}2": joint(f"{side}_elbow", f"{side}_upper", f"{side}_fore"),
            f"j{side}f": joint(f"{side}_flange_joint", f"{side}_fore", f"{side}_flange", kind="fixed"),
            f"j{side}h": joint(f"{side}_hand_joint", f"{side}_flange", f"{side}_hand", kind="fixed"),
            f"j{side}a": joint(f"{side}_fa", f"{side}_hand", f"{side}_finger_a", kind="prismatic",
                               axis="1 0 0"),
            f"j{side}b": joint(f"{side}_fb", f"{side}_hand", f"{side}_finger_b", kind="prismatic",
                               axis="-1 0 0"),
        })
    return '<robot name="two">' + "".join(parts.values()) + "</robot>"


def branched():
    """base -j1-> link1, which carries j2 -> link2 and j3 -> link3 -j4-> link4."""
    return urdf(l3=link("link3"), j3=joint("j3", "link1", "link3", axis="1 0 0"),
                l4=link("link4"), j4=joint("j4", "link3", "link4", axis="0 0 1"))


def test_a_branched_urdf_loads_as_the_whole_tree():
    robot = sd.load_urdf(branched())
    assert robot.joint_names == ["j1", "j2", "j3", "j4"]      # depth first, URDF order
    assert robot.link_names == ["link1", "link2", "link3", "link4"]
    assert robot.model.parent.tolist() == [-1, 0, 0, 2]
    assert not robot.model.is_chain and robot.model.children[0] == (1, 2)
    assert "tree to ['link2', 'link4']" in repr(robot)


def test_tip_link_still_gives_one_chain_and_holds_the_rest():
    with pytest.warns(sd.HeldJointsWarning, match="j2"):
        robot = sd.load_urdf(branched(), tip_link="link4")
    assert robot.joint_names == ["j1", "j3", "j4"] and robot.model.is_chain


def test_tip_links_give_the_subtree_and_name_what_is_held():
    with pytest.warns(sd.HeldJointsWarning) as held:
        robot = sd.load_urdf(two_arms(), tip_links=["l_flange", "r_hand"])
    assert robot.joint_names == ["l_shoulder", "l_elbow", "r_shoulder", "r_elbow"]
    assert robot.model.parent.tolist() == [-1, 0, -1, 2]
    text = str(held[0].message)
    assert all(f"'{side}_f{ab}'" in text for side in "lr" for ab in "ab")
    assert "outside the tree" in text
    whole = sd.load_urdf(two_arms())
    assert whole.dof == 8 and whole.model.parent.tolist() == [-1, 0, 1, 1, -1, 4, 5, 5]


def test_the_subtree_has_the_dynamics_of_the_whole_tree_held_still():
    """The two-arm subtree with the fingers held at zero and lumped equals the whole tree
    with the fingers locked: the same torques for the arm joints when the fingers do not
    move (their bodies then move rigidly with the hands)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sd.HeldJointsWarning)
        sub = sd.load_urdf(two_arms(), tip_links=["l_flange", "r_flange"])
    whole = sd.load_urdf(two_arms())
    arm = [whole.joint_names.index(n) for n in sub.joint_names]
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.uniform(-1, 1, (3, sub.dof))
    Q, QD, QDD = (np.zeros(whole.dof) for _ in range(3))
    Q[arm], QD[arm], QDD[arm] = q, qd, qdd
    np.testing.assert_allclose(whole.inverse_dynamics(Q, QD, QDD)[arm],
                               sub.inverse_dynamics(q, qd, qdd), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(whole.mass_matrix(Q)[np.ix_(arm, arm)], sub.mass_matrix(q),
                               rtol=1e-12, atol=1e-14)


def test_bodies_on_different_branches_do_not_couple_in_the_mass_matrix():
    robot = sd.load_urdf(two_arms())
    M = robot.mass_matrix(robot.random_state(1)[0])
    left, right = range(0, 4), range(4, 8)
    assert np.all(M[np.ix_(left, right)] == 0.0)
    assert np.all(M[1, 4:] == 0.0) and np.all(M[2, 3] == 0.0)   # two fingers: siblings
    assert np.all(np.linalg.eigvalsh(M) > 0)


@pytest.mark.parametrize("tips, words", [
    (["l_flange", "nowhere"], ["'nowhere'", "not a link"]),
    (["l_fore", "l_finger_a"], ["'l_fore'", "on the path", "'l_finger_a'", "drop it"]),
    ([], ["empty"]),
])
def test_bad_tip_links_name_the_culprit(tips, words):
    raises(sd.URDFError, two_arms(), *words, tip_links=tips)


def test_tip_links_below_the_base_only():
    raises(sd.URDFError, two_arms(), "'r_hand'", "not below base_link 'l_upper'",
           base_link="l_upper", tip_links=["l_hand", "r_hand"])


def test_tip_link_and_tip_links_together_are_refused():
    raises(sd.URDFError, two_arms(), "tip_link", "tip_links", tip_link="l_hand",
           tip_links=["r_hand"])


def test_a_mimic_follower_on_another_branch_moves_with_its_leader():
    """The Panda's fingers: finger 2 mimics finger 1 on a sibling branch; one coordinate
    moves two bodies (checked against the tree with both fingers free, through G)."""
    from pin_reference import erd
    path = erd("panda_description/urdf/panda.urdf")
    robot = sd.load_urdf(path)
    assert robot.dof == 8 and len(robot.all_joint_names) == 9
    assert robot.joint_names[-1] == "panda_finger_joint1"
    model = robot.model
    i1, i2 = (model.joint_names.index(n) for n in ("panda_finger_joint1", "panda_finger_joint2"))
    assert model.parent[i1] == model.parent[i2] and model.mimic_leader[i2] == i1
    q = robot.random_state(3)[0]
    full = sd.Robot(dataclasses.replace(model, mimic_leader=np.full(model.dof, -1)))
    G, o = model.mimic_matrix
    np.testing.assert_allclose(robot.mass_matrix(q), G.T @ full.mass_matrix(G @ q + o) @ G,
                               rtol=1e-12, atol=1e-15)
