"""Walks of the URDF's link tree: that it is a tree (no cycle), and the default tip_link
(the end of the single chain of movable joints, or a suggestion naming the longest one)."""
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


def default_tip(base, children):
    """The end of the chain when the movable joints below ``base`` form a single path: the
    child of the last movable joint, followed down a unique tail of fixed joints. (A walk
    with an explicit stack: a chain of any length, in time linear in it.)"""
    movable = []      # (depth, joint, the nearest movable joint above it, or None)
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
    movable.sort(key=lambda t: (t[0], t[1].name))
    for (_, j1, _), (_, j2, above2) in zip(movable, movable[1:]):
        if above2 != j1.name:        # a single path: each one's nearest movable is the last
            raise URDFError(_branch_message(base, children, movable, j1, j2))
    return _fixed_tail(movable[-1][1].child, children)


def _fixed_tail(link, children):
    """``link`` followed down a unique tail of fixed joints."""
    while len(children[link]) == 1 and children[link][0].type == "fixed":
        link = children[link][0].child
    return link


def _branch_message(base, children, movable, j1, j2):
    """Why no tip_link is chosen, and which to choose: first the end of the longest chain
    of movable joints (the arm, not a finger of its gripper), then every branch's end.

    The longest chains are the paths of movable joints from ``base`` to the deepest branch
    ends. Their common part is the suggestion: where they part (a gripper's fingers), it
    ends after the last common joint, followed down the fixed links to just above the link
    that carries the parting joints (the flange, not the hand). Chains that part at the base
    (two arms) give one suggestion each."""
    joint = {j.name: j for _, j, _ in movable}
    below = {}
    for _, j, a in movable:                                  # parents come first (by depth)
        below.setdefault(a, []).append(j.name)
    path = {}
    for _, j, a in movable:
        path[j.name] = (path[a] if a is not None else ()) + (j.name,)
    leaves = [name for name in joint if name not in below]
    longest = max(len(path[name]) for name in leaves)
    deepest = sorted(path[name] for name in leaves if len(path[name]) == longest)
    groups = {}
    for p in deepest:                                        # chains parting at the base
        groups.setdefault(p[0], []).append(p)
    ends, how = [], []
    for paths in groups.values():
        common = 0
        while all(len(p) > common and p[common] == paths[0][common] for p in paths):
            common += 1
        last = joint[paths[0][common - 1]]
        span = f"{paths[0][0]!r} .. {last.name!r}, {common} joints"
        if len(paths) == 1:
            ends.append(_fixed_tail(last.child, children))
            how.append(span + ("" if ends[-1] == last.child else ", and down its fixed links"))
            continue
        parting = sorted({p[common] for p in paths})
        carrier = joint[parting[0]].parent
        route = _links_between(last.child, carrier, children)
        ends.append(route[-2] if len(route) > 1 else route[-1])
        parting = " and ".join(repr(name) for name in parting)
        how.append(span + (f", and down its fixed links to just above {carrier!r}, where "
                           f"{parting} branch off" if len(route) > 1 else
                           f"; {parting} branch off there"))
    others = sorted(joint[name].child for name in leaves)
    tips = ends + [t for t in others if t not in ends]
    if len(ends) == 1:
        why = f"the end of the longest chain of movable joints is {ends[0]!r} ({how[0]})"
    else:
        why = ("the longest chains of movable joints end at "
               + " and ".join(f"{e!r} ({h})" for e, h in zip(ends, how)))
    return (f"the movable joints below {base!r} branch (at {j1.name!r} and {j2.name!r}), so "
            f"there is no single chain to pick; choose a tip_link, e.g. one of {tips}: {why}; "
            "the others end the other branches")


def _links_between(top, bottom, children):
    """The links from ``top`` down to ``bottom`` (both included); ``bottom`` is below ``top``."""
    route, stack = {}, [top]
    while stack:
        link = stack.pop()
        for joint in children[link]:
            route[joint.child] = link
            stack.append(joint.child)
    links = [bottom]
    while links[-1] != top:
        links.append(route[links[-1]])
    return links[::-1]
