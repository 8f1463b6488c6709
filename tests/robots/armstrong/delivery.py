"""How a walk's commands reached the motors, from its bag, read with ``mcap``'s own reader
(not servolab's): for each leg motor and each row sent to its controller, how long until the
motor's goal register, read back in ``/motor_states`` (``MotorState.goal``, the 17 bytes
from the goal position that ``dynamixel_io``'s ``get_feedback`` reads), held that row's goal.

Shared by tests/robots/armstrong/test_realtime.py and benchmarks/gait.py.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from mcap_ros2.reader import read_ros2_messages

#: RX-28 positions: 1024 ticks over 300 degrees, 512 at the centre (e-Manual, RX-28 Goal
#: Position)
TICKS_PER_RAD = 1023 / math.radians(300)


@dataclass(frozen=True)
class Delivery:
    """One motor's rows that changed its goal: each one's delay (s) until read back, None
    where never seen."""

    motor: int
    delays: list[float | None]

    @property
    def delivered(self) -> int:
        return sum(d is not None for d in self.delays)


def goal_deliveries(bag: Path, inits: dict[int, int], *, rows: slice = slice(None)
                    ) -> dict[int, Delivery]:
    """Per motor of ``inits`` (ID -> raw init): the commands ``rows`` picks of those sent to
    its controller, in order, each that changed the motor's goal (a row that repeats the
    goal before it would be found read back at once, proving nothing). The stand's 20 Hz
    poses come before the gait's rows, and no sweep can read back each of those: they are
    left out with ``rows``. A MotorState's
    ``timestamp`` is when its READ was made, on the clock the bag's log times are on (the
    epoch on a real robot, as ROS stamps it; the simulation's time on an emulated one)."""
    (file,) = sorted(bag.glob("*.mcap"))
    commands: dict[int, list[tuple[float, int]]] = {i: [] for i in inits}
    reads: dict[int, list[tuple[float, int]]] = {i: [] for i in inits}
    for message in read_ros2_messages(str(file)):
        t = message.log_time_ns / 1e9
        topic = message.channel.topic
        if topic.endswith("/command"):
            motor = int(topic.split("_m")[1].split("/")[0])
            if motor in inits:
                raw = round(inits[motor] + message.ros_msg.data * TICKS_PER_RAD)
                commands[motor].append((t, raw))
        elif topic.startswith("/motor_states/"):
            for state in message.ros_msg.motor_states:
                if state.id in reads:
                    reads[state.id].append((state.timestamp, state.goal))
    out = {}
    for motor, sent in commands.items():
        seen = sorted(reads[motor])
        delays: list[float | None] = []
        picked = list(range(len(sent)))[rows]
        for k in picked:
            t, raw = sent[k]
            if k > 0 and abs(sent[k - 1][1] - raw) <= 1:
                continue  # the goal did not change: a read-back could not tell the row
            hit = next((ts for ts, goal in seen if ts >= t and abs(goal - raw) <= 1), None)
            delays.append(None if hit is None else hit - t)
        out[motor] = Delivery(motor, delays)
    return out


def row_end_errors(bag: Path, inits: dict[int, int], *, rows: slice = slice(None)
                   ) -> dict[int, list[float]]:
    """Per motor of ``inits``: for each command ``rows`` picks, how far (degrees) the motor's
    present position was from it at the last READ before the next command (or the bag's
    end): how closely the joint followed the row it was given."""
    (file,) = sorted(bag.glob("*.mcap"))
    commands: dict[int, list[tuple[float, int]]] = {i: [] for i in inits}
    reads: dict[int, list[tuple[float, int]]] = {i: [] for i in inits}
    for message in read_ros2_messages(str(file)):
        topic = message.channel.topic
        if topic.endswith("/command"):
            motor = int(topic.split("_m")[1].split("/")[0])
            if motor in inits:
                raw = round(inits[motor] + message.ros_msg.data * TICKS_PER_RAD)
                commands[motor].append((message.log_time_ns / 1e9, raw))
        elif topic.startswith("/motor_states/"):
            for state in message.ros_msg.motor_states:
                if state.id in reads:
                    reads[state.id].append((state.timestamp, state.position))
    out: dict[int, list[float]] = {}
    for motor, sent in commands.items():
        seen = sorted(reads[motor])
        ends = [t for t, _ in sent[1:]] + [math.inf]
        errors = []
        for (t, raw), end in list(zip(sent, ends, strict=True))[rows]:
            inside = [position for ts, position in seen if t <= ts < end]
            if inside:
                errors.append(abs(inside[-1] - raw) / TICKS_PER_RAD * 180 / math.pi)
        out[motor] = errors
    return out
