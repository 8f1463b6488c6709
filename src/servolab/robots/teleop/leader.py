"""An arm's *leader*, as a robot plug-in of its own: the arm's motors and URDF, its torque off,
and, emulated, a scripted hand (:mod:`.hand`) moving it, so that ``servolab sim --robot
NAME_leader --pty`` serves a leader arm that moves, in real time, to any client (``servolab
teleop --leader DEVICE``, a benchmark, another program). ROBOTIS sells the OpenMANIPULATOR-X as
a leader too (OMX-L): the same motors, the same URDF, and a person's hand instead of torque.

An arm's package declares its leader in its own ``ROBOTS`` with :func:`leader_plugin`, giving
the hand's home and swing of each joint (:class:`LeaderPlugin`'s ``hand``): a pose about which
a person would move the arm, chosen for that arm (its table, its reach). Nothing here names an
arm; ``servolab teleop`` finds an arm's leader by :func:`leader_of`.

On a port the leader is the arm itself, its torque off (the joints limp, ready for a hand).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..errors import RobotValueError
from ..plugin import BusSummary, RobotPlugin, ServedRobot
from ..urdf_robot import ON_STOP

if TYPE_CHECKING:
    from ...dynamixel.emulator import Emulator
    from ...sim.simulation import Simulation
    from ..dynamixel_system import DynamixelSystem
    from .hand import HandWorld

#: a joint's (home, swing) for the scripted hand: rad, or m for a prismatic joint
Hand = Mapping[str, tuple[float, float]]
#: what the served leader's hand does: episodes of this long, this far apart, with this
#: seed, the first this long after the server starts (a client has time to connect), on
#: and on
SERVED_EPISODE_S, SERVED_RESET_S, SERVED_SEED, SERVED_BEGIN_S = 20.0, 1.0, 0, 1.0
SERVED_EPISODES = 1_000_000


@dataclass(frozen=True)
class LeaderPlugin(RobotPlugin):
    """A leader arm: ``arm`` names the robot it is the leader of, ``hand`` the scripted
    hand's home and swing of each joint (None: each joint's range decides, see
    :func:`.hand.swings`)."""

    arm: str = ""
    hand: Hand | None = field(default=None, compare=False)


def leader_plugin(arm: str, hand: Hand | None = None, *, name: str | None = None,
                  summary: str | None = None, default_model: str | None = None
                  ) -> LeaderPlugin:
    """The leader of the arm plug-in called ``arm`` (named ``ARM_leader`` unless ``name``):
    its bus and URDF are the arm's, looked up when asked, so declaring it costs nothing.
    ``default_model`` is the arm's (what its ``<ros2_control>`` block leaves unnamed), for
    what reads the leader's URDF by itself (``servolab teleop --robot ARM_leader``)."""
    leader = name or f"{arm}_leader"

    def plugin() -> RobotPlugin:
        from ..registry import entry

        found = entry(arm)
        if found.description is None:
            raise RobotValueError(f"{leader}: the arm {arm!r} has no URDF to lead with")
        return found

    def urdf() -> str:
        text = plugin().description
        assert text is not None
        return text()

    def system() -> DynamixelSystem:
        from ..dynamixel_system import dynamixel_system

        return dynamixel_system(urdf(), f"{arm}.urdf", default_model=plugin().default_model)

    def bus() -> BusSummary:
        return system().bus()

    def open_(port: str | None) -> Any:
        from ..urdf_robot import UrdfRobot

        return UrdfRobot.open(leader, urdf(), port, source=f"{arm}.urdf",
                              default_model=plugin().default_model, on_stop="torque_off")

    def served(baudrate: int | None) -> ServedRobot:
        found = system()
        spec = found.bus().motor_spec().at_baudrate(baudrate or found.baudrate)

        def place(emulator: Emulator) -> tuple[Simulation, Emulator, HandWorld]:
            from ...sim.simulation import Simulation
            from .hand import Episodes, HandScript, hand_on, swings

            simulation = Simulation()
            simulation.add_emulator(emulator)
            script = HandScript(swings(found.joints, hand),
                                Episodes(SERVED_EPISODE_S, SERVED_EPISODES, SERVED_RESET_S),
                                SERVED_SEED, begin=simulation.now() + SERVED_BEGIN_S)
            return simulation, emulator, hand_on(emulator, simulation, found.joints, script)

        return ServedRobot(spec, place=place, what="moving the leader arm by a scripted hand")

    return LeaderPlugin(
        leader, summary or f"{arm} as a leader arm: torque off, moved by a scripted hand "
        "when emulated (servolab teleop)", bus=bus, open=open_, on_stop=ON_STOP["torque_off"],
        description=urdf, served=served, commands=("teleop",), default_model=default_model,
        arm=arm,
        hand=None if hand is None else dict(hand))


def leader_of(arm: str) -> LeaderPlugin | None:
    """The leader plug-in of the robot ``arm`` (or ``arm`` itself when it is a leader), if
    one is found; an alias of either names the same robot."""
    from ..registry import discover

    found = discover()
    name = found.aliases.get(arm, arm)
    for plugin in found.plugins.values():
        if isinstance(plugin, LeaderPlugin) and name in (
                found.aliases.get(plugin.arm, plugin.arm), plugin.name):
            return plugin
    return None
