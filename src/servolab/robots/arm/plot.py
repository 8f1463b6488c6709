"""``arm.png``: each arm joint commanded against measured over the run, and the gripper.

Commanded is what the arm controller commanded (its ``controller_state`` reference, the
trajectory as joint_trajectory_controller sampled it), or, when that was not heard, the
goals' points as sent; measured is ``/joint_states``. Time is from the first joint state.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .session import Heard
from .spec import ArmSpec


def plot_joints(heard: Heard, spec: ArmSpec, target: Path, *, title: str = "") -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t0 = heard.state_times[0]
    times = np.array(heard.state_times) - t0
    rows = len(spec.joints) + (1 if spec.gripper is not None else 0)
    figure, axes = plt.subplots(rows, 1, figsize=(8, 1.8 * rows + 0.6), sharex=True,
                                squeeze=False)
    for i, joint in enumerate(spec.joints):
        axis = axes[i][0]
        measured = np.array([s.get(joint, np.nan) for s in heard.states])
        if heard.references:
            axis.plot(np.array(heard.reference_times) - t0,
                      [r[i] for r in heard.references], color="tab:orange", lw=1.2,
                      label="commanded (controller reference)")
        else:
            for k, (sent, at, positions) in enumerate(heard.sent):
                axis.plot(sent - t0 + at, positions[:, i], ".", color="tab:orange", ms=3,
                          label="commanded (goal points)" if k == 0 else None)
        axis.plot(times, measured, color="tab:blue", lw=1.0, label="measured (/joint_states)")
        axis.set_ylabel(f"{joint}\n(rad)")
        axis.grid(True, alpha=0.3)
        if i == 0:
            axis.legend(loc="best", fontsize=7)
    if spec.gripper is not None:
        axis = axes[-1][0]
        axis.plot(times, [s.get(spec.gripper.joint, np.nan) for s in heard.states],
                  color="tab:green", lw=1.0)
        axis.axhline(spec.gripper.opened, color="grey", lw=0.6, ls="--")
        axis.axhline(spec.gripper.closed, color="grey", lw=0.6, ls=":")
        axis.set_ylabel(f"{spec.gripper.joint}\n(measured)")
        axis.grid(True, alpha=0.3)
    axes[-1][0].set_xlabel("time (s)")
    if title:
        figure.suptitle(f"{title}: {spec.robot}")
    figure.tight_layout()
    figure.savefig(target, dpi=110)
    plt.close(figure)
    return target
