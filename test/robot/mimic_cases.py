"""The synthetic chain with mimic joints that many tests share (no Pinocchio needed: the
gpu tests run it on a card's machine that has none)."""


def mimic_chain(follower="revolute"):
    """base -j1(z)- l1 -j2- l2 -j3 (mimics j2: 1.5 q2 + 0.2)- l3 -j4 (mimics j1: -0.7 q1)- l4,
    axes tilted, every link with products of inertia, damping and friction."""
    def link(name, m, c, I):
        return (f'<link name="{name}"><inertial><origin xyz="{c}" rpy="0.1 0.2 0.3"/>'
                f'<mass value="{m}"/><inertia ixx="{I[0]}" iyy="{I[1]}" izz="{I[2]}" ixy="0.001" '
                f'ixz="-0.002" iyz="0.0015"/></inertial></link>')

    def joint(name, parent, child, kind, xyz, rpy, axis, extra=""):
        return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
                f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>'
                '<limit lower="-2" upper="2" effort="100" velocity="5"/>'
                f'<dynamics damping="0.3" friction="0.1"/>{extra}</joint>')
    prismatic = follower == "prismatic"
    return ('<robot name="mimic"><link name="base"/>'
            + link("l1", 2.0, "0.1 0 0.05", (0.05, 0.06, 0.04))
            + link("l2", 1.5, "0.2 0.01 0", (0.03, 0.05, 0.04))
            + link("l3", 1.0, "0.05 0.02 0.1", (0.02, 0.03, 0.025))
            + link("l4", 0.5, "0.02 0 0.03", (0.01, 0.012, 0.009))
            + joint("j1", "base", "l1", "revolute", "0 0 0.1", "0 0 0", "0 0 1")
            + joint("j2", "l1", "l2", "revolute", "0.3 0 0", "0.3 0 0", "0 1 0")
            + joint("j3", "l2", "l3", "prismatic" if prismatic else "revolute", "0.4 0 0",
                    "0 0.2 0", "1 0 0" if prismatic else "0 0.6 0.8",
                    '<mimic joint="j2" multiplier="1.5" offset="0.2"/>')
            + joint("j4", "l3", "l4", "revolute", "0.2 0.1 0", "0.1 0 0", "0 0 1",
                    '<mimic joint="j1" multiplier="-0.7"/>')
            + "</robot>")
