"""The firmware's short ways for goal writes (issue 49: a gait writes twenty motors' goals
several times a second, and the emulated firmware decoded its whole table for each).

A write of goal, speed, limit or gain registers alone re-plans the joint without decoding the
rest of the table, and the feedback laws (:mod:`servolab.dynamixel.gains`) stay decoded until
a gain register changes. Both are only worth having if they give the joint exactly the
command the full decode gives: that is what these tests hold them to, over every kind of
model, with random writes the firmware accepts and refuses.
"""

from __future__ import annotations

import random

import pytest

from servolab.dynamixel import gains, model
from servolab.dynamixel.packets import Instruction
from servolab.dynamixel.virtual_motor import _COMMAND_ONLY, _GAINS
from servolab.sim import Simulation, emulated_port

# One of each family: AX/RX/EX compliance, MX (1.0) PID, X-series position/velocity PID on
# 2.0, and the XL-320 (the AX-style table on 2.0).
MODELS = ["RX-28", "EX-106+", "MX-28", "XM430-W350", "XL430-W250", "XL-320"]


def _motor(name: str, seed: int):  # type: ignore[no-untyped-def]
    sim = Simulation(0.001)
    port = emulated_port(f"{model(name).name.lower()}:1", simulation=sim)
    motor = port.emulator.motor(1)
    return sim, motor, random.Random(seed)


def _decoded(motor: object) -> dict[str, object]:
    """What the firmware keeps decoded from its table (mode, sign, offsets, limits...)."""
    return {k: v for k, v in vars(motor).items() if isinstance(v, bool | int | float | str)}


@pytest.mark.parametrize("name", MODELS)
def test_a_goal_write_gives_the_joint_the_command_a_full_decode_gives(name: str) -> None:
    """After every write the firmware accepts (of command registers alone, where it takes the
    short way, and of any other writable register, where it does not: torque on and off,
    each operating mode the model has), the plant's command is the one a full decode of the
    table makes."""
    sim, motor, rng = _motor(name, seed=49)
    m = motor.model
    command = sorted(r.name for r in m.registers if r.name in _COMMAND_ONLY and r.writable)
    others = sorted(r.name for r in m.registers if r.writable and r.name not in _COMMAND_ONLY
                    and r.name not in ("id", "baud_rate", "lock"))
    assert "goal_position" in command
    setups: list[dict[str, int]] = [{"torque_enable": 1}, {"torque_enable": 0}]
    for mode in m.operating_modes:
        setups.append({"torque_enable": 0, "operating_mode": mode})
    accepted = 0
    for setup in setups:
        for reg_name, value in setup.items():
            reg = m.register(reg_name)
            motor.write(reg.address, reg.encode(value))
        if m.has("operating_mode"):
            torque = m.register("torque_enable")
            motor.write(torque.address, torque.encode(1))
        for _ in range(150):
            reg = m.register(rng.choice(command if rng.random() < 0.6 else others))
            value = rng.randint(reg.raw_min, reg.raw_max)
            error = motor.write(reg.address, reg.encode(value))
            sim.advance(rng.choice((0.0, 0.001, 0.013)))
            if error:
                continue
            accepted += 1
            fast, decoded = motor._plant.command, _decoded(motor)
            motor._laws = None
            motor._table_changed()          # the full decode, from every register
            assert motor._plant.command == fast, (reg.name, value)
            assert _decoded(motor) == decoded, (reg.name, value)
    assert accepted > 100


@pytest.mark.parametrize("name", ["RX-28", "MX-28", "XM430-W350"])
def test_goal_writes_keep_the_feedback_laws_and_a_gain_write_changes_them(
        name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Goals do not decode the gains again; a new gain is in the next command at once."""
    sim, motor, _ = _motor(name, seed=1)
    m = motor.model
    torque = m.register("torque_enable")
    motor.write(torque.address, torque.encode(1))
    decoded: list[str] = []
    original = gains.compliance

    def counting(model_: object, get: gains.Getter) -> object:
        decoded.append("compliance")
        return original(model_, get)  # type: ignore[arg-type]

    monkeypatch.setattr(gains, "compliance", counting)
    goal = m.register("goal_position")
    for k in range(10):
        motor.write(goal.address, goal.encode(m.position_center + 20 * (k % 3)))
        sim.advance(0.01)
    assert decoded == []
    before = motor._plant.command.compliance
    gain_name = next(n for n in ("cw_compliance_slope", "p_gain", "position_p_gain")
                     if m.has(n))
    assert gain_name in _GAINS
    gain = m.register(gain_name)
    new_value = 64 if motor.get_raw(gain_name) != 64 else 16
    assert motor.write(gain.address, gain.encode(new_value)) == 0
    assert decoded == ["compliance"]
    after = motor._plant.command.compliance
    assert after is not None and after != before


def test_a_goal_that_switches_torque_on_takes_the_full_decode() -> None:
    """Protocol 1.0: a goal position switches torque on (e-Manual; ROS dynamixel_motor never
    writes torque_enable), and the joint then holds from where the horn is."""
    sim, motor, _ = _motor("RX-28", seed=2)
    m = motor.model
    goal = m.register("goal_position")
    assert motor.get_raw("torque_enable") == 0
    status = motor.execute(Instruction(1, 0x03, bytes((goal.address,)) + goal.encode(600)),
                           "WRITE")
    assert status.error == 0
    assert motor.get_raw("torque_enable") == 1
    command = motor._plant.command
    assert command.torque_enabled
    sim.advance(1.0)
    present = m.register("present_position")
    assert present.decode(motor.read(present.address, present.size).params) == 600
