"""What the bus learnt of a motor goes where the motor goes (bus/memory.py).

A record added to :class:`MotorMemory` but left out of what an ID change moves would leave
the old ID's level, limits or torque behind and give the new ID a stranger's: these tests
fill every record the memory has, found by looking, not from a list.
"""

from __future__ import annotations

from typing import Any

from servolab.dynamixel import Bus, model
from servolab.dynamixel.bus.memory import MotorMemory

XM430 = model("XM430-W350")


def _records(memory: MotorMemory) -> dict[str, dict[int, Any]]:
    return {name: getattr(memory, name) for name in MotorMemory.__slots__
            if isinstance(getattr(memory, name), dict)}


def _filled(motor_id: int) -> tuple[MotorMemory, dict[int, Any]]:
    memory = MotorMemory()
    for name, record in _records(memory).items():
        record[motor_id] = f"{name} of {motor_id}"
    memory.answered.add(motor_id)
    return memory, {motor_id: XM430}


def test_an_id_change_moves_every_record_and_drops_what_was_at_the_new_id() -> None:
    memory, models = _filled(3)
    memory.levels[7] = 0                 # a stranger once seen at 7: not the moved motor's
    memory.rekey_after_id_change(3, 7, models)
    assert models == {7: XM430}
    for name, record in _records(memory).items():
        assert record == {7: f"{name} of 3"}, name
    assert memory.answered == {7}


def test_an_id_change_of_a_motor_known_for_nothing_clears_the_new_id() -> None:
    memory, models = _filled(7)
    memory.rekey_after_id_change(3, 7, models)
    assert models == {}
    assert all(record == {} for record in _records(memory).values())
    assert memory.answered == set()


def test_forget_drops_every_record_of_one_motor_only() -> None:
    memory, models = _filled(3)
    for record in _records(memory).values():
        record[4] = "kept"
    memory.forget(3, models)
    assert models == {}
    for name, record in _records(memory).items():
        assert record == {4: "kept"}, name
    assert memory.answered == set()


def test_a_factory_reset_forgets_the_settings_and_keeps_model_and_alerts() -> None:
    memory, models = _filled(3)
    memory.forget_settings(3)
    assert models == {3: XM430}
    assert {name: dict(r) for name, r in _records(memory).items() if r} == {
        "alerts": {3: "alerts of 3"}}
    assert memory.answered == set()


def test_the_bus_follows_a_motor_to_its_new_id_with_what_it_learnt() -> None:
    """Through the bus: a level and a torque learnt at ID 1 are the motor's at ID 9."""
    with Bus.open("emu://xm430-w350:1") as bus:
        bus.write(1, "torque_enable", 0)
        bus.write(1, "status_return_level", 1)
        bus.change_id(1, 9)
        assert bus.status_return_level == {9: 1}
        assert bus.read(9, "status_return_level") == 1
        assert 1 not in bus.motors and bus.motors[9].name == "XM430-W350"
