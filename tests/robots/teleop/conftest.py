"""Two emulated arms in this process, on the simulation's virtual clock: the rig ``servolab
teleop`` runs by default, opened piece by piece so that a test can step its loop, reach into
its motors and look at what the follower does after a stop."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path

from servolab.robots.teleop.hand import Episodes
from servolab.robots.teleop.loop import LoopOptions
from servolab.robots.teleop.run import TeleopRequest, TeleopTask, prepare
from servolab.runs import RunFolder

#: a fast loop for tests: 100 cycles a virtual second (the emulated firmware costs ~2 ms of
#: CPU a cycle), the follower's state at every one
FAST = LoopOptions(rate=100.0, state_rate=100.0, camera_rate=0.0)


def request(**changes: object) -> TeleopRequest:
    """The default rig, with the fast loop, no camera and short episodes unless changed."""
    fields: dict[str, object] = {"episodes": Episodes(1.0, 1, 0.2), "camera": False,
                                 "options": FAST}
    fields.update(changes)
    return TeleopRequest(**fields)  # type: ignore[arg-type]


@contextmanager
def rig(out: Path, **changes: object) -> Iterator[TeleopTask]:
    """The rig's task, open (arms checked and configured, the follower holding, the bag
    open), closed after."""
    task = TeleopTask(RunFolder.create("teleop", out), prepare(request(**changes)),
                      lambda _: None, None)
    with ExitStack() as opened:
        task.open(opened)
        try:
            yield task
        finally:
            if task.bag is not None:
                task.bag.close()
