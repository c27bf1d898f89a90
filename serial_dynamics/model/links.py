"""The links a call may name, and the one resolver every call that takes a link uses.

A model knows every link of the URDF it keeps: the base link, each body's link, and each
link lumped into a body by a fixed (or held) joint, with its placement in that body
(``model.frames``; -1: the base). Kinematics, task space, wrenches, payloads and the nodes'
services all resolve a name here, so they accept the same set and refuse alike. A payload
(``moving=True``) also needs a link that moves with some joint.
"""
from __future__ import annotations


def link_problem(model, link, moving=False):
    """Why ``link`` cannot be named on ``model`` (a sentence), or None where it can."""
    if link not in model.frames:
        return f"link {link!r} is not a link of the model; its links are {sorted(model.frames)}"
    if moving and model.frames[link][0] < 0:
        return (f"link {link!r} does not move: it is the base or fixed to the base, so a "
                f"payload there moves with no joint; name a link that moves: "
                f"{moving_links(model)}")
    return None


def resolve_link(model, link, moving=False, prefix=""):
    """``link`` (the tip link when None), checked: a ValueError with ``prefix`` and the
    reason (``link_problem``) when the model cannot take it."""
    link = model.tip_link if link is None else link
    problem = link_problem(model, link, moving)
    if problem is not None:
        raise ValueError(prefix + problem)
    return link


def moving_links(model):
    """The links that move with some joint, sorted."""
    return sorted(k for k, (body, _, _) in model.frames.items() if body >= 0)
