"""ID and baud-rate changes over a real serial line: a pseudo-terminal served by the emulator
(:class:`~servolab.dynamixel.ports.PtyServer`, in this process), driven by the unmodified
ROBOTIS dynamixel-sdk and by servolab's :class:`Bus` through its :class:`SerialPort`.

The SDK is the independent witness: it sees the motor where servolab says it put it. It also
shows why servolab takes the WRITE's status from the new ID: the SDK's txRxPacket keeps only a
status from the ID it wrote to, so its own write of the ID reports COMM_RX_TIMEOUT although the
motor took the new ID (the "is it powered?" the issue reports of servolab before).
"""

from __future__ import annotations

from collections.abc import Iterator

import dynamixel_sdk
import pytest

from servolab.dynamixel import Bus, ConfigError, model
from servolab.dynamixel.emulator import Emulator, VirtualMotor
from servolab.dynamixel.ports import PtyServer

#: X-series control table (e-Manual, XM430-W350): ID 7, Baud Rate 8, Torque Enable 64
ID, BAUD_RATE = 7, 8

#: realtime: the SDK's packet timeout is a deadline on the wall clock, which the pty server
#: may miss beside a test that keeps every core busy (tests/dynamixel/test_sdk_client.py)
pytestmark = pytest.mark.realtime


@pytest.fixture
def pty() -> Iterator[tuple[PtyServer, Emulator]]:
    """Two XM430-W350 (IDs 1 and 2) at 57600 bps on a pty."""
    emulator = Emulator(2, [VirtualMotor(model("xm430-w350"), i, baudrate=57600)
                            for i in (1, 2)])
    with PtyServer(emulator, 57600) as server:
        yield server, emulator


class Sdk:
    """The ROBOTIS SDK's PortHandler and PacketHandler on ``device``."""

    def __init__(self, device: str, baud: int) -> None:
        self.port = dynamixel_sdk.PortHandler(device)
        assert self.port.openPort()
        assert self.port.setBaudRate(baud)
        self.ph = dynamixel_sdk.PacketHandler(2.0)

    def answers(self, motor_id: int) -> bool:
        _, comm, _ = self.ph.ping(self.port, motor_id)
        return comm == dynamixel_sdk.COMM_SUCCESS

    def close(self) -> None:
        self.port.closePort()


def test_sdk_id_write_times_out_though_the_motor_moved(pty: tuple[PtyServer, Emulator]) -> None:
    server, emulator = pty
    sdk = Sdk(server.device, 57600)
    try:
        comm, _ = sdk.ph.write1ByteTxRx(sdk.port, 1, ID, 5)
        assert comm == dynamixel_sdk.COMM_RX_TIMEOUT   # the status came from ID 5
        assert sdk.answers(5) and not sdk.answers(1)
    finally:
        sdk.close()
    assert sorted(m.id for m in emulator.motors) == [2, 5]


def test_bus_changes_id_and_baud_over_a_serial_line_and_the_sdk_sees_it(
        pty: tuple[PtyServer, Emulator]) -> None:
    """servolab refuses ID 2 (used), gives motor 1 the ID 7, sets it to 1 Mbps and follows
    it; then the SDK finds it at ID 7 and 1 Mbps only, and motor 2 still at 57600."""
    server, emulator = pty
    with Bus.open(server.device, protocol=2, baudrate=57600) as bus:
        with pytest.raises(ConfigError, match="ID 2 is taken"):
            bus.change_id(1, 2)
        assert emulator.motor(1).get_raw("id") == 1
        assert bus.change_id(1, 7).id == 7
        assert bus.change_baud(7, 1_000_000).baudrate == 1_000_000
        assert bus.baudrate == 1_000_000
        assert bus.read(7, "baud_rate", raw=True) == 3     # e-Manual: 3 = 1 Mbps
    sdk = Sdk(server.device, 1_000_000)
    try:
        assert sdk.answers(7) and not sdk.answers(1) and not sdk.answers(2)
        value, comm, error = sdk.ph.read1ByteTxRx(sdk.port, 7, BAUD_RATE)
        assert (value, comm, error) == (3, dynamixel_sdk.COMM_SUCCESS, 0)
        assert sdk.port.setBaudRate(57600)
        assert sdk.answers(2) and not sdk.answers(7)
    finally:
        sdk.close()


def test_sdk_baud_write_is_answered_at_the_old_rate(pty: tuple[PtyServer, Emulator]) -> None:
    """What servolab's change_baud counts on: the status of the WRITE comes at the old rate,
    and the motor answers at the new one only, as the SDK sees it."""
    server, _ = pty
    sdk = Sdk(server.device, 57600)
    try:
        comm, error = sdk.ph.write1ByteTxRx(sdk.port, 2, BAUD_RATE, 3)
        assert (comm, error) == (dynamixel_sdk.COMM_SUCCESS, 0)
        assert not sdk.answers(2)
        assert sdk.port.setBaudRate(1_000_000)
        assert sdk.answers(2)
    finally:
        sdk.close()
