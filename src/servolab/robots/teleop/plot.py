"""``teleop.png``: each follower joint's goal (the leader, mapped) and where the follower was, at
each state read, with the episodes shaded."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ...runs import RunFolder
    from .loop import TeleopLoop


def plot_run(loop: TeleopLoop, run_folder: RunFolder) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    record = loop.record
    t = np.array(record.times) - record.started
    goals, positions = np.array(record.goals), np.array(record.positions)
    names = loop.follower.names
    figure, axes = plt.subplots(len(names), 1, figsize=(8, 1.6 * len(names) + 0.8),
                                sharex=True, squeeze=False)
    for i, (ax, name) in enumerate(zip(axes[:, 0], names, strict=True)):
        ax.plot(t, goals[:, i], linestyle="--", linewidth=1.0, label="goal (leader)")
        ax.plot(t, positions[:, i], linewidth=1.0, label="follower")
        for episode in record.episodes:
            end = episode.end if episode.end == episode.end else record.ended
            ax.axvspan(episode.start - record.started, end - record.started, alpha=0.08)
        ax.set_ylabel(name, fontsize=8)
        ax.grid(True, alpha=0.3)
    axes[0, 0].legend(loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("time [s] (episodes shaded)")
    axes[0, 0].set_title("teleoperation: the follower's joints against the leader's")
    return run_folder.save_figure(figure, "teleop.png")
