"""The figure of docs/contacts.md, docs/contacts_drop_stand.png: Solo12 (example-robot-data's
URDF, a floating base) dropped from 5 cm onto the ground, then standing.

Its four feet (point contacts at the FOOT links' origins) meet ``sd.Ground(friction=1.0)``
in ``sd.simulate`` (semi-implicit Euler, 1 ms, velocity-level time stepping: docs/
simulation.md). The joints get the torques that hold the robot standing in the drop's
posture with its feet on the ground (``contact_inverse_dynamics`` at rest) plus a PD
towards that posture (50 N m/rad, 0.5 N m s/rad; test/contacts/test_ground_simulation.py
holds it with 5 and 0.1, which lets it settle 8 mm higher: the feet stick where they land).
The figure shows the base height and the feet's normal forces over time, with the weight;
the script prints the numbers docs/contacts.md quotes.

Run: .venv/bin/python docs/make_contact_figure.py   (about 10 s)
"""
import os
import sysconfig

import numpy as np

import serial_dynamics as sd

HERE = os.path.dirname(os.path.abspath(__file__))
# example-robot-data's URDF, where its wheel (the [test] extra) puts it
SOLO = os.path.join(sysconfig.get_paths()["purelib"], "cmeel.prefix", "share",
                    "example-robot-data", "robots", "solo_description", "robots", "solo12.urdf")

FEET = ["FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"]
LEGS = np.array([0.0, 0.8, -1.6, 0.0, 0.8, -1.6, 0.0, -0.8, 1.6, 0.0, -0.8, 1.6])
DROP, DURATION, DT = 0.05, 1.0, 1e-3      # m, s, s
KP, KD = 50.0, 0.5                        # N m/rad, N m s/rad


def run():
    robot = sd.load_urdf(SOLO, floating_base=True)
    q0 = np.r_[np.zeros(6), 1.0, LEGS]
    stand = -min(robot.forward_kinematics(q0, f)[2, 3] for f in FEET)   # feet on the ground
    q0[2] = stand
    feet = [sd.Contact(f) for f in FEET]
    still = np.zeros(robot.nv)
    tau, _ = robot.contact_inverse_dynamics(q0, still, still, feet, friction=1.0)

    def control(t, q, v):                 # holding torques + PD on the joints
        return tau[6:] + KP * (LEGS - q[7:]) - KD * v[6:]

    q0[2] += DROP
    res = sd.simulate(robot, DURATION, q0, torque=control, ground=sd.Ground(friction=1.0),
                      contacts=feet, method="semi_implicit_euler", dt=DT)
    weight = 9.81 * (robot.model.base_mass + robot.model.mass.sum())
    fz = res.contact_forces[:, :, 2]
    total = fz.sum(axis=1)
    touch = res.t[np.argmax(res.contact_active.any(axis=1))]
    # at rest: from then on every speed below 1 mm/s (rad/s) and every foot pushing
    moving = (np.max(np.abs(res.qd), axis=1) > 1e-3) | ~res.contact_active.all(axis=1)
    rest = res.t[np.flatnonzero(moving)[-1] + 1]
    peak = int(np.argmax(total))
    print(f"Solo12, {robot.model.base_mass + robot.model.mass.sum():.3f} kg, weight "
          f"{weight:.3f} N; standing base height {stand * 1e3:.1f} mm, dropped from "
          f"{DROP * 1e2:.0f} cm above it")
    print(f"first touch at t = {touch:.3f} s (free fall: {np.sqrt(2 * DROP / 9.81):.3f} s)")
    print(f"peak: the feet's normal forces sum to {total[peak]:.0f} N "
          f"({total[peak] / weight:.1f} x the weight) over the step at t = {res.t[peak]:.3f} s; "
          f"one foot at most {fz.max():.0f} N")
    after = res.t >= touch
    air = res.t[after & ~res.contact_active.any(axis=1)]
    if air.size:
        print(f"in the air again (a hop) from t = {air[0]:.3f} s to {air[-1] + DT:.3f} s")
    print(f"at rest (speeds < 1e-3, four feet pushing) from t = {rest:.3f} s, "
          f"{rest - touch:.3f} s after the touch; base height then {res.q[-1, 2] * 1e3:.2f} mm "
          f"({(res.q[-1, 2] - stand) * 1e3:+.2f} mm from the standing pose)")
    print(f"final sum of the normal forces {total[-1]:.6f} N, weight {weight:.6f} N "
          f"(relative difference {abs(total[-1] - weight) / weight:.1e}); each foot "
          f"{np.round(fz[-1], 3).tolist()} N")
    plot(res, fz, total, weight, stand, touch, rest, peak)


def plot(res, fz, total, weight, stand, touch, rest, peak):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = res.t
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True,
                                   gridspec_kw={"height_ratios": [1, 1.6]})
    ax1.plot(t, res.q[:, 2] * 1e3, color="k", lw=1.5, label="base height")
    ax1.axhline(stand * 1e3, color="0.5", ls=":", lw=1, label="standing pose")
    ax1.set_ylabel("base height (mm)")
    ax1.legend(loc="upper right", fontsize=9)
    ax1.set_title("Solo12 dropped from 5 cm onto the ground, then standing\n"
                  "(holding torques + joint PD, semi-implicit Euler at 1 ms, friction 1.0)",
                  fontsize=11)
    styles = [("tab:blue", "-", 3.2), ("tab:orange", "--", 2.2), ("tab:green", "-.", 1.6),
              ("tab:red", ":", 1.4)]          # the stance is symmetric: the four coincide
    for i, foot in enumerate(FEET):
        color, ls, lw = styles[i]
        ax2.plot(t, fz[:, i], color=color, ls=ls, lw=lw, label=f"{foot}")
    ax2.plot(t, total, color="k", lw=1.6, label="sum of the four")
    ax2.axhline(weight, color="k", ls="--", lw=1, label=f"weight {weight:.2f} N")
    # linear up to 40 N (standing), logarithmic above (the landing's peak)
    ax2.set_yscale("symlog", linthresh=40.0, linscale=2.5)
    ax2.set_ylim(-1.0, 400.0)
    ax2.set_yticks([0, 10, 20, 30, 40, 100, 200, 400])
    ax2.set_yticklabels(["0", "10", "20", "30", "40", "100", "200", "400"])
    ax2.annotate(f"landing: {total[peak]:.0f} N", xy=(t[peak], total[peak]),
                 xytext=(t[peak] + 0.06, total[peak] * 1.2), fontsize=9,
                 arrowprops=dict(arrowstyle="->", color="0.3"))
    for ax in (ax1, ax2):
        ax.axvline(touch, color="0.6", lw=0.8)
        ax.axvline(rest, color="0.6", lw=0.8)
        ax.grid(alpha=0.3)
    high = ax1.get_ylim()[1]
    ax1.text(touch + 0.008, high - 12, "touch", fontsize=9, color="0.3")
    ax1.text(rest + 0.008, high - 12, "at rest", fontsize=9, color="0.3")
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("normal force (N; log above 40)")
    ax2.legend(loc="upper right", fontsize=8.5, ncol=2,
               title="normal forces (the four feet coincide)", title_fontsize=8.5)
    fig.tight_layout()
    out = os.path.join(HERE, "contacts_drop_stand.png")
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    run()
