"""Which leader joint each follower joint copies, and within which limits (pure).

Joints are matched by name, as the two arms' URDFs name them: a follower joint with no
leader joint of its name is refused before anything moves, and a leader joint no follower
joint copies is left out (and said). Each goal is kept within the follower's URDF limits, so
a leader that reaches further (another model, a joint past its stop) never sends the
follower into its own.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

from ..errors import RobotValueError

if TYPE_CHECKING:
    from ..dynamixel_system import DynamixelJoint


class JointMap:
    """Leader joint positions -> follower goals (joint units, the follower's order)."""

    def __init__(self, leader: Sequence[DynamixelJoint], follower: Sequence[DynamixelJoint]
                 ) -> None:
        names = [j.name for j in leader]
        missing = [j.name for j in follower if j.name not in names]
        if missing:
            raise RobotValueError(
                f"the follower's joint{'s' if len(missing) > 1 else ''} {', '.join(missing)} "
                f"{'have' if len(missing) > 1 else 'has'} no leader joint of that name (the "
                f"leader has {', '.join(names)}): teleoperation copies joints by name")
        self.follower = tuple(j.name for j in follower)
        self.index = [names.index(j.name) for j in follower]
        #: leader joints no follower joint copies
        self.unused = tuple(n for n in names if n not in self.follower)
        self.lower = [-math.inf if j.lower is None else j.lower for j in follower]
        self.upper = [math.inf if j.upper is None else j.upper for j in follower]

    def __call__(self, leader: Sequence[float]) -> list[float]:
        """The follower's goals for the leader's positions ``leader`` (the leader's order)."""
        return [min(max(leader[i], low), high)
                for i, low, high in zip(self.index, self.lower, self.upper, strict=True)]
