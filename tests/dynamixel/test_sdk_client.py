"""The unmodified ROBOTIS dynamixel-sdk, through its own PortHandler on the pseudo-terminal of
``servolab sim``, drives emulated motors: the emulator is a device any Dynamixel client can use.

The SDK's PortHandler only accepts standard baud rates, so it opens the pty at 57600 bps, which
real RX-28 at their factory 57142 bps also understand (0.8 % apart, within UART tolerance).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import dynamixel_sdk
import pytest

from servolab.apps.sim import HARDWARE_NICENESS
from tests.simproc import sim_process
from tests.waiting import wait_until

#: realtime: the SDK's packet timeout is a deadline on the wall clock (34 ms, and less at
#: 1 Mbps), which the pty server missed beside a test that keeps every core busy (a
#: clean-clone run: COMM_RX_TIMEOUT); so these never run beside one (tests/conftest.py)
pytestmark = [pytest.mark.slow, pytest.mark.realtime]


def _open(device: str, version: float) -> tuple[object, object]:
    port = dynamixel_sdk.PortHandler(device)
    assert port.openPort()
    assert port.setBaudRate(57600)
    return port, dynamixel_sdk.PacketHandler(version)


def _ok(result: tuple) -> tuple:
    """SDK calls return (..., comm_result, error): both must be 0."""
    *values, comm, error = result
    assert comm == dynamixel_sdk.COMM_SUCCESS, comm
    assert error == 0, error
    return tuple(values)


def test_sdk_drives_protocol1_rx28_through_pty(tmp_path: Path) -> None:
    with sim_process("--motors", "rx28:1-3", out_dir=tmp_path) as (device, _):
        port, ph = _open(device, 1.0)
        try:
            for motor_id in (1, 2, 3):
                (model_number,) = _ok(ph.ping(port, motor_id))
                assert model_number == 28  # the SDK reads it from address 0 after PING
                (number,) = _ok(ph.read2ByteTxRx(port, motor_id, 0))
                assert number == 28
            # A missing motor stays silent.
            _, comm, _ = ph.ping(port, 9)
            assert comm == dynamixel_sdk.COMM_RX_TIMEOUT

            _ok(ph.write1ByteTxRx(port, 1, 24, 1))          # torque_enable
            _ok(ph.write2ByteTxRx(port, 1, 32, 300))        # moving_speed: 33 rpm
            (start,) = _ok(ph.read2ByteTxRx(port, 1, 36))   # present_position
            _ok(ph.write2ByteTxRx(port, 1, 30, 800))        # goal_position
            seen = [start]

            def arrived() -> bool:
                (pos,) = _ok(ph.read2ByteTxRx(port, 1, 36))
                seen.append(pos)
                return pos == 800

            assert wait_until(arrived, timeout=10.0), f"motor 1 never reached 800: {seen}"
            # It moved toward the goal, never away from it, and got there.
            assert seen == sorted(seen)
            assert len(set(seen)) > 2  # seen in motion, not teleported

            # SYNC_WRITE (1.0) of torque on and goal_position 300 to all three.
            for addr, size, value in ((24, 1, 1), (30, 2, 300)):
                group = dynamixel_sdk.GroupSyncWrite(port, ph, addr, size)
                for motor_id in (1, 2, 3):
                    assert group.addParam(motor_id, list(value.to_bytes(size, "little")))
                assert group.txPacket() == dynamixel_sdk.COMM_SUCCESS
            for motor_id in (1, 2, 3):
                (goal,) = _ok(ph.read2ByteTxRx(port, motor_id, 30))
                assert goal == 300
            assert wait_until(lambda: all(
                _ok(ph.read2ByteTxRx(port, i, 36))[0] == 300 for i in (1, 2, 3)), timeout=10.0), \
                "motors 1-3 never all reached goal_position 300"
        finally:
            port.closePort()


def test_sdk_drives_protocol2_xm430_through_pty(tmp_path: Path) -> None:
    with sim_process("--motors", "xm430-w210:100-102", "--baud", "57600",
                     out_dir=tmp_path) as (device, _):
        port, ph = _open(device, 2.0)
        ids = (100, 101, 102)
        try:
            for motor_id in ids:
                (model_number,) = _ok(ph.ping(port, motor_id))
                assert model_number == 1030
            # Broadcast ping finds all of them.
            found, comm = ph.broadcastPing(port)
            assert comm == dynamixel_sdk.COMM_SUCCESS
            assert sorted(found) == list(ids)
            assert all(found[i][0] == 1030 for i in ids)

            # The gains and profile a controller tunes, written and read back as the SDK's
            # own read/write examples do (e-Manual, XM430-W210 control table: Velocity I/P
            # Gain 76/78, Position D/I/P Gain 80/82/84, Feedforward 2nd/1st Gain 88/90, all
            # 2 bytes; Profile Acceleration/Velocity 108/112, 4 bytes; factory values first).
            gains = {76: 1920, 78: 100, 80: 0, 82: 0, 84: 800, 88: 0, 90: 0}
            assert {a: _ok(ph.read2ByteTxRx(port, 100, a))[0] for a in gains} == gains
            tuned = {76: 1000, 78: 150, 80: 120, 82: 30, 84: 1200, 88: 40, 90: 500}
            for address, value in tuned.items():
                _ok(ph.write2ByteTxRx(port, 100, address, value))
            for address, value in ((108, 25), (112, 140)):
                _ok(ph.write4ByteTxRx(port, 100, address, value))
            assert {a: _ok(ph.read2ByteTxRx(port, 100, a))[0] for a in tuned} == tuned
            assert [_ok(ph.read4ByteTxRx(port, 100, a))[0] for a in (108, 112)] == [25, 140]
            # a gain beyond its range (0..16 383) is refused with a Data Range error
            comm, error = ph.write2ByteTxRx(port, 100, 84, 16384)
            assert comm == dynamixel_sdk.COMM_SUCCESS and error == 0x04

            for motor_id in ids:
                _ok(ph.write1ByteTxRx(port, motor_id, 11, 1))   # operating_mode: velocity
                _ok(ph.write1ByteTxRx(port, motor_id, 64, 1))   # torque_enable
            goals = {100: 100, 101: -60, 102: 30}               # goal_velocity, 0.229 rpm units
            group = dynamixel_sdk.GroupSyncWrite(port, ph, 104, 4)
            for motor_id, value in goals.items():
                group.addParam(motor_id, list(value.to_bytes(4, "little", signed=True)))
            assert group.txPacket() == dynamixel_sdk.COMM_SUCCESS

            reader = dynamixel_sdk.GroupSyncRead(port, ph, 132, 4)   # present_position
            for motor_id in ids:
                assert reader.addParam(motor_id)

            def positions() -> dict[int, int]:
                assert reader.txRxPacket() == dynamixel_sdk.COMM_SUCCESS
                out = {}
                for motor_id in ids:
                    assert reader.isAvailable(motor_id, 132, 4)
                    raw = reader.getData(motor_id, 132, 4)
                    out[motor_id] = raw - (1 << 32) if raw >= 1 << 31 else raw
                return out

            first = positions()
            assert wait_until(lambda: all(abs(positions()[i] - first[i]) > 50 for i in ids),
                              timeout=10.0), f"wheels did not all turn: {first} -> {positions()}"
            later = positions()
            for motor_id, goal in goals.items():
                # Each wheel turned the way its goal_velocity says.
                assert math.copysign(1, later[motor_id] - first[motor_id]) == math.copysign(
                    1, goal)
            # The faster wheel covered more ground in the same time.
            assert abs(later[100] - first[100]) > abs(later[102] - first[102])
        finally:
            port.closePort()


def test_sim_stops_on_sigint_and_writes_summary(tmp_path: Path) -> None:
    with sim_process("--motors", "rx28:1", out_dir=tmp_path) as (device, proc):
        port, ph = _open(device, 1.0)
        _ok(ph.ping(port, 1))
        port.closePort()
    assert proc.returncode == 0
    summary = (tmp_path / "summary.json").read_text()
    assert '"instructions_received"' in summary
    # it stands in for hardware, which a busy CPU never slows: it runs at raised priority
    # where the OS lets it (root or CAP_SYS_NICE; the summary says), else as it was started
    nice = json.loads(summary)["nice"]
    assert nice == (HARDWARE_NICENESS if _may_raise_priority() else None)


def _may_raise_priority() -> bool:
    """Whether this machine lets a process lower its niceness (asked of a child, so this
    process keeps its own)."""
    child = subprocess.run([sys.executable, "-c", "import os; os.nice(-1)"],
                           capture_output=True, timeout=30)
    return child.returncode == 0


def test_motors_are_silent_at_another_baud_rate(tmp_path: Path) -> None:
    """Like real ones: motors at 1 Mbps do not hear a client at 57600 bps, and do at 1 Mbps."""
    with sim_process("--motors", "ex106+:1-2", "--baud", "1000000",
                     out_dir=tmp_path) as (device, _):
        port, ph = _open(device, 1.0)
        try:
            _, comm, _ = ph.ping(port, 1)
            assert comm == dynamixel_sdk.COMM_RX_TIMEOUT
            assert port.setBaudRate(1_000_000)
            (number,) = _ok(ph.ping(port, 1))
            assert number == 107   # EX-106+
        finally:
            port.closePort()


def test_sdk_goal_write_without_torque_write_moves_a_protocol1_servo(tmp_path: Path) -> None:
    """What seed 001's dynamixel_motor does, done with the SDK: PING, then write a goal position
    and never torque_enable; a Protocol 1.0 servo switches torque on by itself and goes there
    (the seeds' working programs rely on it)."""
    with sim_process("--motors", "rx28:7", out_dir=tmp_path) as (device, _):
        port, ph = _open(device, 1.0)
        try:
            (number,) = _ok(ph.ping(port, 7))
            assert number == 28
            _ok(ph.write2ByteTxRx(port, 7, 30, 700))            # goal_position only
            seen: list[int] = []

            def arrived() -> bool:
                (pos,) = _ok(ph.read2ByteTxRx(port, 7, 36))
                seen.append(pos)
                return pos == 700

            assert wait_until(arrived, timeout=10.0), f"never reached 700: {seen}"
            assert len(set(seen)) > 2 and seen == sorted(seen)   # moved there, monotonically
            (torque,) = _ok(ph.read1ByteTxRx(port, 7, 24))
            assert torque == 1
        finally:
            port.closePort()


def _seed000_tx(m12: int, m34: int) -> bytes:
    """The SYNC_WRITE packet of seed 000's ``tx.m``, byte for byte as its MATLAB builds it
    through the old ROBOTIS dynamixel library: broadcast ID, length 16, instruction 0x83,
    start address 32 (moving speed), 2 bytes per motor, IDs 1-4. Its slips are kept: motor 3
    gets the high byte of the constant 34 and motor 4 both bytes of it, instead of ``m34``."""
    low, high = (lambda v: v & 0xFF), (lambda v: (v >> 8) & 0xFF)
    params = [32, 2, 1, low(m12), high(m12), 2, low(m12), high(m12),
              3, low(m34), high(34), 4, low(34), high(34)]
    body = [0xFE, 16, 0x83, *params]
    return bytes([0xFF, 0xFF, *body, ~sum(body) & 0xFF])


def test_seed000_sync_write_of_moving_speed_turns_ex106_wheels(tmp_path: Path) -> None:
    """Seed 000 drives four EX-106+ in wheel mode at 1 Mbps: ``tx(1023+s, s)`` with s = 30 %
    of 1023 sends motors 1-2 clockwise at 30 % output and 3-4 counter-clockwise, with no
    torque write anywhere; the robot drives until the encoder count of motor 4 (wheel mode:
    0..65535, e-Manual EX-106+ Present Position) has moved the distance, then
    ``dxl_write_word(254, 32, 0)`` stops all. The bytes go to the emulator exactly as the seed
    sends them."""
    with sim_process("--motors", "ex106+:1-4", "--baud", "1000000",
                     out_dir=tmp_path) as (device, _):
        port, ph = _open(device, 1.0)
        try:
            assert port.setBaudRate(1_000_000)
            for motor_id in (1, 2, 3, 4):                   # the robot's wheel-mode setup
                _ok(ph.write2ByteTxRx(port, motor_id, 6, 0))
                _ok(ph.write2ByteTxRx(port, motor_id, 8, 0))
            s = round(30 / 100 * 1023)                      # "Speed Percentage: 30"
            starts = {i: _ok(ph.read2ByteTxRx(port, i, 36))[0] for i in (1, 2, 3, 4)}
            port.writePort(list(_seed000_tx(1023 + s, s)))   # tx(a, b) for a positive distance
            counted = 0
            p = starts[4]

            def odometry_reached() -> bool:
                nonlocal counted, p
                (q,) = _ok(ph.read2ByteTxRx(port, 4, 36))   # the seed's loop, motor m = 4
                counted += q - p if q - p >= 0 else q - p + 65535
                p = q
                return counted > 1000
            assert wait_until(odometry_reached, timeout=20.0), counted
            for motor_id in (1, 2, 3, 4):
                (torque,) = _ok(ph.read1ByteTxRx(port, motor_id, 24))
                assert torque == 1                          # switched on by the speed write
                (speed,) = _ok(ph.read2ByteTxRx(port, motor_id, 38))
                assert bool(speed & 0x400) == (motor_id in (1, 2))   # 1-2 clockwise
            (speed1,) = _ok(ph.read2ByteTxRx(port, 1, 38))
            assert speed1 & 0x3FF == pytest.approx(s, abs=2)  # 30 % output, 0.1 % units
            ph.write2ByteTxOnly(port, 254, 32, 0)           # "transmit 0% speed to all"

            def stopped() -> bool:
                return all(_ok(ph.read2ByteTxRx(port, i, 38))[0] & 0x3FF == 0
                           for i in (1, 2, 3, 4))
            assert wait_until(stopped, timeout=5.0)
        finally:
            port.closePort()


def test_sdk_sees_the_time_based_profile_through_pty(tmp_path: Path, busy_cpu: None) -> None:
    """ROBOTIS's own sequence for a time-based move, as the e-Manual describes it: Drive Mode
    (10) bit 2 with torque off, then Profile Acceleration (108) 900 ms and Profile Velocity
    (112) 3 000 ms, a goal 2 000 ticks away, and Moving Status (123) polled until In-Position.
    The motor reports a trapezoidal profile in progress (0x32), then in position (0x31) on
    its goal, and the move takes the span on the server's real-time clock: never less than
    3 s, long enough for many polls however busy the machine (e-Manual,
    control_table_profile_velocity.md, control_table_moving_status.md). Every core is kept
    busy meanwhile, as on a lab PC."""
    import time

    with sim_process("--motors", "xm430-w350:1", "--baud", "57600",
                     out_dir=tmp_path) as (device, _):
        port, ph = _open(device, 2.0)
        try:
            _ok(ph.write1ByteTxRx(port, 1, 10, 4))            # Drive Mode: time-based
            _ok(ph.write1ByteTxRx(port, 1, 64, 1))            # Torque Enable
            _ok(ph.write4ByteTxRx(port, 1, 108, 900))         # Profile Acceleration: 900 ms
            _ok(ph.write4ByteTxRx(port, 1, 112, 3000))        # Profile Velocity: 3 000 ms
            (start,) = _ok(ph.read4ByteTxRx(port, 1, 132))    # Present Position
            goal = start + 2000
            began = time.monotonic()
            _ok(ph.write4ByteTxRx(port, 1, 116, goal))        # Goal Position
            statuses: list[int] = []
            trajectory: list[int] = []

            def in_position() -> bool:
                (status,) = _ok(ph.read1ByteTxRx(port, 1, 123))
                (desired,) = _ok(ph.read4ByteTxRx(port, 1, 140))   # Position Trajectory
                statuses.append(status)
                trajectory.append(desired)
                return bool(status & 0x01) and not status & 0x02

            assert wait_until(in_position, timeout=10.0), statuses[-5:]
            took = time.monotonic() - began
            (present,) = _ok(ph.read4ByteTxRx(port, 1, 132))
        finally:
            port.closePort()
    assert present == goal and trajectory[-1] == goal
    assert 0x32 in statuses and statuses[-1] == 0x31
    assert set(statuses) <= {0x32, 0x31}    # trapezoidal throughout: ongoing, then in position
    assert trajectory == sorted(trajectory) and len(set(trajectory)) > 5
    assert took >= 3.0 - 0.002      # the span, on the wall clock (a 1 ms step early at most)


def test_sdk_drives_current_mode_and_current_based_position_through_pty(
        tmp_path: Path, busy_cpu: None) -> None:
    """ROBOTIS's current-control sequence (Operating Mode(11) 0, torque on, Goal Current(102))
    and the current-based position one (mode 5, Goal Current as the limit, Goal Position):
    with no load a current turns the horn its way, drawing the current asked; in mode 5 the
    horn goes to its goal. Every core is kept busy meanwhile."""
    with sim_process("--motors", "xm430-w350:1", "--baud", "57600",
                     out_dir=tmp_path) as (device, _):
        port, ph = _open(device, 2.0)
        try:
            _ok(ph.write1ByteTxRx(port, 1, 11, 0))            # Operating Mode: current
            _ok(ph.write1ByteTxRx(port, 1, 64, 1))            # Torque Enable
            _ok(ph.write2ByteTxRx(port, 1, 102, 300))         # Goal Current: 300 x 2.69 mA

            def turning() -> bool:
                (velocity,) = _ok(ph.read4ByteTxRx(port, 1, 128))   # Present Velocity
                return 0 < velocity < 2**31             # counter-clockwise
            assert wait_until(turning, timeout=5.0)
            (current,) = _ok(ph.read2ByteTxRx(port, 1, 126))   # Present Current
            assert current == 300           # the current loop holds what was asked
            _ok(ph.write1ByteTxRx(port, 1, 64, 0))
            _ok(ph.write1ByteTxRx(port, 1, 11, 5))            # current-based position
            _ok(ph.write1ByteTxRx(port, 1, 64, 1))
            _ok(ph.write2ByteTxRx(port, 1, 102, 200))
            (start,) = _ok(ph.read4ByteTxRx(port, 1, 132))
            goal = (start + 1000) % 2**32
            _ok(ph.write4ByteTxRx(port, 1, 116, goal))

            def there() -> bool:
                (present,) = _ok(ph.read4ByteTxRx(port, 1, 132))
                return present == goal
            assert wait_until(there, timeout=10.0)
            (error,) = _ok(ph.read1ByteTxRx(port, 1, 70))      # Hardware Error Status
            assert error == 0
        finally:
            port.closePort()
