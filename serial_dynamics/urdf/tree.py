"""Walks of the URDF's link tree: that it is a tree (no cycle), the path from the base to a
link, and the default selection (the end of the single chain of movable joints, or the
tips of the whole tree)."""
from __future__ import annotations

from ..model.errors import URDFError


def check_tree(root, links, children, parent_joint):
    """Every link hangs below the root. Each link has at most one parent joint, so a link
    the root does not reach lies on, or below, a cycle of joints: name the cycle."""
    reached, stack = ({root}, [root]) if root is not None else (set(), [])
    while stack:
        for joint in children[stack.pop()]:
            if joint.child not in reached:
                reached.add(joint.child)
                stack.append(joint.child)
    lost = [name for name in links if name not in reached]
    if lost:
        link, seen = lost[0], []
        while link not in seen:          # up the parents until one repeats: the cycle
            seen.append(link)
            link = parent_joint[link].parent
        cycle = seen[seen.index(link):]
        joints = [parent_joint[name].name for name in cycle]
        reach = "no link is a root" if root is None else f"the root {root!r} does not reach"
        raise URDFError(f"the joints {joints} form a cycle through the links {cycle} ({reach}); "
                        "a URDF must be a tree")


def path_up(link, stop, parent_joint):
    """The joints from ``stop`` down to ``link`` (base-to-tip order), or None if ``link`` is
    not below ``stop``."""
    path = []
    while link != stop:
        if link not in parent_joint:
            return None
        path.append(parent_joint[link])
        link = parent_joint[link].parent
    return path[::-1]


def _movable(base, children):
    """(depth, joint, the nearest movable joint above it or None) for every movable joint
    below ``base`` (a walk with an explicit stack: any depth, linear time)."""
    movable = []
    stack = [(base, 0, None)]
    while stack:
        link, depth, above = stack.pop()
        for joint in children[link]:
            nearest = above
            if joint.type != "fixed":
                movable.append((depth, joint, above))
                nearest = joint.name
            stack.append((joint.child, depth + 1, nearest))
    if not movable:
        raise URDFError(f"no movable joint below base_link {base!r}")
    return movable


def has_movable(base, children):
    """Whether any movable joint lies below ``base`` (a walk with an explicit stack)."""
    stack = [base]
    while stack:
        for joint in children[stack.pop()]:
            if joint.type != "fixed":
                return True
            stack.append(joint.child)
    return False


def single_chain_tip(base, children):
    """The end of the chain when the movable joints below ``base`` form a single path: the
    child of the last movable joint, followed down a unique tail of fixed joints; None
    where they branch (the model is then a tree)."""
    movable = sorted(_movable(base, children), key=lambda t: (t[0], t[1].name))
    for (_, j1, _), (_, j2, above2) in zip(movable, movable[1:]):
        if above2 != j1.name:        # a single path: each one's nearest movable is the last
            return None
    return _fixed_tail(movable[-1][1].child, children)


def movable_leaves(base, children):
    """The child links of the movable joints below ``base`` with no movable joint below
    them: the tips of the whole tree."""
    movable = _movable(base, children)
    above = {a for _, _, a in movable}
    return [j.child for _, j, _ in movable if j.name not in above]


def _fixed_tail(link, children):
    """``link`` followed down a unique tail of fixed joints."""
    while len(children[link]) == 1 and children[link][0].type == "fixed":
        link = children[link][0].child
    return link
