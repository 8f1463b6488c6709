"""Every shipped model, emulated behind ``servolab sim --pty`` and driven by the unmodified
ROBOTIS ``dynamixel_sdk``: scanned (the model number PING reports), its whole control table read
and checked by name against its model file, registers written by name and read back, a value
outside a register's range refused with the protocol's error, and a goal reached.

One ``servolab sim --pty`` per protocol, all its models on it at IDs 1, 2, 3, ... and 1 Mbps
(every shipped model runs at 1 Mbps), so the whole contract costs two process starts. The SDK
knows addresses, not names: each name is looked up in the model, which is the point: the SDK
finds each register where the model file says it is.

The pty server may answer a transaction late on a loaded machine (issue 29: 1-3 % of pings);
such a transaction is retried, at most twice, and the retries are counted and bounded, so that
a late answer does not fail a test about model data while a wrong one still does.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import dynamixel_sdk as sdk
import pytest

from servolab.dynamixel import MODELS, model
from servolab.dynamixel.models import Model, Register
from tests.simproc import sim_process
from tests.waiting import wait_until

pytestmark = pytest.mark.slow

BAUD = 1_000_000
#: models the emulator cannot run (none: the XL-320's AX-style table on Protocol 2.0 is)
NOT_EMULATED: set[str] = set()
#: Registers the firmware itself sets as it runs, or the test set: not compared to defaults.
LIVE = ("present_", "realtime_tick", "moving", "moving_status", "velocity_trajectory",
        "position_trajectory", "hardware_error_status", "sensed_current", "backup_ready")
TRANSIENT = (sdk.COMM_RX_TIMEOUT, sdk.COMM_RX_CORRUPT)


def bus_of(protocol: int) -> list[tuple[int, Model]]:
    """The emulated bus of a protocol: (ID, model), IDs from 1 in name order."""
    names = sorted(n for n, m in MODELS.items() if m.protocol == protocol
                   and n not in NOT_EMULATED)
    return [(i, model(n)) for i, n in enumerate(names, start=1)]


def short_spec(bus: list[tuple[int, Model]]) -> str:
    """The command-line spec of a bus, spelling each model as its file is named (``mx-28-2``
    for MX-28(2.0)): the spellings a user types reach the same models."""
    return ";".join(f"{Path(m.path).stem}:{i}" for i, m in bus)


class Client:
    """The SDK on the pty, at 1 Mbps; every call checked, transient failures retried."""

    def __init__(self, device: str, protocol: int) -> None:
        self.port = sdk.PortHandler(device)
        assert self.port.openPort()
        assert self.port.setBaudRate(BAUD)
        self.ph = sdk.PacketHandler(float(protocol))
        self.calls = self.retries = 0

    def call(self, fn: Callable[..., Any], *args: Any, error: int = 0) -> tuple[Any, ...]:
        """``fn(port, *args)``, which ends in (comm result, error): comm must succeed and the
        error byte be ``error``."""
        self.calls += 1
        for attempt in range(3):
            *values, comm, got = fn(self.port, *args)
            if comm in TRANSIENT and attempt < 2:
                self.retries += 1
                continue
            assert comm == sdk.COMM_SUCCESS, (fn.__name__, args, comm)
            assert got == error, (fn.__name__, args, got)
            return tuple(values)
        raise AssertionError("unreachable")

    def read(self, motor_id: int, reg: Register) -> int:
        (data,) = self.call(self.ph.readTxRx, motor_id, reg.address, reg.size)
        return reg.decode(bytes(data))

    def write(self, motor_id: int, reg: Register, raw: int, *, error: int = 0) -> None:
        self.call(self.ph.writeTxRx, motor_id, reg.address, reg.size, list(reg.encode(raw)),
                  error=error)

    def close(self) -> None:
        self.port.closePort()
        # A late answer now and then, never a habit: a systematic failure is no retry.
        assert self.retries <= max(3, self.calls // 10), (self.retries, self.calls)


def check_bus(client: Client, bus: list[tuple[int, Model]], protocol: int) -> None:
    ph = client.ph
    # -- scan: every model answers PING at its ID with the number its file gives -----------
    if protocol == 2:
        found, comm = ph.broadcastPing(client.port)
        assert comm == sdk.COMM_SUCCESS
        assert {i: found[i][0] for i in found} == {i: m.number for i, m in bus}
        assert {i: found[i][1] for i in found} == {i: m.firmware for i, m in bus}
    for motor_id, m in bus:
        assert client.call(ph.ping, motor_id) == (m.number,), m.name
    *_, comm, _ = ph.ping(client.port, len(bus) + 1)
    assert comm == sdk.COMM_RX_TIMEOUT                     # nobody at the next ID

    for motor_id, m in bus:
        # -- the whole table in one READ, every register decoded by name ---------------------
        (block,) = client.call(ph.readTxRx, motor_id, 0, m.table_size)
        table = bytes(block)

        def value(name: str, m: Model = m, table: bytes = table) -> int:
            reg = m.register(name)
            return reg.decode(table[reg.address:reg.address + reg.size])

        expected = {r.name: r.default for r in m.registers if r.default is not None}
        expected |= {"id": motor_id, "baud_rate": m.baud_register_for(BAUD),
                     "firmware_version": m.firmware}
        if m.has("max_torque"):
            expected["torque_limit"] = expected["max_torque"]   # copied at power-up
        got = {name: value(name) for name in expected if not name.startswith(LIVE)}
        assert got == {n: v for n, v in expected.items() if n in got}, m.name
        voltage = "present_voltage" if m.has("present_voltage") else "present_input_voltage"
        assert value(voltage) == round(m.nominal_voltage * 10), m.name   # 0.1 V, at rest
        start = value("present_position")
        assert value("goal_position") == start, m.name      # a goal where it stands

        # -- writes by name, read back -------------------------------------------------------
        client.write(motor_id, m.register("led"), 1)
        assert client.read(motor_id, m.register("led")) == 1, m.name
        speed = m.register("moving_speed" if m.has("moving_speed") else "profile_velocity")
        client.write(motor_id, speed, 300)
        assert client.read(motor_id, speed) == 300, m.name
        # -- a value outside a register's range: the protocol's range error, nothing written
        # (on 1.0 the moving_speed write switched torque on already)
        torque = m.register("torque_enable")
        before = client.read(motor_id, torque)
        client.write(motor_id, torque, torque.raw_max + 1, error=0x08 if protocol == 1 else 0x04)
        assert client.read(motor_id, torque) == before, m.name
        client.write(motor_id, torque, 1)

    # -- a goal of 100 ticks, reached by every motor at its own model's speed -----------------
    goals = {}
    for motor_id, m in bus:
        reg = m.register("goal_position")
        goals[motor_id] = client.read(motor_id, m.register("present_position")) + 100
        client.write(motor_id, reg, goals[motor_id])
    waiting = dict(bus)

    def all_there() -> bool:
        for motor_id, m in list(waiting.items()):
            if abs(client.read(motor_id, m.register("present_position"))
                   - goals[motor_id]) <= 1:
                del waiting[motor_id]
        return not waiting

    wait_until(all_there, timeout=10.0)
    assert not waiting, f"never reached their goals: {[m.name for m in waiting.values()]}"


@pytest.mark.parametrize("protocol", [1, 2])
def test_every_model_through_the_sdk(tmp_path: Path, protocol: int) -> None:
    bus = bus_of(protocol)
    assert len(bus) == {1: 11, 2: 12}[protocol]  # 1.0: AX, RX, EX, MX; 2.0: MX(2.0), XL-320, X
    with sim_process("--motors", short_spec(bus), "--baud", str(BAUD),
                     out_dir=tmp_path) as (device, _):
        client = Client(device, protocol)
        try:
            check_bus(client, bus, protocol)
        finally:
            client.close()


def test_every_shipped_model_is_on_a_bus() -> None:
    """Each shipped model file is a model on one of the two buses: none skipped, none left
    out of emulation."""
    from importlib.resources import files

    shipped = [f for f in files("servolab.dynamixel").joinpath("model_tables").iterdir()
               if f.name.endswith(".yaml")]
    on_a_bus = [m.name for p in (1, 2) for _, m in bus_of(p)]
    assert not NOT_EMULATED
    assert len(on_a_bus) == len(set(on_a_bus)) == len(shipped) == 23
