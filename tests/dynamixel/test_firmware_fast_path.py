"""The firmware's short ways for goal writes (issue 49: a gait writes twenty motors' goals
several times a second, and the emulated firmware decoded its whole table for each).

A write of goal, speed, limit or gain registers alone re-plans the joint without decoding the
rest of the table, and the feedback laws (:mod:`servolab.dynamixel.gains`) stay decoded until
a gain register changes. Both are only worth having if they give the joint exactly the
command the full decode gives: that is what these tests hold them to, over every kind of
model, with random writes the firmware accepts and refuses.
"""

from __future__ import annotations

import dataclasses
import inspect
import random
from collections.abc import Set as AbstractSet

import pytest

from servolab.dynamixel import gains, model
from servolab.dynamixel.emulator import Emulator, Reply
from servolab.dynamixel.models import Register
from servolab.dynamixel.packets import Frame, Instruction, Status
from servolab.dynamixel.virtual_motor import _COMMAND_ONLY, _SETTINGS, VirtualMotor
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
    assert gain_name in gains.REGISTERS
    gain = m.register(gain_name)
    new_value = 64 if motor.get_raw(gain_name) != 64 else 16
    assert motor.write(gain.address, gain.encode(new_value)) == 0
    assert decoded == ["compliance"]
    after = motor._plant.command.compliance
    assert after is not None and after != before


class _FullDecode(VirtualMotor):
    """The firmware as it was before the short way: every change decodes the whole table."""

    def _table_changed(self, names: AbstractSet[str] | None = None) -> None:
        self._laws = None
        super()._table_changed(None)


def _twin_bus(name: str, kind: type[VirtualMotor]) -> tuple[Simulation, Emulator]:
    sim = Simulation(0.001)
    m = model(name)
    # an X-series horn more than a turn from 0: what Position Control Mode drops when torque
    # comes on in it (e-Manual, Present Position note)
    position = 7.0 if m.has("operating_mode") else 0.3
    emulator = sim.add_emulator(Emulator(m.protocol, [kind(m, 1, position=position)]))
    return sim, emulator


@pytest.mark.parametrize("name", MODELS)
def test_a_motor_answers_every_instruction_as_the_full_decode_does(name: str) -> None:
    """Behaviour, as a host sees it: two buses in step, one motor taking the short way and its
    twin always decoding everything, sent the same instructions give the same status bytes
    (errors and data) to every one, and their horns stand at the same angle at every step.
    Each round switches torque off, writes settings (modes, Drive Mode, homing, limits: the
    EEPROM takes them only then on the X-series), switches torque on by a goal or by Torque
    Enable, then sends random goals, gains and limits and READs of the whole table over time."""
    rng = random.Random(4949)
    m = model(name)
    pair = [_twin_bus(name, VirtualMotor), _twin_bus(name, _FullDecode)]
    motors = [emulator.motors[0] for _, emulator in pair]
    writable = [r for r in m.registers if r.writable and r.name not in ("id", "baud_rate",
                                                                         "lock")]
    command = [r for r in writable if r.name in _COMMAND_ONLY]
    # the registers the firmware keeps decoded besides the command's (a write of any of these
    # must take the full decode)
    settings = [r for r in writable if r.name in _SETTINGS - _COMMAND_ONLY]
    torque, goal = m.register("torque_enable"), m.register("goal_position")
    split = 1 if m.protocol == 1 else 2

    def send(reg: Register | None, value: int = 0) -> None:
        answers = [motor.read(0, m.table_size) if reg is None else motor.execute(
            Instruction(1, 0x03, reg.address.to_bytes(split, "little") + reg.encode(value)),
            "WRITE") for motor in motors]
        assert answers[0] == answers[1], (reg and reg.name, value)
        dt = rng.choice((0.0, 0.001, 0.004, 0.05))
        for sim, _ in pair:
            sim.advance(dt)
        assert motors[0].position == motors[1].position, (reg and reg.name, value)

    for _ in range(12):
        send(torque, 0)
        for _ in range(6):
            reg = rng.choice(settings)
            send(reg, rng.randint(reg.raw_min, reg.raw_max))
        if rng.random() < 0.5:
            send(torque, 1)
        else:           # (1.0: a goal switches torque on; X-series with Drive Mode bit 3)
            send(goal, rng.randint(goal.raw_min, goal.raw_max))
        for _ in range(25):
            if rng.random() < 0.25:
                send(None)
            else:
                reg = rng.choice(command)
                send(reg, rng.randint(reg.raw_min, reg.raw_max))


@pytest.mark.parametrize("instruction", ["RESET", "FACTORY_RESET", "REBOOT"])
def test_a_reset_brings_back_the_default_gains(instruction: str) -> None:
    """After a reset the laws are those of the factory gains, whatever was written before
    (REBOOT keeps the EEPROM, and no gain register is in EEPROM: e-Manual, Control Table)."""
    name = "RX-28" if instruction == "RESET" else "XM430-W350"
    _, motor, _ = _motor(name, seed=3)
    fresh = _motor(name, seed=3)[1]
    m = motor.model
    gain_name = "cw_compliance_slope" if m.has("cw_compliance_slope") else "position_p_gain"
    gain = m.register(gain_name)
    assert motor.write(gain.address, gain.encode(gain.default // 2 or 1)) == 0
    assert motor._plant.command.compliance != fresh._plant.command.compliance
    code = {"RESET": 0x06, "FACTORY_RESET": 0x06, "REBOOT": 0x08}[instruction]
    motor.execute(Instruction(1, code, b"\x01" if instruction == "FACTORY_RESET" else b""),
                  instruction)
    assert motor.get_raw(gain_name) == gain.default
    assert motor._feedback_laws() == fresh._feedback_laws()
    assert motor._plant.command.compliance == fresh._plant.command.compliance


@pytest.mark.parametrize("kind", [Instruction, Status, Frame, Reply])
def test_the_packet_classes_hand_written_constructors_match_their_fields(kind: type) -> None:
    """Instruction, Status, Frame and Reply write their own __init__ (a frozen dataclass's
    calls object.__setattr__ per field, four objects a READ): it must take the dataclass's
    fields, in order, with their defaults, and keep the instances frozen."""
    fields = dataclasses.fields(kind)
    parameters = list(inspect.signature(kind).parameters.values())
    assert [p.name for p in parameters] == [f.name for f in fields]
    for parameter, field in zip(parameters, fields, strict=True):
        assert (parameter.default is inspect.Parameter.empty) == (
            field.default is dataclasses.MISSING)
        if field.default is not dataclasses.MISSING:
            assert parameter.default == field.default
    made = kind(*[1 if f.type in ("int", "float") else b"x" for f in fields])
    assert dataclasses.replace(made) == made and hash(made) == hash(dataclasses.replace(made))
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(made, fields[0].name, 2)
