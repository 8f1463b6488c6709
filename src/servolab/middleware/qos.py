"""Quality of service, in rclpy's names: :class:`QoSProfile` and its policies.

A publisher and a subscription each carry one profile. servolab honours four policies, the ones
a robot's topics need and rmw_zenoh maps onto Zenoh: reliability, durability, history and
depth. Deadline, lifespan and liveliness keep ROS's defaults (infinite, AUTOMATIC).

The policy values are ROS's own (``rmw/types.h``: 0 SYSTEM_DEFAULT, 1 RELIABLE /
TRANSIENT_LOCAL / KEEP_LAST, 2 BEST_EFFORT / VOLATILE / KEEP_ALL), which is also how they are
written in rmw_zenoh's liveliness tokens. Where ROS lets the middleware pick
(SYSTEM_DEFAULT), servolab picks what rmw_zenoh picks: RELIABLE, VOLATILE, KEEP_LAST.

An int where a profile is expected is a depth, as in rclpy: ``create_publisher(T, "t", 10)``
is KEEP_LAST(10), RELIABLE, VOLATILE.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace
from enum import IntEnum

from .errors import MiddlewareValueError


class ReliabilityPolicy(IntEnum):
    """RELIABLE retransmits what is lost; BEST_EFFORT drops it (sensor streams)."""

    SYSTEM_DEFAULT = 0
    RELIABLE = 1
    BEST_EFFORT = 2


class DurabilityPolicy(IntEnum):
    """TRANSIENT_LOCAL keeps a publisher's last ``depth`` messages for subscriptions that
    join later (a latched topic: ``/robot_description``, a map); VOLATILE keeps none."""

    SYSTEM_DEFAULT = 0
    TRANSIENT_LOCAL = 1
    VOLATILE = 2


class HistoryPolicy(IntEnum):
    """KEEP_LAST holds at most ``depth`` messages waiting; KEEP_ALL holds every one."""

    SYSTEM_DEFAULT = 0
    KEEP_LAST = 1
    KEEP_ALL = 2


@dataclass(frozen=True, slots=True)
class QoSProfile:
    """rclpy's ``QoSProfile`` for the policies servolab honours (see the module docstring).

    ``depth`` counts for KEEP_LAST; with KEEP_ALL it is ignored (and written as 0).
    """

    history: HistoryPolicy = HistoryPolicy.KEEP_LAST
    depth: int = 10
    reliability: ReliabilityPolicy = ReliabilityPolicy.RELIABLE
    durability: DurabilityPolicy = DurabilityPolicy.VOLATILE

    def __post_init__(self) -> None:
        if isinstance(self.depth, bool) or not isinstance(self.depth, int) or self.depth < 0:
            raise MiddlewareValueError(f"QoS depth must be an int >= 0, got {self.depth!r}")
        # Accept plain ints and SYSTEM_DEFAULT, store rmw_zenoh's choice for the latter.
        object.__setattr__(self, "history", HistoryPolicy(self.history)
                           or HistoryPolicy.KEEP_LAST)
        object.__setattr__(self, "reliability", ReliabilityPolicy(self.reliability)
                           or ReliabilityPolicy.RELIABLE)
        object.__setattr__(self, "durability", DurabilityPolicy(self.durability)
                           or DurabilityPolicy.VOLATILE)
        if self.history == HistoryPolicy.KEEP_LAST and self.depth == 0:
            # KEEP_LAST of nothing would hold no message at all; say what was meant
            raise MiddlewareValueError("QoS KEEP_LAST needs depth >= 1 (use KEEP_ALL to keep every "
                                       "message)")

    @property
    def reliable(self) -> bool:
        return self.reliability == ReliabilityPolicy.RELIABLE

    @property
    def transient_local(self) -> bool:
        return self.durability == DurabilityPolicy.TRANSIENT_LOCAL

    @property
    def keep_all(self) -> bool:
        return self.history == HistoryPolicy.KEEP_ALL

    @property
    def queue_depth(self) -> int:
        """How many messages may wait: ``depth``, or 0 (no bound) for KEEP_ALL."""
        return 0 if self.keep_all else self.depth

    @property
    def history_depth(self) -> int:
        """How many messages a TRANSIENT_LOCAL publisher keeps for late subscriptions:
        ``depth``, or :data:`KEEP_ALL_HISTORY` for KEEP_ALL (kept history must be bounded:
        a publisher that runs for hours would otherwise keep every message it sent)."""
        return KEEP_ALL_HISTORY if self.keep_all else self.depth

    def with_depth(self, depth: int) -> QoSProfile:
        return replace(self, depth=depth)


#: The history a TRANSIENT_LOCAL + KEEP_ALL publisher keeps (servolab's bound; see
#: :attr:`QoSProfile.history_depth`).
KEEP_ALL_HISTORY = 1000

#: rclpy's ``qos_profile_sensor_data``: newest data only, losses allowed.
qos_profile_sensor_data = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
#: rclpy's ``qos_profile_system_default`` as rmw_zenoh resolves it.
qos_profile_system_default = QoSProfile()
#: What a latched topic wants: late subscriptions get the last message.
qos_profile_latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def as_profile(qos: QoSProfile | int) -> QoSProfile:
    """A profile from what rclpy accepts where a QoS goes: a profile, or a depth (KEEP_LAST
    of it; 0 means KEEP_ALL, servolab's spelling before profiles)."""
    if isinstance(qos, QoSProfile):
        return qos
    if isinstance(qos, bool) or not isinstance(qos, int):
        raise TypeError(f"QoS must be a QoSProfile or a depth (int), got {qos!r}")
    if qos == 0:
        return QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=0)
    return QoSProfile(depth=qos)


def adapted_policies(offers: Iterable[QoSProfile | None]
                     ) -> tuple[ReliabilityPolicy, DurabilityPolicy]:
    """The reliability and durability a subscription takes to hear every publisher of a
    topic, as ``ros2 topic echo`` chooses them (ros2topic ``EchoVerb.choose_qos``): RELIABLE
    if every publisher is, else BEST_EFFORT; TRANSIENT_LOCAL if every publisher is (so what a
    latched topic kept reaches it), else VOLATILE. With no publisher known: RELIABLE,
    VOLATILE. Unknown offers (None) do not count."""
    known = [q for q in offers if q is not None]
    reliable = all(q.reliable for q in known)
    latched = bool(known) and all(q.transient_local for q in known)
    return (ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
            DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)
