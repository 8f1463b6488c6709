"""How fast the Dynamixel driver is: on the wire, and on the host's CPU against the official SDK.

One *cycle* is what every servolab robot does each control step: write all goal positions, then
read all present positions, with the instructions the motors' model has:

- Protocol 1.0, RX-28: one SYNC_WRITE of ``goal_position``, then one READ of
  ``present_position`` per motor (the RX-28 has neither BULK_READ nor SYNC_READ);
- Protocol 2.0, XM430-W210: one SYNC_WRITE of ``goal_position`` and one SYNC_READ of
  ``present_position``.

Three buses are measured:

(a) 20 RX-28 on Protocol 1.0 at 57142 bps, the RX-28 factory rate. This is the Armstrong biped:
    its balance controller needs the state of its 20 motors at 20 Hz, a 50 ms cycle.
(b) the same 20 RX-28 at 1 000 000 bps, the fastest rate they take.
(c) 5 XM430-W210 on Protocol 2.0 at 1 000 000 bps: the fly treadmill, whose write-and-read round
    trip must leave most of a 15 ms camera frame to the tracking code.

**1. Wire time.** An emulated bus (``emu://``) wires the driver to the byte-level emulator
through a ``MemoryPort`` on a simulation's virtual clock: every byte takes 10 bits' time at the
baud rate and every motor answers after its return delay, so the clock's advance over one cycle
is the time the cycle occupies a real wire, the upper bound on the cycle rate whatever the host
does (the *wire limit*). It is given with the return delay at the factory 250 (0.5 ms) and at 0
(the usual tuning), next to the same figure computed from the packet sizes of the protocol
documents (bytes x 10 / baud + one return delay per answer) as a cross-check, and next to the
official ROBOTIS SDK's cycle on the same virtual wire, which shows that both drivers send the
same packets. Not included: the USB adapter's latency (an FTDI latency timer adds up to its
setting, 16 ms by default and 1 ms at best, to every answer) and the host's time.

**2. Host CPU time, the driver alone.** The exact reply bytes of every transaction are recorded
once from the emulator (request bytes -> reply bytes); then servolab's ``Bus`` runs on a
``ReplayPort`` and the SDK (``PacketHandler``, ``GroupSyncWrite``, ``GroupSyncRead``, written as
its examples are) on a ``PortHandler`` subclass, both of which serve those recorded replies, with
no emulator in the loop. A request that was not recorded stops the run, so both drivers must
send byte-identical packets; both must return exactly the values the emulated motors held. Per
call (µs, the best of several interleaved rounds, garbage collector off): READ of one register,
SYNC_WRITE of 20 goals, SYNC_READ of 20 present positions (on the RX-28, which has none: one
READ per motor), the 20-motor full-state sweep (present position through moving: one 11-byte
READ per RX-28, one 25-byte SYNC_READ of 20 XM430, every field decoded), and the cycle of
each bus. 'ours' works in raw register values as the SDK does; 'ours SI' converts to radians
etc. The ratio ours/SDK is measured in the same run, so it carries over to other machines
better than the absolute figures.

**3. Cycle rate against the wire limit.** The cycle can go no faster than its wire time plus
the host's time per cycle (the USB latency aside): achieved rate = 1 / (wire + host), given as
a share of the wire limit 1 / wire, for servolab and for the SDK.

**4. The pty server on a loaded machine.** ``servolab sim --pty`` stands in for a bus for any
program that opens a serial port (the SDK, a CI job). One busy process per core loads the
machine; a client PINGs one emulated XM430-W210 at 57600 bps through the pty, and each reply is
timed against when the modelled wire says it is due (request, return delay and status crossed:
4.67 ms after the write). Three servers take turns, each in a process of its own: a bare Python
responder with the same timing model and nothing else (no emulator, no simulation thread, no
lock: the anchor), ``servolab sim`` at default priority (as a CI runner without the right to
raise it has it) and ``servolab sim`` as it runs itself (nice -10 and a real-time serving
thread where the OS allows). Per server: how late it handed each reply over by its own clock
(p50, p99, max) and how late the client had it (its own wake-up included), with the client's
p99 over the anchor's.

**5. Scan of a mixed bus.** ``servolab scan`` with no options (both protocols at the factory
rates, 57600 and 1 Mbps: a 2.0 broadcast PING per rate, a 1.0 PING per ID spaced by wire time)
of eight motors, X-series, XL-320, RX-28, MX-28 and AX-12A, on one emulated bus that mixes 1.0
and 2.0, on the virtual wire with the adapter's latency timer taken as 16 ms: its wire time,
beside the SDK's own search of the same bus on the same wire in the same run (2.0
``broadcastPing``, then 1.0 ``ping`` of every ID, each allowed the SDK's packet timeout), as a
ratio; and the same scan through a pty at real wire speed (wall clock; not with ``--no-pty``).
``--quick`` scans IDs 0..31 only, the same way, which hold all eight motors.

Goals: host CPU at or below the SDK's for every operation; a cycle rate >= 95 % of the wire
limit on every bus (return delay 0, the hardest case); the pty server hands 99 % of its replies
over within the return delay + 1 ms on the loaded machine; the default scan of the mixed bus
under 10 s. The report says which are met, and why not where not.

Run: ``.venv/bin/python benchmarks/bus_cycle.py [--cycles N] [--rounds R] [--json PATH]
[--pty-pings N] [--pty-blocks B] [--load P] [--no-pty]``.
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import platform
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

from servolab.clock import WallClock
from servolab.dynamixel import Bus, MemoryPort, model
from servolab.dynamixel.models import Model
from servolab.dynamixel.motorspec import MotorEntry, MotorSpec
from servolab.dynamixel.ports import Port
from servolab.dynamixel.units import to_si
from servolab.dynamixel.wire import BITS_PER_BYTE
from servolab.sim import Simulation, emulated_port

try:
    import dynamixel_sdk as sdk
    from dynamixel_sdk.port_handler import LATENCY_TIMER as SDK_LATENCY_TIMER_MS
except ImportError:  # pragma: no cover - the SDK is in the [test] extra
    sdk = None
    SDK_LATENCY_TIMER_MS = 16

FACTORY_RETURN_DELAY = 250  # raw, x 2 us = 0.5 ms
TUNED_RETURN_DELAY = 0
WIRE_CYCLES = 3  # the virtual-clock cycle is deterministic; a few show that it is
AGREEMENT = 0.03  # emulated and analytic wire time must agree within 3 %
WIRE_GOAL = 0.95  # cycle rate / wire limit


class BenchmarkError(RuntimeError):
    """A check failed: the figures would not mean what they claim."""


# -- the three buses -----------------------------------------------------------------------------
@dataclass(frozen=True)
class Config:
    key: str
    model_name: str
    ids: tuple[int, ...]
    baudrate: int
    purpose: str

    @property
    def model(self) -> Model:
        return model(self.model_name)

    @property
    def protocol(self) -> int:
        return self.model.protocol

    @property
    def label(self) -> str:
        return (f"{len(self.ids)} x {self.model.name}, protocol {self.protocol}.0, "
                f"{self.baudrate} bps")

    @property
    def instructions(self) -> str:
        if self.protocol == 1:
            return f"1 SYNC_WRITE + {len(self.ids)} READ"
        return "1 SYNC_WRITE + 1 SYNC_READ"


ARMSTRONG_IDS = (*range(11, 17), *range(21, 27), *range(31, 35), *range(41, 45))
CONFIGS = (
    Config("a", "RX-28", ARMSTRONG_IDS, 57_142, "Armstrong biped: 20 motors' state at 20 Hz"),
    Config("b", "RX-28", ARMSTRONG_IDS, 1_000_000, "Armstrong biped at the RX-28's top rate"),
    Config("c", "XM430-W210", (1, 2, 3, 4, 5), 1_000_000,
           "fly treadmill: round trip within a 15 ms camera frame"),
)
ARMSTRONG_RATE_HZ = 20.0
CAMERA_FRAME_S = 0.015


def make_bus(config: Config, *, virtual: bool, live_physics: bool = False) -> Bus:
    """An emulated bus of ``config``'s motors, every motor declared (no PING in the cycle) and
    each at its own angle, so every motor reports a different position. ``virtual``: on its
    simulation's virtual clock (wire time); else on the wall clock, with the physics frozen
    (nothing steps the simulation) or, ``live_physics``, stepped in real time."""
    m = config.model
    n = len(config.ids)
    motors = tuple(MotorEntry(m, motor_id, position=0.02 * (k - n // 2))
                   for k, motor_id in enumerate(config.ids))
    sim = Simulation()
    port = emulated_port(MotorSpec(m.protocol, config.baudrate, motors), config.baudrate,
                         simulation=sim)
    if not virtual:
        if live_physics:
            sim.start_real_time()
        else:
            port.clock = WallClock()
    bus = Bus(port)
    for motor_id in config.ids:
        bus.declare(motor_id, m)
    hold_still(bus, config.ids)
    return bus


def hold_still(bus: Bus, ids: Sequence[int]) -> None:
    """Keep the motors where they stand whatever goals the cycles write: a 1.0 servo switches
    its torque on when it gets a goal position; with Torque Limit 0 its output is 0 %
    (e-Manual, Torque Limit(34)). (An X-series motor leaves torque off.)"""
    if bus.proto.version == 1:
        for motor_id in ids:
            bus.write(motor_id, "torque_limit", 0, raw=True)


def set_return_delay(bus: Bus, ids: Sequence[int], raw: int) -> None:
    for motor_id in ids:
        bus.write(motor_id, "return_delay_time", raw, raw=True)
    emulator = bus.emulator
    assert emulator is not None
    for motor_id in ids:
        if emulator.motor(motor_id).get_raw("return_delay_time") != raw:
            raise BenchmarkError(f"motor {motor_id}: return_delay_time did not become {raw}")


# -- what the cycle does, for both drivers -------------------------------------------------------
class Workload:
    """The goals each cycle writes (two sets, alternating, so every cycle changes something) and
    the positions it must read back."""

    def __init__(self, config: Config, bus: Bus) -> None:
        self.config = config
        m = config.model
        self.goal_reg = m.register("goal_position")
        self.present_reg = m.register("present_position")
        n = len(config.ids)
        self.goal_sets: tuple[dict[int, int], dict[int, int]] = tuple(  # type: ignore[assignment]
            {i: m.position_center + 10 * (k - n // 2) + alt for k, i in enumerate(config.ids)}
            for alt in (0, 1))
        self.si_goal_sets = tuple({i: to_si(m, self.goal_reg, raw) for i, raw in goals.items()}
                                  for goals in self.goal_sets)
        emulator = bus.emulator
        assert emulator is not None
        for i in config.ids:
            # A 1.0 goal write switches torque on (as on the hardware): with no torque allowed
            # the horns stay where they are, so every cycle must read the same positions.
            motor = emulator.motor(i)
            motor.set_raw("torque_limit" if m.protocol == 1 else "pwm_limit", 0)
        self.expected = {i: emulator.motor(i).get_raw("present_position") for i in config.ids}
        if len(set(self.expected.values())) != n:
            raise BenchmarkError("emulated motors should all stand at different positions")

    def check(self, who: str, bus: Bus, reads: Sequence[Mapping[int, float]], n: int, *,
              si: bool = False) -> None:
        """Every cycle read the motors' true positions; the last goals are in the motors."""
        m = self.config.model
        want = ({i: to_si(m, self.present_reg, v) for i, v in self.expected.items()} if si
                else self.expected)
        for k, got in enumerate(reads):
            if dict(got) != want:
                raise BenchmarkError(f"{who}: cycle {k} read {dict(got)}, the motors hold {want}")
        emulator = bus.emulator
        assert emulator is not None
        last = self.goal_sets[(n - 1) & 1]
        held = {i: emulator.motor(i).get_raw("goal_position") for i in self.config.ids}
        if held != last:
            raise BenchmarkError(f"{who}: motors hold goals {held}, the last cycle wrote {last}")


def ours_cycle(bus: Bus, ids: Sequence[int], *, raw: bool = True
               ) -> Callable[[Mapping[int, float]], Mapping[int, float]]:
    """servolab: ``sync_write`` + ``sync_read`` (one READ per motor on the RX-28)."""
    ids = list(ids)

    def cycle(goals: Mapping[int, float]) -> Mapping[int, float]:
        bus.sync_write("goal_position", goals, raw=raw)
        return bus.sync_read("present_position", ids, raw=raw)

    return cycle


class SdkPort(sdk.PortHandler if sdk else object):  # type: ignore[misc]
    """The ROBOTIS SDK's PortHandler on a servolab MemoryPort instead of a serial device.

    The SDK's packet and timeout logic run unchanged; only the byte I/O and the time source
    go to the MemoryPort and its clock (milliseconds, as the SDK counts). On a virtual clock a
    read waits (virtually) for the bytes it asks for, up to the SDK's packet timeout, so the
    SDK's transactions take the same wire time as ours; on the wall clock nothing waits.
    """

    def __init__(self, port: MemoryPort) -> None:
        super().__init__(f"servolab:{port.name}")
        self.mem = port

    def openPort(self) -> bool:
        return self.setBaudRate(self.mem.baudrate)

    def closePort(self) -> None:
        self.is_open = False

    def setBaudRate(self, baudrate: int) -> bool:
        # Any rate, as the MemoryPort takes it (the serial PortHandler only knows standard
        # rates, so it would refuse the RX-28's 57142).
        self.mem.set_baudrate(baudrate)
        self.baudrate = baudrate
        self.tx_time_per_byte = (1000.0 / baudrate) * BITS_PER_BYTE
        self.is_open = True
        return True

    def clearPort(self) -> None:
        self.mem.reset_input()

    def getBytesAvailable(self) -> int:
        return self.mem.available()

    def readPort(self, length: int) -> bytes:
        # Wait up to just past the SDK's deadline: its isPacketTimeout() wants time to have
        # moved *beyond* it, and a virtual clock stops exactly where it is sent. Reads return
        # as soon as ``length`` bytes are in, so the margin costs no wire time.
        remaining_ms = self.packet_start_time + self.packet_timeout - self.getCurrentTime()
        return self.mem.read(length, max(0.0, remaining_ms) / 1000.0 + 1e-6)

    def writePort(self, packet: Sequence[int]) -> int:
        data = bytes(packet)
        self.mem.write(data)
        return len(data)

    def setPacketTimeout(self, packet_length: int) -> None:
        # The SDK's own formula: wire time of the expected bytes + twice its latency allowance
        # + 2 ms, in ms.
        self.packet_start_time = self.getCurrentTime()
        self.packet_timeout = (self.tx_time_per_byte * packet_length
                               + SDK_LATENCY_TIMER_MS * 2.0 + 2.0)

    def setPacketTimeoutMillis(self, msec: float) -> None:
        self.packet_start_time = self.getCurrentTime()
        self.packet_timeout = msec

    def isPacketTimeout(self) -> bool:
        if self.getCurrentTime() - self.packet_start_time > self.packet_timeout:
            self.packet_timeout = 0
            return True
        return False

    def getCurrentTime(self) -> float:
        return self.mem.clock.now() * 1000.0


def sdk_cycle(config: Config, port: Any, ph: Any = None
              ) -> Callable[[Mapping[int, float]], Mapping[int, float]]:
    """The SDK, written as its examples do: GroupSyncWrite, then read2ByteTxRx per motor
    (1.0) or GroupSyncRead (2.0); every result and error code checked. ``port``: a servolab
    MemoryPort (the SDK goes through :class:`SdkPort`) or an SDK PortHandler."""
    if sdk is None:
        raise BenchmarkError("dynamixel_sdk is not installed: pip install -e '.[test]'")
    if isinstance(port, MemoryPort):
        handler = SdkPort(port)
        if not handler.openPort():
            raise BenchmarkError("SDK adapter did not open")
    else:
        handler = port
    ph = ph or sdk.PacketHandler(float(config.protocol))
    goal = config.model.register("goal_position")
    present = config.model.register("present_position")
    ids = list(config.ids)
    writer = sdk.GroupSyncWrite(handler, ph, goal.address, goal.size)
    ok = sdk.COMM_SUCCESS

    def fail(what: str, result: int, error: int = 0) -> BenchmarkError:
        return BenchmarkError(f"SDK {what}: {ph.getTxRxResult(result)} "
                              f"{ph.getRxPacketError(error)}")

    if config.protocol == 1:
        def cycle(goals: Mapping[int, float]) -> Mapping[int, float]:
            writer.clearParam()
            for motor_id, value in goals.items():
                writer.addParam(motor_id, [sdk.DXL_LOBYTE(value), sdk.DXL_HIBYTE(value)])
            result = writer.txPacket()
            if result != ok:
                raise fail("sync write", result)
            out = {}
            for motor_id in ids:
                value, result, error = ph.read2ByteTxRx(handler, motor_id, present.address)
                if result != ok or error:
                    raise fail(f"read motor {motor_id}", result, error)
                out[motor_id] = value
            return out

        return cycle

    reader = sdk.GroupSyncRead(handler, ph, present.address, present.size)
    for motor_id in ids:
        if not reader.addParam(motor_id):
            raise BenchmarkError(f"SDK GroupSyncRead refused motor {motor_id}")

    def cycle2(goals: Mapping[int, float]) -> Mapping[int, float]:
        writer.clearParam()
        for motor_id, value in goals.items():
            writer.addParam(motor_id, [
                sdk.DXL_LOBYTE(sdk.DXL_LOWORD(value)), sdk.DXL_HIBYTE(sdk.DXL_LOWORD(value)),
                sdk.DXL_LOBYTE(sdk.DXL_HIWORD(value)), sdk.DXL_HIBYTE(sdk.DXL_HIWORD(value))])
        result = writer.txPacket()
        if result != ok:
            raise fail("sync write", result)
        result = reader.txRxPacket()
        if result != ok:
            raise fail("sync read", result)
        out = {}
        for motor_id in ids:
            if not reader.isAvailable(motor_id, present.address, present.size):
                raise BenchmarkError(f"SDK sync read: no data from motor {motor_id}")
            out[motor_id] = reader.getData(motor_id, present.address, present.size)
        return out

    return cycle2


# -- wire time -------------------------------------------------------------------------------------
def analytic(config: Config, return_delay_raw: int) -> dict[str, float]:
    """Bytes and wire time of one cycle from the packet layouts of the protocol documents
    (no byte stuffing: the goal values used contain no FF FF FD)."""
    n = len(config.ids)
    goal = config.model.register("goal_position").size
    present = config.model.register("present_position").size
    if config.protocol == 1:
        # FF FF ID LEN INST params CHECKSUM: 6 bytes + parameters; status: 6 + data
        sync_write = 6 + 2 + n * (1 + goal)       # params: address, length, (id, data) each
        read = 6 + 2                              # params: address, length
        out, inp = sync_write + n * read, n * (6 + present)
    else:
        # FF FF FD 00 ID LEN_L LEN_H INST params CRC_L CRC_H: 10 + parameters;
        # status: FF FF FD 00 ID LEN LEN 55 ERR data CRC CRC: 11 + data
        sync_write = 10 + 4 + n * (1 + goal)      # params: address(2), length(2), (id, data)
        sync_read = 10 + 4 + n                    # params: address(2), length(2), ids
        out, inp = sync_write + sync_read, n * (11 + present)
    seconds = (out + inp) * BITS_PER_BYTE / config.baudrate + n * return_delay_raw * 2e-6
    return {"bytes_out": out, "bytes_in": inp, "seconds": seconds}


def virtual_cycles(bus: Bus, cycle: Callable[[Mapping[int, float]], Mapping[int, float]],
                   work: Workload, who: str, *, si: bool = False) -> tuple[float, int, int]:
    """(seconds, bytes out, bytes in) of one cycle on the virtual wire; checks every cycle is
    the same and reads the right positions."""
    port = bus.port
    assert isinstance(port, MemoryPort)
    clock = port.clock
    times, reads = [], []
    w0, r0 = port.bytes_written, port.bytes_read
    for k in range(WIRE_CYCLES):
        t0 = clock.now()
        reads.append(cycle((work.si_goal_sets if si else work.goal_sets)[k & 1]))
        times.append(clock.now() - t0)
    work.check(who, bus, reads, WIRE_CYCLES, si=si)
    if max(times) - min(times) > 1e-9:
        raise BenchmarkError(f"{who}: wire time differs between cycles: {times}")
    return (statistics.fmean(times), (port.bytes_written - w0) // WIRE_CYCLES,
            (port.bytes_read - r0) // WIRE_CYCLES)


def wire_time(config: Config) -> list[dict[str, Any]]:
    bus = make_bus(config, virtual=True)
    if not bus.port.clock.virtual:
        raise BenchmarkError("the wire-time bus must run on a virtual clock")
    work = Workload(config, bus)
    ours = ours_cycle(bus, config.ids)
    theirs = sdk_cycle(config, bus.port)
    rows = []
    for delay in (FACTORY_RETURN_DELAY, TUNED_RETURN_DELAY):
        set_return_delay(bus, config.ids, delay)
        seconds, out, inp = virtual_cycles(bus, ours, work, "servolab")
        sdk_seconds, sdk_out, sdk_inp = virtual_cycles(bus, theirs, work, "SDK")
        calc = analytic(config, delay)
        diff = round((seconds - calc["seconds"]) / calc["seconds"], 6) + 0.0  # no -0.0
        if abs(diff) > AGREEMENT:
            raise BenchmarkError(f"({config.key}) emulated wire time {seconds * 1e3:.3f} ms and "
                                 f"analytic {calc['seconds'] * 1e3:.3f} ms differ by "
                                 f"{diff:+.1%}")
        if (out, inp) != (calc["bytes_out"], calc["bytes_in"]):
            raise BenchmarkError(f"({config.key}) emulated bytes {out}/{inp}, analytic "
                                 f"{calc['bytes_out']}/{calc['bytes_in']}")
        if (sdk_out, sdk_inp) != (out, inp):
            raise BenchmarkError(f"({config.key}) SDK moved {sdk_out}/{sdk_inp} bytes per cycle, "
                                 f"servolab {out}/{inp}: not the same transactions")
        rows.append({
            "return_delay_raw": delay, "return_delay_ms": delay * 2e-3,
            "bytes_out": out, "bytes_in": inp,
            "emulated_ms": seconds * 1e3, "analytic_ms": calc["seconds"] * 1e3,
            "difference": diff, "sdk_emulated_ms": sdk_seconds * 1e3,
            "max_rate_hz": 1.0 / seconds,
        })
    return rows


# -- host CPU time: the driver alone, on recorded replies ------------------------------------------
class RecordingPort(Port):
    """A port that passes everything to another one and records each request with the reply
    bytes read after it."""

    def __init__(self, inner: MemoryPort) -> None:
        self.inner = inner
        self.name, self.baudrate, self.clock = inner.name, inner.baudrate, inner.clock
        self.protocol, self.latency = inner.protocol, inner.latency
        self.table: dict[bytes, bytes] = {}
        self._request: bytes | None = None

    def write(self, data: bytes) -> None:
        self._request = bytes(data)
        self.table.setdefault(self._request, b"")
        self.inner.write(data)

    def read(self, size: int, timeout: float) -> bytes:
        got = self.inner.read(size, timeout)
        if self._request is not None:
            self.table[self._request] += got
        return got

    def reset_input(self) -> None:
        self.inner.reset_input()


def unrecorded(who: str, data: bytes) -> BenchmarkError:
    return BenchmarkError(f"{who} sent a request that was not recorded: {data.hex(' ')} "
                          "(the two drivers must send the same bytes)")


class ReplayPort(Port):
    """Serves recorded replies: a request's reply bytes are there as soon as it is written."""

    def __init__(self, table: Mapping[bytes, bytes], baudrate: int, protocol: int) -> None:
        self.table = dict(table)
        self.name, self.baudrate, self.protocol = "replay", baudrate, protocol
        self.clock = WallClock()
        self._reply = b""
        self._at = 0

    def write(self, data: bytes) -> None:
        reply = self.table.get(data)
        if reply is None:
            raise unrecorded("servolab", bytes(data))
        self._reply, self._at = reply, 0

    def read(self, size: int, timeout: float) -> bytes:
        at = self._at
        self._at = at + size
        return self._reply[at:at + size]

    def reset_input(self) -> None:
        self._reply, self._at = b"", 0


class SdkReplayPort(sdk.PortHandler if sdk else object):  # type: ignore[misc]
    """The SDK's PortHandler serving the same recorded replies. Only the byte I/O is replaced
    (what pyserial would do); the SDK's timing (its packet timeout on time.time()) is its own."""

    def __init__(self, table: Mapping[bytes, bytes], baudrate: int) -> None:
        super().__init__("replay")
        self.table = dict(table)
        self._reply = b""
        self._at = 0
        self.setBaudRate(baudrate)

    def openPort(self) -> bool:
        return True

    def closePort(self) -> None:
        self.is_open = False

    def setBaudRate(self, baudrate: int) -> bool:
        self.baudrate = baudrate
        self.tx_time_per_byte = (1000.0 / baudrate) * BITS_PER_BYTE
        self.is_open = True
        return True

    def clearPort(self) -> None:
        self._reply, self._at = b"", 0

    def getBytesAvailable(self) -> int:
        return len(self._reply) - self._at

    def readPort(self, length: int) -> bytes:
        at = self._at
        self._at = at + length
        return self._reply[at:at + length]

    def writePort(self, packet: Sequence[int]) -> int:
        data = bytes(packet)
        reply = self.table.get(data)
        if reply is None:
            raise unrecorded("SDK", data)
        self._reply, self._at = reply, 0
        return len(data)


#: The full state of a motor: present position through moving, one contiguous block.
FULL_STATE = {
    1: ["present_position", "present_speed", "present_load", "present_voltage",
        "present_temperature", "registered", "moving"],                 # 36..46, 11 bytes
    2: ["moving", "moving_status", "present_pwm", "present_current", "present_velocity",
        "present_position", "present_input_voltage", "present_temperature"],  # 122..146, 25
}


@dataclass(frozen=True)
class ReplayBus:
    """Motors whose replies the driver-alone measurement records."""

    key: str
    model_name: str
    ids: tuple[int, ...]
    baudrate: int

    @property
    def model(self) -> Model:
        return model(self.model_name)

    @property
    def label(self) -> str:
        return f"{len(self.ids)} x {self.model.name}, protocol {self.model.protocol}.0"


REPLAY_BUSES = (ReplayBus("1.0", "RX-28", ARMSTRONG_IDS, 1_000_000),
                ReplayBus("2.0", "XM430-W210", tuple(range(1, 21)), 1_000_000))


@dataclass
class Op:
    """One operation, as servolab and as the SDK do it, with the values it must return."""

    key: str          # e.g. "2.0 SYNC_READ"
    label: str
    ours: Callable[[Bus, bool, int], Any]                 # (bus, raw, k) -> values
    theirs: Callable[[Any, Any, int], Any]                 # (port, packet handler, k) -> values
    check: Callable[[Any, bool], None] = lambda got, si: None
    #: (port, packet handler) -> None: the SDK's objects made once, as a program would
    prepare: Callable[[Any, Any], None] = lambda port, ph: None


def _sdk_ok(ph: Any, what: str, result: int, error: int = 0) -> None:
    if result != sdk.COMM_SUCCESS or error:
        raise BenchmarkError(f"SDK {what}: {ph.getTxRxResult(result)} "
                             f"{ph.getRxPacketError(error)}")


def _signed(value: int, size: int) -> int:
    bits = 8 * size
    return value - (1 << bits) if value & (1 << (bits - 1)) else value


def make_ops(rb: ReplayBus, held: Mapping[int, Mapping[str, int]],
             goal_sets: Sequence[Mapping[int, int]]) -> list[Op]:
    """The operations on ``rb``'s motors. ``held``: each motor's registers as the emulator
    holds them (what every read must return)."""
    m = rb.model
    v1 = m.protocol == 1
    ids = list(rb.ids)
    first = ids[0]
    goal, present = m.register("goal_position"), m.register("present_position")
    state = FULL_STATE[m.protocol]
    regs = [m.register(n) for n in state]
    start = min(r.address for r in regs)
    length = max(r.address + r.size for r in regs) - start

    def expect(got: Any, want: Any, want_si: Any, what: str, si: bool) -> None:
        if got != (want_si if si else want):
            raise BenchmarkError(f"{rb.key} {what}: read {got}, the motors hold {want}")

    def in_si(name: str, raw: int) -> float:
        return to_si(m, m.register(name), raw)

    positions = {i: held[i]["present_position"] for i in ids}
    positions_si = {i: in_si("present_position", v) for i, v in positions.items()}
    full = {i: {n: held[i][n] for n in state} for i in ids}
    full_si = {i: {n: in_si(n, v) for n, v in values.items()} for i, values in full.items()}

    # -- servolab ----------------------------------------------------------------------------
    def our_read(bus: Bus, raw: bool, k: int) -> Any:
        return bus.read(first, "present_position", raw=raw)

    def our_sync_write(bus: Bus, raw: bool, k: int) -> Any:
        goals = goal_sets[k & 1] if raw else si_goal_sets[k & 1]
        bus.sync_write("goal_position", goals, raw=raw)

    def our_sync_read(bus: Bus, raw: bool, k: int) -> Any:
        return bus.sync_read("present_position", ids, raw=raw)

    def our_sweep(bus: Bus, raw: bool, k: int) -> Any:
        return bus.sync_read(state, ids, raw=raw)

    si_goal_sets = [{i: to_si(m, goal, v) for i, v in g.items()} for g in goal_sets]

    # -- the SDK, as its examples do it ------------------------------------------------------
    if v1:
        def sdk_read(port: Any, ph: Any, k: int) -> Any:
            value, result, error = ph.read2ByteTxRx(port, first, present.address)
            _sdk_ok(ph, "read", result, error)
            return value

        def sdk_sync_read(port: Any, ph: Any, k: int) -> Any:
            out = {}
            for motor_id in ids:
                value, result, error = ph.read2ByteTxRx(port, motor_id, present.address)
                _sdk_ok(ph, f"read motor {motor_id}", result, error)
                out[motor_id] = value
            return out

        def sdk_sweep(port: Any, ph: Any, k: int) -> Any:
            out = {}
            for motor_id in ids:
                data, result, error = ph.readTxRx(port, motor_id, start, length)
                _sdk_ok(ph, f"read motor {motor_id}", result, error)
                out[motor_id] = {
                    "present_position": sdk.DXL_MAKEWORD(data[0], data[1]),
                    "present_speed": sdk.DXL_MAKEWORD(data[2], data[3]),
                    "present_load": sdk.DXL_MAKEWORD(data[4], data[5]),
                    "present_voltage": data[6], "present_temperature": data[7],
                    "registered": data[8], "moving": data[10]}
            return out
    else:
        def sdk_read(port: Any, ph: Any, k: int) -> Any:
            value, result, error = ph.read4ByteTxRx(port, first, present.address)
            _sdk_ok(ph, "read", result, error)
            return _signed(value, 4)

        def sdk_sync_read(port: Any, ph: Any, k: int) -> Any:
            reader = readers[port, present.address]
            result = reader.txRxPacket()
            _sdk_ok(ph, "sync read", result)
            out = {}
            for motor_id in ids:
                if not reader.isAvailable(motor_id, present.address, 4):
                    raise BenchmarkError(f"SDK sync read: no data from motor {motor_id}")
                out[motor_id] = _signed(reader.getData(motor_id, present.address, 4), 4)
            return out

        def sdk_sweep(port: Any, ph: Any, k: int) -> Any:
            reader = readers[port, start]
            result = reader.txRxPacket()
            _sdk_ok(ph, "sync read", result)
            out = {}
            for motor_id in ids:
                if not reader.isAvailable(motor_id, start, length):
                    raise BenchmarkError(f"SDK sync read: no data from motor {motor_id}")
                get = reader.getData
                out[motor_id] = {
                    "moving": get(motor_id, 122, 1), "moving_status": get(motor_id, 123, 1),
                    "present_pwm": _signed(get(motor_id, 124, 2), 2),
                    "present_current": _signed(get(motor_id, 126, 2), 2),
                    "present_velocity": _signed(get(motor_id, 128, 4), 4),
                    "present_position": _signed(get(motor_id, 132, 4), 4),
                    "present_input_voltage": get(motor_id, 144, 2),
                    "present_temperature": get(motor_id, 146, 1)}
            return out

    readers: dict[tuple[Any, int], Any] = {}
    writers: dict[Any, Any] = {}

    def sdk_prepare(port: Any, ph: Any) -> None:
        writers[port] = sdk.GroupSyncWrite(port, ph, goal.address, goal.size)
        if not v1:
            for address, size in ((present.address, present.size), (start, length)):
                reader = sdk.GroupSyncRead(port, ph, address, size)
                for motor_id in ids:
                    reader.addParam(motor_id)
                readers[port, address] = reader

    def sdk_sync_write(port: Any, ph: Any, k: int) -> Any:
        writer = writers[port]
        writer.clearParam()
        for motor_id, value in goal_sets[k & 1].items():
            if v1:
                writer.addParam(motor_id, [sdk.DXL_LOBYTE(value), sdk.DXL_HIBYTE(value)])
            else:
                writer.addParam(motor_id, [
                    sdk.DXL_LOBYTE(sdk.DXL_LOWORD(value)), sdk.DXL_HIBYTE(sdk.DXL_LOWORD(value)),
                    sdk.DXL_LOBYTE(sdk.DXL_HIWORD(value)), sdk.DXL_HIBYTE(sdk.DXL_HIWORD(value))])
        _sdk_ok(ph, "sync write", writer.txPacket())

    sync_read_label = ("present_position x 20: 20 READs (no SYNC_READ)" if v1
                       else "SYNC_READ present_position x 20")
    sweep_label = (f"full-state sweep: 20 READs of {length} bytes" if v1
                   else f"full-state sweep: SYNC_READ {length} bytes x 20")
    return [
        Op(f"{rb.key} READ", "READ present_position, 1 motor", our_read, sdk_read,
           lambda got, si: expect(got, positions[first], positions_si[first], "READ", si),
           sdk_prepare),
        Op(f"{rb.key} SYNC_WRITE", "SYNC_WRITE goal_position x 20", our_sync_write,
           sdk_sync_write, prepare=sdk_prepare),
        Op(f"{rb.key} SYNC_READ", sync_read_label, our_sync_read, sdk_sync_read,
           lambda got, si: expect(got, positions, positions_si, "SYNC_READ", si), sdk_prepare),
        Op(f"{rb.key} sweep", sweep_label, our_sweep, sdk_sweep,
           lambda got, si: expect(got, full, full_si, "sweep", si), sdk_prepare),
    ]


def cycle_op(config: Config, work: Workload) -> Op:
    """The cycle of one of the three buses, on replayed bytes."""
    ids = list(config.ids)
    ours_raw = ours_cycle_k(ids, work, raw=True)
    ours_si = ours_cycle_k(ids, work, raw=False)

    def ours(bus: Bus, raw: bool, k: int) -> Any:
        return (ours_raw if raw else ours_si)(bus, k)

    cycles: dict[Any, Callable[[Mapping[int, float]], Mapping[int, float]]] = {}

    def theirs(port: Any, ph: Any, k: int) -> Any:
        return cycles[port](work.goal_sets[k & 1])

    m = config.model
    expected_si = {i: to_si(m, work.present_reg, v) for i, v in work.expected.items()}

    def check(got: Any, si: bool) -> None:
        if dict(got) != (expected_si if si else work.expected):
            raise BenchmarkError(f"({config.key}) cycle read {dict(got)}, the motors hold "
                                 f"{work.expected}")

    def prepare(port: Any, ph: Any) -> None:
        cycles[port] = sdk_cycle(config, port, ph)

    return Op(f"({config.key}) cycle", f"cycle: {config.instructions}", ours, theirs, check,
              prepare)


def ours_cycle_k(ids: list[int], work: Workload, *, raw: bool
                 ) -> Callable[[Bus, int], Mapping[int, float]]:
    goal_sets = work.goal_sets if raw else work.si_goal_sets

    def cycle(bus: Bus, k: int) -> Mapping[int, float]:
        bus.sync_write("goal_position", goal_sets[k & 1], raw=raw)
        return bus.sync_read("present_position", ids, raw=raw)

    return cycle


def record(bus: Bus, run: Callable[[Bus], Any]) -> dict[bytes, bytes]:
    """Request -> reply bytes of what ``run`` does on ``bus`` (an emulated bus)."""
    inner = bus.port
    assert isinstance(inner, MemoryPort)
    recorder = RecordingPort(inner)
    bus.port = recorder
    try:
        run(bus)
    finally:
        bus.port = inner
    return recorder.table


def time_calls(fn: Callable[[int], Any], n: int) -> float:
    """Seconds per call of ``fn(k)`` over ``n`` calls, garbage collector off."""
    gc.collect()
    gc.disable()
    try:
        t0 = time.perf_counter()
        for k in range(n):
            fn(k)
        t1 = time.perf_counter()
    finally:
        gc.enable()
    return (t1 - t0) / n


def measure(op: Op, table: Mapping[bytes, bytes], models: Mapping[int, Model], baudrate: int,
            protocol: int, calls: int, rounds: int, warmup: int) -> dict[str, Any]:
    """µs per call of ``op`` by servolab (raw and SI) and by the SDK, on replayed bytes."""
    bus = Bus(ReplayPort(table, baudrate, protocol), retries=0)
    for motor_id, m in models.items():
        bus.declare(motor_id, m)
    port = SdkReplayPort(table, baudrate)
    ph = sdk.PacketHandler(float(protocol))
    op.prepare(port, ph)
    sides: dict[str, Callable[[int], Any]] = {
        "ours": lambda k: op.ours(bus, True, k),
        "ours_si": lambda k: op.ours(bus, False, k),
        "sdk": lambda k: op.theirs(port, ph, k),
    }
    for side, fn in sides.items():  # each side returns the right values, and warms up
        for k in range(max(2, warmup)):
            op.check(fn(k), side == "ours_si")
    times: dict[str, list[float]] = {side: [] for side in sides}
    order = list(sides)
    for r in range(rounds):
        for side in order[r % len(order):] + order[:r % len(order)]:  # rotate the order
            times[side].append(time_calls(sides[side], calls) * 1e6)
    out: dict[str, Any] = {"label": op.label}
    for side, values in times.items():
        best = min(values)
        if not (math.isfinite(best) and best > 0):
            raise BenchmarkError(f"{op.key} {side}: {best} µs per call is not a positive number")
        out[side] = {"host_us": best, "host_us_median": statistics.median(values),
                     "host_us_rounds": values}
    out["ratio_ours_sdk"] = out["ours"]["host_us"] / out["sdk"]["host_us"]
    out["ratio_ours_si_sdk"] = out["ours_si"]["host_us"] / out["sdk"]["host_us"]
    if bus.stats.timeouts or bus.stats.corrupt or bus.stats.stale:
        raise BenchmarkError(f"{op.key}: the replayed bus saw timeouts or corrupt replies")
    return out


def held_state(bus: Bus, ids: Sequence[int]) -> dict[int, dict[str, int]]:
    emulator = bus.emulator
    assert emulator is not None
    names = [r.name for r in bus.model_of(ids[0]).registers]
    return {i: {n: emulator.motor(i).get_raw(n) for n in names} for i in ids}


def replay_bus_ops(rb: ReplayBus, calls: int, rounds: int, warmup: int
                   ) -> dict[str, dict[str, Any]]:
    """Record, then measure, READ, SYNC_WRITE, SYNC_READ and the sweep on ``rb``'s motors."""
    config = Config(rb.key, rb.model_name, rb.ids, rb.baudrate, "replay")
    bus = make_bus(config, virtual=False)
    n = len(rb.ids)
    m = rb.model
    goal_sets = [{i: m.position_center + 10 * (k - n // 2) + alt for k, i in enumerate(rb.ids)}
                 for alt in (0, 1)]
    held = held_state(bus, rb.ids)
    ops = make_ops(rb, held, goal_sets)
    results = {}
    for op in ops:
        table = record(bus, lambda b, op=op: [op.ours(b, raw, k) for raw in (True, False)
                                              for k in (0, 1)])
        results[op.key] = measure(op, table, dict(bus.motors), rb.baudrate, m.protocol,
                                  calls, rounds, warmup)
    return results


def replay_cycle(config: Config, calls: int, rounds: int, warmup: int) -> dict[str, Any]:
    """The cycle of one of the three buses, measured as the operations are."""
    bus = make_bus(config, virtual=False)
    work = Workload(config, bus)
    op = cycle_op(config, work)
    table = record(bus, lambda b: [op.ours(b, raw, k) for raw in (True, False)
                                   for k in (0, 1)])
    return measure(op, table, dict(bus.motors), config.baudrate, config.protocol, calls,
                   rounds, warmup)


def rates(config: Config, wire: list[dict[str, Any]], cpu: Mapping[str, Any]
          ) -> list[dict[str, Any]]:
    """Achieved cycle rate over the wire limit, per return delay, for both drivers."""
    rows = []
    for row in wire:
        wire_s = row["emulated_ms"] / 1e3
        entry: dict[str, Any] = {"return_delay_raw": row["return_delay_raw"],
                                 "wire_limit_hz": 1.0 / wire_s}
        for side in ("ours", "sdk"):
            cycle_s = wire_s + cpu[side]["host_us"] / 1e6
            entry[f"{side}_rate_hz"] = 1.0 / cycle_s
            entry[f"{side}_share"] = wire_s / cycle_s
        rows.append(entry)
    return rows


# -- 4. the pty server's reply latency -------------------------------------------------------------
PTY_MOTORS = "xm430-w210:1"   # one XM430-W210, ID 1, factory return delay 250 (0.5 ms)
PTY_BAUD = 57_600
PTY_RETURN_DELAY = FACTORY_RETURN_DELAY * 2e-6
PTY_GOAL_S = 1e-3             # a reply handed over within the return delay + 1 ms
PTY_LOST_S = 0.1              # a ping with no whole reply by then is counted lost

#: The anchor: a responder as bare as Python allows, in a process of its own: no emulator, no
#: simulation thread, no lock. It answers the one PING with the one status on the server's
#: own timing model (the reply handed over once the request, the return delay and the reply
#: have crossed the wire, counted from when the request was read), waiting with
#: time.sleep; it prints how late it handed each reply over when its stdin closes.
BARE_RESPONDER = r'''
import json, os, pty, select, sys, termios, time, tty
master, slave = pty.openpty()
tty.setraw(slave, termios.TCSANOW)
print(os.ttyname(slave), flush=True)
request, reply = bytes.fromhex(sys.argv[1]), bytes.fromhex(sys.argv[2])
wait = (len(request) + len(reply)) * 10 / float(sys.argv[3]) + float(sys.argv[4])
late, buf = [], b""
while True:
    ready = select.select([master, sys.stdin], [], [])[0]
    if sys.stdin in ready:
        break
    arrival = time.monotonic()
    buf += os.read(master, 4096)
    while request in buf:
        buf = buf[buf.index(request) + len(request):]
        due = arrival + wait
        left = due - time.monotonic()
        if left > 0:
            time.sleep(left)
        os.write(master, reply)
        late.append(time.monotonic() - due)
print(json.dumps(late), flush=True)
'''

#: ``servolab sim`` without raising its priority: as a CI runner without the right to do so
#: (not root, no CAP_SYS_NICE) runs it.
SIM_DEFAULT_PRIORITY = r'''
import sys
from servolab.apps.sim import sim
from servolab.dynamixel import motorspec
from servolab.runs import RunFolder
spec = motorspec.load(sys.argv[1], baudrate=int(sys.argv[2]))
sim(spec, run=RunFolder.create("sim", sys.argv[3]), raise_priority=False)
'''


def _ms(seconds: float | None) -> float | None:
    return None if seconds is None or not math.isfinite(seconds) else round(seconds * 1e3, 3)


def _spread(late: Sequence[float]) -> dict[str, Any]:
    """p50, p99 and max (ms) of lateness figures (s; inf for a ping never answered), the
    share beyond the goal and the number lost."""
    ordered = sorted(late)
    if not ordered:
        raise BenchmarkError("no pty figures")
    def q(f: float) -> float:
        return ordered[min(len(ordered) - 1, max(0, math.ceil(f * len(ordered)) - 1))]
    return {"n": len(ordered), "p50_ms": _ms(q(0.5)), "p99_ms": _ms(q(0.99)),
            "max_ms": _ms(max((x for x in ordered if math.isfinite(x)), default=None)),
            "over_goal": sum(x > PTY_GOAL_S for x in ordered) / len(ordered),
            "lost": sum(not math.isfinite(x) for x in ordered)}


class PtyClient:
    """The client: the pty opened raw at the line speed, as a serial client opens it, and a
    PING timed from before its write to after the status's last byte is read."""

    def __init__(self, device: str, baudrate: int) -> None:
        import select
        import termios
        import tty

        self.fd = os.open(device, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self.fd)
        attrs = termios.tcgetattr(self.fd)
        attrs[4] = attrs[5] = getattr(termios, f"B{baudrate}")
        termios.tcsetattr(self.fd, termios.TCSANOW, attrs)
        self.poll = select.poll()
        self.poll.register(self.fd, select.POLLIN)

    def ping(self, request: bytes, size: int) -> float:
        """Seconds from the write to the whole status (inf if it does not come)."""
        import termios

        termios.tcflush(self.fd, termios.TCIFLUSH)
        t0 = time.monotonic()
        os.write(self.fd, request)
        got = b""
        while len(got) < size:
            left = t0 + PTY_LOST_S - time.monotonic()
            if left <= 0 or not self.poll.poll(left * 1e3):
                return math.inf
            got += os.read(self.fd, size - len(got))
        return time.monotonic() - t0

    def close(self) -> None:
        os.close(self.fd)


class PtyServerProcess:
    """A server in a process of its own: the bare responder or ``servolab sim``. Started
    here; :meth:`wait_ready` waits for its device, so that several start side by side."""

    def __init__(self, key: str, argv: list[str], out: Path | None) -> None:
        import subprocess

        self.key, self.out = key, out
        self.device = ""
        self.proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True)

    def wait_ready(self) -> None:
        """Wait for the server to name its pty (it serves from then on)."""
        assert self.proc.stdout is not None
        self.device = self.proc.stdout.readline().strip()
        if not self.device:
            self.proc.kill()
            _, err = self.proc.communicate()
            raise BenchmarkError(f"pty server {self.key} did not start: {err.strip()}")

    def stop(self) -> dict[str, Any]:
        """Stop it; what it says of its own replies: lateness (s) for the bare responder,
        the summary for servolab sim."""
        import signal
        import subprocess

        proc = self.proc
        try:
            if self.out is None:
                out, _ = proc.communicate("", timeout=30)
                lines = out.strip().splitlines()
                return {"lateness_s": json.loads(lines[-1]) if lines else []}
            proc.send_signal(signal.SIGINT)
            proc.communicate(timeout=30)
            summary: dict[str, Any] = json.loads((self.out / "summary.json").read_text())
            return summary
        except (subprocess.TimeoutExpired, ValueError, OSError) as exc:
            proc.kill()
            proc.communicate()
            raise BenchmarkError(f"pty server {self.key} did not stop cleanly: {exc}") from None


def pty_latency(pings: int, blocks: int, load: int, workdir: Path) -> dict[str, Any]:
    """Replies through the pty on a loaded machine: ``load`` busy processes, and ``pings``
    PINGs to each server per block, the servers taking turns block by block (each first in
    turn), so that what the machine does meanwhile falls on all of them alike."""
    import subprocess

    from servolab.dynamixel.packets import Status
    from servolab.dynamixel.protocol2 import PROTOCOL2

    request = PROTOCOL2.encode_instruction(PROTOCOL2.ping(1))
    number = model("XM430-W210").number
    status = PROTOCOL2.encode_status(Status(1, 0, bytes([number & 0xFF, number >> 8, 46])))
    modelled = (len(request) + len(status)) * BITS_PER_BYTE / PTY_BAUD + PTY_RETURN_DELAY
    spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
                for _ in range(load)]
    servers: list[PtyServerProcess] = []
    seen: dict[str, list[float]] = {}
    own: dict[str, dict[str, Any]] = {}
    try:
        servers.append(PtyServerProcess("bare", [
            sys.executable, "-c", BARE_RESPONDER, request.hex(), status.hex(), str(PTY_BAUD),
            str(PTY_RETURN_DELAY)], None))
        servers.append(PtyServerProcess("sim_default", [
            sys.executable, "-c", SIM_DEFAULT_PRIORITY, PTY_MOTORS, str(PTY_BAUD),
            str(workdir / "sim_default")], workdir / "sim_default"))
        servers.append(PtyServerProcess("sim", [
            sys.executable, "-m", "servolab", "sim", "--pty", "--motors", PTY_MOTORS,
            "--baud", str(PTY_BAUD), "--out", str(workdir / "sim")], workdir / "sim"))
        for server in servers:      # started side by side, then each waited for
            server.wait_ready()
        clients = {s.key: PtyClient(s.device, PTY_BAUD) for s in servers}
        # The client at real-time priority where allowed, so that what it sees is the
        # servers' doing rather than its own wake-up on a loaded machine.
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(10))
            client_realtime = True
        except (OSError, AttributeError):
            client_realtime = False
        try:
            for server in servers:     # each answers at all before anything is timed
                if not math.isfinite(clients[server.key].ping(request, len(status))):
                    raise BenchmarkError(f"pty server {server.key} does not answer a PING")
            for block in range(blocks):
                turn = block % len(servers)       # each server first in turn
                for server in servers[turn:] + servers[:turn]:
                    client = clients[server.key]
                    for _ in range(pings):
                        seen.setdefault(server.key, []).append(
                            client.ping(request, len(status)) - modelled)
                        time.sleep(0.002)   # a control loop's pause between transactions
        finally:
            for client in clients.values():
                client.close()
            if client_realtime:
                os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
        for server in servers:
            own[server.key] = server.stop()
    finally:
        for server in servers:
            if server.proc.poll() is None:
                server.proc.kill()
                server.proc.communicate()
        for spinner in spinners:
            spinner.kill()
            spinner.wait()
    out: dict[str, Any] = {"motors": PTY_MOTORS, "baudrate": PTY_BAUD, "pings": pings,
                           "blocks": blocks, "load_processes": load, "cores": os.cpu_count(),
                           "modelled_ms": round(modelled * 1e3, 3), "goal_ms": PTY_GOAL_S * 1e3,
                           "client_realtime": client_realtime, "servers": {}}
    for server in servers:
        figures = own[server.key]
        if server.key == "bare":
            handed = _spread(figures["lateness_s"])
            how = "bare responder (anchor)"
        else:   # (a servolab sim that does not say: None)
            handed = dict(figures.get("reply_lateness") or dict.fromkeys(
                ("replies", "p50_ms", "p99_ms", "max_ms")))
            raised = [f"nice {figures['nice']}"] if figures.get("nice") is not None else []
            raised += ["real-time thread"] if figures.get("realtime") else []
            how = ("servolab sim, default priority" if server.key == "sim_default" else
                   f"servolab sim ({', '.join(raised) or 'priority not raised: not allowed'})")
        out["servers"][server.key] = {"label": how, "handed_over": handed,
                                      "seen": _spread(seen[server.key])}
    bare_p99 = out["servers"]["bare"]["seen"]["p99_ms"]
    for figures in out["servers"].values():
        p99 = figures["seen"]["p99_ms"]
        figures["seen_p99_vs_bare"] = (p99 / bare_p99 if p99 is not None and bare_p99
                                       else None)
    return out


def pty_report(pty: dict[str, Any]) -> list[str]:
    client = "at real-time priority" if pty["client_realtime"] else "at its own priority"
    lines = ["", f"4. The pty server on a loaded machine ({pty['load_processes']} busy processes "
             f"on {pty['cores']} cores): a PING of one XM430-W210 at",
             f"   {pty['baudrate']} bps, whose request, 0.5 ms return delay and status take "
             f"{pty['modelled_ms']:.2f} ms on the wire; {pty['pings']} PINGs",
             f"   x {pty['blocks']} blocks per server, the servers taking turns. 'handed over': "
             "how late after that the server",
             "   wrote the reply (its own figure); 'seen': how late the client had it (its "
             "wake-up included;", f"   the client {client}). Each server runs in a process of "
             "its own; a PING unanswered", f"   after {PTY_LOST_S * 1e3:.0f} ms is lost.", ""]
    lines.append(f"{'':44}{'handed over, ms':>24}{'seen by the client, ms':>34}")
    lines.append(f"{'':44}{'p50':>8}{'p99':>8}{'max':>8}{'p50':>8}{'p99':>8}{'max':>8}"
                 f"{'> 1 ms':>8}{'p99/bare':>10}")

    def f(value: float | None, lost: bool = False) -> str:
        if lost:
            return f"{f'>{PTY_LOST_S * 1e3:.0f}':>8}"
        return f"{value:>8.3f}" if value is not None else f"{'-':>8}"

    for figures in pty["servers"].values():
        h, s = figures["handed_over"], figures["seen"]
        ratio = figures["seen_p99_vs_bare"]
        lost = f" ({s['lost']} lost)" if s["lost"] else ""
        lines.append(f"   {figures['label']:41}{f(h['p50_ms'])}{f(h['p99_ms'])}{f(h['max_ms'])}"
                     f"{f(s['p50_ms'], s['p50_ms'] is None)}{f(s['p99_ms'], s['p99_ms'] is None)}"
                     f"{f(s['max_ms'])}{s['over_goal']:>8.1%}"
                     + (f"{ratio:>10.2f}" if ratio is not None else f"{'-':>10}") + lost)
    return lines


def pty_goals(pty: dict[str, Any]) -> list[str]:
    out = []
    bare = pty["servers"]["bare"]["handed_over"]["p99_ms"]
    for key in ("sim", "sim_default"):
        figures = pty["servers"][key]
        p99 = figures["handed_over"]["p99_ms"]
        if p99 is None:
            out.append(f"  NOT met: {figures['label']} does not say how late it handed its "
                       "replies over (a servolab sim before reply_lateness)")
        elif p99 <= pty["goal_ms"]:
            out.append(f"  met: {figures['label']} hands 99 % of replies over within the "
                       f"return delay + {pty['goal_ms']:g} ms (p99 {p99:.3f} ms late)")
        else:
            out.append(f"  NOT met: {figures['label']} hands 99 % of replies over within "
                       f"{p99} ms of their time, not {pty['goal_ms']:g} ms: the OS wakes an "
                       f"ordinary thread that late on this loaded machine (the bare "
                       f"responder's own p99: {bare} ms)")
    return out

# -- 5. a scan of a mixed bus ----------------------------------------------------------------------
#: The mixed bus a lab has: (model, ID), each at its factory rate (X-series 2.0 at 57600, XL-320
#: 2.0 at 1 Mbps, RX-28 and MX-28 1.0 at 57142, AX-12A 1.0 at 1 Mbps).
SCAN_MOTORS = (("XM430-W210", 1), ("XM430-W210", 2), ("XL430-W250", 3), ("XL-320", 4),
               ("RX-28", 11), ("RX-28", 12), ("MX-28", 30), ("AX-12A", 21))
SCAN_GOAL_S = 10.0
#: ``--quick``: the scan of IDs 0..31 only (every motor of SCAN_MOTORS is among them), the same
#: way (2.0 by broadcast PING, 1.0 by a PING per ID), in a fraction of the default scan's time
SCAN_QUICK_IDS = tuple(range(32))
#: A USB adapter's latency timer as FTDI ships it (16 ms): what the SDK's timeouts always
#: allow (LATENCY_TIMER), and what servolab's allow on a port whose timer it cannot read.
SCAN_LATENCY = SDK_LATENCY_TIMER_MS / 1000.0
SCAN_PTY_SERVER = r'''
import sys, time
from servolab.dynamixel import model
from servolab.dynamixel.emulator import Emulator, VirtualMotor
from servolab.dynamixel.ports import PtyServer
from servolab.sim import Simulation

simulation = Simulation()
emulator = simulation.add_emulator(Emulator(None))
for name, motor_id in MOTORS:
    emulator.add(VirtualMotor(model(name), motor_id))
simulation.start_real_time()
with PtyServer(emulator, 57600, clock=simulation, lock=simulation.lock) as server:
    print(server.device, flush=True)
    sys.stdin.read()      # until the benchmark closes it
    print(server.replies_lost, flush=True)
simulation.stop_real_time()
'''


def scan_bus() -> tuple[Simulation, Any]:
    """The mixed bus of :data:`SCAN_MOTORS`, one emulator for both protocols, on a virtual
    clock."""
    from servolab.dynamixel.emulator import Emulator, VirtualMotor

    simulation = Simulation()
    emulator = simulation.add_emulator(Emulator(None))
    for name, motor_id in SCAN_MOTORS:
        emulator.add(VirtualMotor(model(name), motor_id))
    return simulation, emulator


def _scan_expected() -> set[tuple[int, int]]:
    return {(motor_id, model(name).protocol) for name, motor_id in SCAN_MOTORS}


def scan_ours_virtual(ids: Sequence[int] | None = None) -> dict[str, Any]:
    """``servolab scan`` with no options (both protocols at the factory rates) on the virtual
    wire, the adapter taken to have a 16 ms latency timer: simulated seconds, instructions.
    ``ids`` (``--quick``): those IDs only, Protocol 2.0 still by broadcast PING."""
    from servolab.apps.scan import scan_plan

    simulation, emulator = scan_bus()
    port = MemoryPort(emulator, 57600, clock=simulation, lock=simulation.lock)
    port.latency = SCAN_LATENCY
    bus = Bus(port)
    plan = scan_plan([2, 1], None)
    estimate = sum(bus.scan_time(ids, [rate], protocols=versions, broadcast=True)
                   for rate, versions in plan)
    started, wall = simulation.now(), time.perf_counter()
    found = [r for rate, versions in plan
             for r in bus.scan(ids, [rate], protocols=versions, broadcast=True)]
    took = simulation.now() - started
    got = {(r.id, r.protocol or 0) for r in found}
    if got != _scan_expected():
        raise BenchmarkError(f"servolab's scan found {sorted(got)}, not the bus's motors")
    return {"wire_s": took, "estimate_s": estimate, "host_s": time.perf_counter() - wall,
            "instructions": emulator.instructions_seen, "found": len(found),
            "plan": [[rate, versions] for rate, versions in plan]}


def scan_sdk_virtual(ids: Sequence[int] | None = None) -> dict[str, Any]:
    """The anchor: the ROBOTIS SDK finding the same motors on the same virtual wire, as its
    own examples and the Dynamixel Wizard do: at each factory rate a 2.0 ``broadcastPing``,
    then a 1.0 ``ping`` (PING, and READ of the model number) of every ID 0..253 (or of
    ``ids``), each waiting the SDK's packet timeout (wire time + 2 x LATENCY_TIMER + 2 ms)."""
    simulation, emulator = scan_bus()
    mem = MemoryPort(emulator, 57600, clock=simulation, lock=simulation.lock)
    port = SdkPort(mem)
    port.openPort()
    v1, v2 = sdk.PacketHandler(1.0), sdk.PacketHandler(2.0)
    got: set[tuple[int, int]] = set()
    started, wall = simulation.now(), time.perf_counter()
    for rate in (57_600, 1_000_000):
        port.setBaudRate(rate)
        found, _ = v2.broadcastPing(port)
        got |= {(motor_id, 2) for motor_id in found}
        for motor_id in range(254) if ids is None else ids:
            _, result, _ = v1.ping(port, motor_id)
            if result == sdk.COMM_SUCCESS:
                got.add((motor_id, 1))
    took = simulation.now() - started
    if got != _scan_expected():
        raise BenchmarkError(f"the SDK's scan found {sorted(got)}, not the bus's motors")
    return {"wire_s": took, "host_s": time.perf_counter() - wall,
            "instructions": emulator.instructions_seen, "found": len(got)}


def scan_ours_pty(ids: Sequence[int] | None = None) -> dict[str, Any]:
    """The same scan through a pseudo-terminal at real wire speed: the mixed bus served by a
    process of its own (a real-time simulation behind a ``PtyServer``), scanned from here on
    the wall clock, as ``servolab scan --port PTY`` does."""
    import subprocess

    from servolab.apps.scan import scan_plan

    code = f"MOTORS = {SCAN_MOTORS!r}\n" + SCAN_PTY_SERVER
    with subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE,
                          stdout=subprocess.PIPE, text=True) as server:
        assert server.stdin and server.stdout
        device = server.stdout.readline().strip()
        if not device:
            raise BenchmarkError("the mixed bus's pty server did not start")
        with Bus.open(device, retries=0) as bus:
            plan = scan_plan([2, 1], None)
            estimate = sum(bus.scan_time(ids, [rate], protocols=versions, broadcast=True)
                           for rate, versions in plan)
            started = time.perf_counter()
            found = [r for rate, versions in plan
                     for r in bus.scan(ids, [rate], protocols=versions, broadcast=True)]
            took = time.perf_counter() - started
            latency = bus.port.latency
        server.stdin.close()
        lost = int(server.stdout.readline() or -1)
        server.wait(timeout=10)
    got = {(r.id, r.protocol or 0) for r in found}
    return {"wall_s": took, "estimate_s": estimate, "found": len(got),
            "all_found": got == _scan_expected(), "replies_lost": lost,
            "port_latency_s": latency}


def mixed_scan(pty: bool, ids: Sequence[int] | None = None) -> dict[str, Any]:
    """The scan on the virtual wire, the SDK's beside it, and through a pty (``pty``); of
    every ID, or of ``ids`` only (``--quick``: then not the default scan the goal is for)."""
    ours, theirs = scan_ours_virtual(ids), scan_sdk_virtual(ids)
    figures: dict[str, Any] = {
        "motors": [[name, motor_id] for name, motor_id in SCAN_MOTORS],
        "ids": None if ids is None else [min(ids), max(ids)],
        "adapter_latency_s": SCAN_LATENCY, "goal_s": SCAN_GOAL_S,
        "ours": ours, "sdk": theirs, "ratio_ours_sdk": ours["wire_s"] / theirs["wire_s"],
        "pty": None}
    if pty:
        figures["pty"] = through = scan_ours_pty(ids)
        figures["ratio_pty_virtual"] = through["wall_s"] / ours["wire_s"]
    return figures


def scan_report(scan: dict[str, Any]) -> list[str]:
    ours, theirs, through = scan["ours"], scan["sdk"], scan["pty"]
    how = ("'servolab scan' with no options" if scan["ids"] is None else
           "'servolab scan' as with no options but of IDs {}-{} only (--quick)".format(
               *scan["ids"]))
    lines = ["", f"5. Scan of a mixed bus ({len(scan['motors'])} motors: 2.0 and 1.0, at 57600 "
             f"and 1000000 bps), {how}, on the",
             "   virtual wire (every byte its wire time; the adapter's latency timer taken "
             f"as {scan['adapter_latency_s'] * 1e3:.0f} ms):",
             f"   servolab   {ours['wire_s']:6.2f} s of wire time, {ours['instructions']} "
             f"instructions (estimate said {ours['estimate_s']:.2f} s)",
             f"   SDK        {theirs['wire_s']:6.2f} s of wire time, {theirs['instructions']} "
             "instructions (broadcastPing, then ping of every 1.0 ID)",
             f"   ratio servolab/SDK {scan['ratio_ours_sdk']:.3f}"]
    if through is not None:
        lines += [f"   through a pty at real wire speed: {through['wall_s']:.2f} s wall "
                  f"(x {scan['ratio_pty_virtual']:.2f} the virtual wire's), "
                  f"{through['found']} of {len(scan['motors'])} motors found, "
                  f"{through['replies_lost']} replies lost"]
    return lines


def scan_goals(scan: dict[str, Any]) -> list[str]:
    ours, through, goal = scan["ours"], scan["pty"], scan["goal_s"]
    taken = through["wall_s"] if through is not None else ours["wire_s"]
    where = "through the pty" if through is not None else "on the virtual wire"
    which = ("the default scan" if scan["ids"] is None else
             "the scan of IDs {}-{} (--quick: not the default scan)".format(*scan["ids"]))
    if taken < goal and (through is None or through["all_found"]):
        return [f"  met: {which} of a mixed bus takes {taken:.1f} s {where} "
                f"(goal under {goal:g} s)"]
    why = ("it missed motors: " + str(through["found"]) if through is not None
           and not through["all_found"] else f"{taken:.1f} s")
    return [f"  NOT met: {which} of a mixed bus {where}: {why} (goal all motors "
            f"under {goal:g} s)"]


def with_scan(text: str, scan: dict[str, Any]) -> str:
    """The report with section 5 before its goals, and its goal after theirs."""
    lines = text.split("\n")
    at = lines.index("Goals:") - 1 if "Goals:" in lines else len(lines)
    return "\n".join(lines[:at] + scan_report(scan) + lines[at:] + scan_goals(scan))


# -- report ----------------------------------------------------------------------------------------
def report(results: list[dict[str, Any]], replay: dict[str, dict[str, Any]],
           args: argparse.Namespace, pty: dict[str, Any] | None = None) -> str:
    lines = ["Dynamixel bus cycle: write every goal_position, read every present_position", ""]
    lines.append(f"{'':4}{'bus':44}{'instructions per cycle':24}")
    for res in results:
        c: Config = res["config"]
        lines.append(f"({c.key}) {c.label:44}{c.instructions:24}")

    lines += ["", "1. Wire time per cycle: servolab's wire model (MemoryPort on a virtual clock, "
              "10 bits a byte, each", "   answer after its return delay), the same from the packet "
              "sizes (bytes x 10 / baud + delays),", "   and the official SDK's cycle on the same "
              "virtual wire. No USB latency, no host time.", ""]
    head = (f"{'':4}{'return delay':>15}{'bytes out/in':>14}{'emulated ms':>13}"
            f"{'analytic ms':>13}{'diff':>7}{'SDK ms':>9}{'max rate Hz':>13}")
    lines.append(head)
    for res in results:
        c = res["config"]
        for row in res["wire"]:
            delay = f"{row['return_delay_raw']} ({row['return_delay_ms']:g} ms)"
            lines.append(
                f"({c.key}) {delay:>15}{row['bytes_out']:>8}/{row['bytes_in']:<5}"
                f"{row['emulated_ms']:>13.3f}{row['analytic_ms']:>13.3f}"
                f"{row['difference']:>+7.1%}{row['sdk_emulated_ms']:>9.3f}"
                f"{row['max_rate_hz']:>13.1f}")

    lines += ["", f"2. Host CPU per call, µs, the driver alone: recorded replies served by a "
              f"replay port (best of {args.rounds} interleaved", f"   round(s) x {args.cycles} "
              f"calls after {args.warmup} warm-up, perf_counter, gc off). Both drivers send the "
              "same bytes and", "   read back the values the motors held. 'ours' in raw values "
              "like the SDK, 'ours SI' in radians etc.", ""]
    head = f"{'':5}{'operation':48}{'ours':>8}{'ours SI':>9}{'SDK':>8}{'ours/SDK':>10}"
    lines.append(head)
    rows = [(key, r) for key, r in replay.items()]
    rows += [(f"({res['config'].key}) cycle", res["cpu"]) for res in results]
    for key, r in rows:
        name = key.split(" ")[0]
        lines.append(f"{name:5}{r['label']:48}{r['ours']['host_us']:>8.1f}"
                     f"{r['ours_si']['host_us']:>9.1f}{r['sdk']['host_us']:>8.1f}"
                     f"{r['ratio_ours_sdk']:>10.2f}")
    lines.append("   (1.0: 20 x RX-28 IDs 11-44; 2.0: 20 x XM430-W210 IDs 1-20; cycles: the "
                 "buses above)")

    lines += [""]
    for res in results:
        c, cpu = res["config"], res["cpu"]
        lines.append(f"({c.key}) {c.label}: ratio ours/sdk = {cpu['ratio_ours_sdk']:.2f}")

    lines += ["", "3. Cycle rate against the wire limit: 1 / (wire time + host CPU per cycle), "
              "as a share of 1 / wire time", "   (no USB latency: real adapters add their "
              "latency timer, >= 1 ms, to every answer).", ""]
    lines.append(f"{'':4}{'return delay':>13}{'wire limit Hz':>15}{'ours Hz':>10}{'ours %':>8}"
                 f"{'SDK Hz':>10}{'SDK %':>8}")
    for res in results:
        c = res["config"]
        for row in res["rates"]:
            lines.append(f"({c.key}) {row['return_delay_raw']:>13}{row['wire_limit_hz']:>15.1f}"
                         f"{row['ours_rate_hz']:>10.1f}{row['ours_share']:>8.1%}"
                         f"{row['sdk_rate_hz']:>10.1f}{row['sdk_share']:>8.1%}")

    lines += ["", "What it means:"]
    for res in results:
        c, wire, cpu = res["config"], res["wire"], res["cpu"]
        best_ms = wire[-1]["emulated_ms"] + cpu["ours"]["host_us"] / 1e3
        if c.key in ("a", "b"):
            verdict = "reachable" if 1e3 / best_ms >= ARMSTRONG_RATE_HZ else "NOT reachable"
            lines.append(f"({c.key}) Armstrong needs {ARMSTRONG_RATE_HZ:.0f} Hz (a "
                         f"{1e3 / ARMSTRONG_RATE_HZ:.0f} ms cycle): {1e3 / best_ms:.1f} Hz with "
                         f"return delay 0 + CPU, {verdict} at {c.baudrate} bps (+ 20 x the USB "
                         "latency on a real adapter)")
        else:
            frame_ms = CAMERA_FRAME_S * 1e3
            lines.append(f"({c.key}) the fly treadmill's round trip takes "
                         f"{best_ms / frame_ms:.0%} of a {frame_ms:.0f} ms camera frame with "
                         "return delay 0 + CPU (+ 2 x the USB latency on a real adapter)")

    if pty is not None:
        lines += pty_report(pty)

    lines += ["", "Goals:"]
    lines += goals(results, replay, pty)
    return "\n".join(lines)


def goals(results: list[dict[str, Any]], replay: dict[str, dict[str, Any]],
          pty: dict[str, Any] | None = None) -> list[str]:
    """Which goals are met, and why not where not."""
    out = pty_goals(pty) if pty is not None else []
    slower = [(key, r) for key, r in replay.items() if r["ratio_ours_sdk"] > 1.0]
    slower += [(f"({res['config'].key}) cycle", res["cpu"]) for res in results
               if res["cpu"]["ratio_ours_sdk"] > 1.0]
    if not slower:
        out.append("  met: host CPU at or below the SDK's for every operation")
    for key, r in slower:
        out.append(f"  NOT met: {key} ({r['label']}) takes {r['ratio_ours_sdk']:.2f} x the "
                   f"SDK's CPU ({r['ours']['host_us']:.1f} vs {r['sdk']['host_us']:.1f} µs): "
                   "the extra checks per call (plan still valid, status return level, "
                   "late-status window, alerts) cost more than this operation's work")
    for res in results:
        c = res["config"]
        row = res["rates"][-1]  # return delay 0: the wire limit is highest
        share = row["ours_share"]
        if share >= WIRE_GOAL:
            out.append(f"  met: ({c.key}) {share:.1%} of the wire limit at return delay 0 "
                       f"(goal {WIRE_GOAL:.0%})")
        else:
            host = res["cpu"]["ours"]["host_us"]
            wire_us = 1e6 / row["wire_limit_hz"]
            sdk_share = row["sdk_share"]
            out.append(f"  NOT met: ({c.key}) {share:.1%} of the wire limit at return delay 0 "
                       f"(goal {WIRE_GOAL:.0%}; the SDK {sdk_share:.1%}): the wire takes only "
                       f"{wire_us:.0f} µs a cycle, so {host:.0f} µs of Python per cycle is more "
                       f"than {(1 / WIRE_GOAL - 1):.1%} of it; {c.instructions} per cycle, each "
                       "a Python call into the port")
    return out


def to_json(results: list[dict[str, Any]], replay: dict[str, dict[str, Any]],
            args: argparse.Namespace, pty: dict[str, Any] | None = None) -> dict[str, Any]:
    return {
        "benchmark": "bus_cycle",
        "python": platform.python_version(),
        "platform": platform.platform(),
        "dynamixel_sdk": metadata.version("dynamixel-sdk") if sdk else None,
        "cycles": args.cycles, "rounds": args.rounds, "warmup": args.warmup,
        "configs": {
            res["config"].key: {
                "label": res["config"].label, "model": res["config"].model.name,
                "protocol": res["config"].protocol, "baudrate": res["config"].baudrate,
                "ids": list(res["config"].ids), "instructions": res["config"].instructions,
                "purpose": res["config"].purpose, "wire": res["wire"], "cpu": res["cpu"],
                "rates": res["rates"],
            } for res in results
        },
        "replay": replay,
        "pty": pty,
        "goals": goals(results, replay, pty),
    }


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cycles", type=int, default=500,
                        help="calls per timed run of each operation (default 500)")
    parser.add_argument("--rounds", type=int, default=7,
                        help="timed runs per driver, interleaved; the best counts (default 7)")
    parser.add_argument("--warmup", type=int, default=50,
                        help="untimed calls per driver first (default 50)")
    parser.add_argument("--pty-pings", type=int, default=200, metavar="N",
                        help="PINGs per server and block through the pty (default 200)")
    parser.add_argument("--pty-blocks", type=int, default=3, metavar="B",
                        help="blocks of PINGs per server, the servers taking turns (default 3)")
    parser.add_argument("--load", type=int, default=os.cpu_count() or 1, metavar="P",
                        help="busy processes that load the machine while the pty is timed "
                        "(default: one per core)")
    parser.add_argument("--no-pty", action="store_true", help="leave the pty out")
    parser.add_argument("--no-scan", action="store_true", help="leave the mixed-bus scan out")
    parser.add_argument("--quick", action="store_true",
                        help="3 calls, 1 round, 1 warm-up, 20 PINGs, the scan of IDs 0-31: a "
                        "smoke test, not a measurement")
    parser.add_argument("--json", type=Path, metavar="PATH", help="also write the figures here")
    args = parser.parse_args(argv)
    if args.quick:
        args.cycles, args.rounds, args.warmup = 3, 1, 1
        args.pty_pings, args.pty_blocks = 20, 1
    if args.cycles < 1 or args.rounds < 1 or args.warmup < 0:
        parser.error("--cycles and --rounds must be at least 1, --warmup at least 0")
    if args.pty_pings < 1 or args.pty_blocks < 1 or args.load < 0:
        parser.error("--pty-pings and --pty-blocks must be at least 1, --load at least 0")
    return args


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    if sdk is None:
        print("dynamixel_sdk is not installed: pip install -e '.[test]'", file=sys.stderr)
        return 2
    replay: dict[str, dict[str, Any]] = {}
    for rb in REPLAY_BUSES:
        replay.update(replay_bus_ops(rb, args.cycles, args.rounds, args.warmup))
    results = []
    for config in CONFIGS:
        wire = wire_time(config)
        cpu = replay_cycle(config, args.cycles, args.rounds, args.warmup)
        results.append({"config": config, "wire": wire, "cpu": cpu,
                        "rates": rates(config, wire, cpu)})
    pty = None
    if not args.no_pty:
        with tempfile.TemporaryDirectory(prefix="bus_cycle_pty_") as workdir:
            pty = pty_latency(args.pty_pings, args.pty_blocks, args.load, Path(workdir))
    scan = None if args.no_scan else mixed_scan(
        pty=not args.no_pty, ids=SCAN_QUICK_IDS if args.quick else None)
    text = report(results, replay, args, pty)
    print(text if scan is None else with_scan(text, scan))
    if args.json:
        figures = to_json(results, replay, args, pty)
        if scan is not None:
            figures["scan"] = scan
            figures["goals"] = [*figures["goals"], *scan_goals(scan)]
        args.json.write_text(json.dumps(figures, indent=2) + "\n")
        print(f"\nfigures written to {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
