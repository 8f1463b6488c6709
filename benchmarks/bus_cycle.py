"""How long one Dynamixel bus cycle takes: on the wire, and on the host's CPU.

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

**Wire time.** An emulated bus (``emu://``) wires the driver to the byte-level emulator through
a ``MemoryPort`` on a simulation's virtual clock: every byte takes 10 bits' time at the baud
rate and every motor answers after its return delay, so the clock's advance over one cycle is
the time the cycle occupies a real wire, the upper bound on the cycle rate whatever the host
does. It is given with the return delay at the factory 250 (0.5 ms) and at 0 (the usual tuning),
next to the same figure computed from the packet sizes of the protocol documents (bytes x 10 /
baud + one return delay per answer) as a cross-check, and next to the official ROBOTIS SDK's
cycle on the same virtual wire, which shows that both drivers send the same packets. Not
included: the USB adapter's latency (an FTDI latency timer adds up to its setting, 16 ms by
default and 1 ms at best, to every answer, i.e. to each of the 20 READs of (a) and (b)) and the
host's time.

**Host CPU time.** The same transactions are then run by servolab's ``Bus`` and by the SDK
(``PacketHandler`` + ``GroupSyncWrite`` / ``GroupSyncRead``, through a small ``PortHandler``
subclass that reads and writes a servolab ``MemoryPort``) against the same emulator in this
process, on a wall-clock port, where answers are there at once and nothing waits. The
emulator's own time (its ``receive``, wrapped with a ``time.perf_counter``
accumulators) is subtracted from both sides, with the accumulator's own per-call overhead, so
what remains is the driver's work (plus the in-memory port's byte handling, the same bytes on
both sides). The emulated motors' physics is frozen during this measurement (nothing steps their
simulation; their torque limit is 0, so nothing would move anyway); ``--live-physics`` runs the
simulation in real time on its own thread, which only adds noise. Both sides must read back
exactly the positions the emulated motors hold and leave the goals they wrote in the motors'
control tables, and must put the same number of bytes and instructions on the wire; the run
stops otherwise. The ratio ours/SDK is measured in the same run, so it carries over to other
machines better than the absolute figures.

Run: ``.venv/bin/python benchmarks/bus_cycle.py [--cycles N] [--rounds R] [--json PATH]``.
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import platform
import statistics
import sys
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
    return bus


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
        now = self.mem.clock.now()
        return sum(1 for ready, _ in self.mem._rx if ready <= now)

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


def sdk_cycle(config: Config, port: MemoryPort
              ) -> Callable[[Mapping[int, float]], Mapping[int, float]]:
    """The SDK, written as its examples do: GroupSyncWrite, then read2ByteTxRx per motor
    (1.0) or GroupSyncRead (2.0); every result and error code checked."""
    if sdk is None:
        raise BenchmarkError("dynamixel_sdk is not installed: pip install -e '.[test]'")
    handler = SdkPort(port)
    if not handler.openPort():
        raise BenchmarkError("SDK adapter did not open")
    ph = sdk.PacketHandler(float(config.protocol))
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
    theirs = sdk_cycle(config, bus.port)  # type: ignore[arg-type]
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


# -- host CPU time ---------------------------------------------------------------------------------
class EmulatorTimer:
    """Accumulates the time spent inside the emulator (``receive``, outermost calls only), by
    wrapping that method of one emulator instance. (On the wall clock nothing else of the
    emulator runs on this thread: its simulation is frozen or steps on its own thread.)"""

    METHODS = ("receive",)

    def __init__(self, target: Any) -> None:
        self.total = 0.0
        self.calls = 0
        self._inside = False
        for name in self.METHODS:
            setattr(target, name, self._wrap(getattr(target, name)))

    def _wrap(self, fn: Callable[..., Any]) -> Callable[..., Any]:
        clock = time.perf_counter

        def timed(*args: Any) -> Any:
            if self._inside:
                return fn(*args)
            self._inside = True
            t0 = clock()
            try:
                return fn(*args)
            finally:
                self.total += clock() - t0
                self.calls += 1
                self._inside = False

        return timed


def wrapper_overhead(samples: int = 20_000) -> float:
    """Seconds per wrapped call that the accumulator does not see (the call into the wrapper
    and the bookkeeping around its two clock readings), to be charged to the emulator too."""

    class Dummy:
        def receive(self, *args: Any) -> None:
            return None

    bare, wrapped = Dummy(), Dummy()
    timer = EmulatorTimer(wrapped)
    best = math.inf
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(samples):
            bare.receive(1)
        t1 = time.perf_counter()
        seen = timer.total
        for _ in range(samples):
            wrapped.receive(1)
        t2 = time.perf_counter()
        best = min(best, ((t2 - t1) - (timer.total - seen) - (t1 - t0)) / samples)
    return max(0.0, best)


@dataclass
class Run:
    """One timed run of ``n`` cycles by one driver."""

    total: float       # s, perf_counter over the run
    cpu: float         # s, process_time over the run
    emulator: float    # s inside the emulator
    calls: int         # outermost emulator calls
    bytes_out: int
    bytes_in: int
    instructions: int  # instruction packets the emulator parsed

    def host(self, overhead: float) -> float:
        return self.total - self.emulator - self.calls * overhead


def timed_run(bus: Bus, timer: EmulatorTimer, work: Workload, who: str,
              cycle: Callable[[Mapping[int, float]], Mapping[int, float]], n: int, *,
              si: bool = False) -> Run:
    port = bus.port
    assert isinstance(port, MemoryPort)
    emulator = port.emulator
    goal_sets = work.si_goal_sets if si else work.goal_sets
    reads: list[Mapping[int, float]] = []
    append = reads.append
    e0, c0 = timer.total, timer.calls
    w0, r0, i0 = port.bytes_written, port.bytes_read, emulator.instructions_seen
    gc.collect()
    gc.disable()
    try:
        p0 = time.process_time()
        t0 = time.perf_counter()
        for k in range(n):
            append(cycle(goal_sets[k & 1]))
        t1 = time.perf_counter()
        p1 = time.process_time()
    finally:
        gc.enable()
    work.check(who, bus, reads, n, si=si)
    return Run(t1 - t0, p1 - p0, timer.total - e0, timer.calls - c0,
               port.bytes_written - w0, port.bytes_read - r0,
               emulator.instructions_seen - i0)


def cpu_time(config: Config, cycles: int, rounds: int, warmup: int, overhead: float, *,
             live_physics: bool = False) -> dict[str, Any]:
    bus = make_bus(config, virtual=False, live_physics=live_physics)
    emulator = bus.emulator
    assert emulator is not None
    work = Workload(config, bus)
    timer = EmulatorTimer(emulator)
    sides: dict[str, tuple[Callable[[Mapping[int, float]], Mapping[int, float]], bool]] = {
        "ours": (ours_cycle(bus, config.ids, raw=True), False),
        "ours_si": (ours_cycle(bus, config.ids, raw=False), True),
        "sdk": (sdk_cycle(config, bus.port), False),  # type: ignore[arg-type]
    }
    names = {"ours": "servolab", "ours_si": "servolab (SI units)", "sdk": "SDK"}
    for side, (cycle, si) in sides.items():
        if warmup:
            timed_run(bus, timer, work, names[side], cycle, warmup, si=si)
    runs: dict[str, list[Run]] = {side: [] for side in sides}
    order = list(sides)
    for r in range(rounds):
        for side in order[r % len(order):] + order[:r % len(order)]:  # rotate the order
            cycle, si = sides[side]
            runs[side].append(timed_run(bus, timer, work, names[side], cycle, cycles, si=si))
    ref = runs["sdk"][0]
    for side in ("ours", "ours_si"):
        mine = runs[side][0]
        if (mine.bytes_out, mine.bytes_in, mine.instructions) != (
                ref.bytes_out, ref.bytes_in, ref.instructions):
            raise BenchmarkError(
                f"({config.key}) {names[side]} and the SDK did different transactions: "
                f"{mine.bytes_out}/{mine.bytes_in} bytes, {mine.instructions} instructions vs "
                f"{ref.bytes_out}/{ref.bytes_in}, {ref.instructions}")
    result: dict[str, Any] = {
        "bytes_out_per_cycle": ref.bytes_out / cycles,
        "bytes_in_per_cycle": ref.bytes_in / cycles,
        "instructions_per_cycle": ref.instructions / cycles,
    }
    for side, side_runs in runs.items():
        host = [run.host(overhead) / cycles * 1e6 for run in side_runs]
        result[side] = {
            "host_us": min(host),
            "host_us_median": statistics.median(host),
            "host_us_rounds": host,
            "emulator_us": statistics.median(run.emulator / cycles * 1e6 for run in side_runs),
            "emulator_calls_per_cycle": side_runs[0].calls / cycles,
            "cpu_over_wall": sum(r.cpu for r in side_runs) / sum(r.total for r in side_runs),
        }
    result["ratio_ours_sdk"] = result["ours"]["host_us"] / result["sdk"]["host_us"]
    result["ratio_ours_sdk_median"] = (result["ours"]["host_us_median"]
                                       / result["sdk"]["host_us_median"])
    result["ratio_ours_si_sdk"] = result["ours_si"]["host_us"] / result["sdk"]["host_us"]
    for side in sides:
        if not (math.isfinite(result[side]["host_us"]) and result[side]["host_us"] > 0):
            raise BenchmarkError(f"({config.key}) {names[side]}: host time "
                                 f"{result[side]['host_us']} µs is not a positive number")
    return result


# -- report ----------------------------------------------------------------------------------------
def report(results: list[dict[str, Any]], args: argparse.Namespace, overhead: float) -> str:
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

    lines += ["", f"2. Host CPU time per cycle, µs (best of {args.rounds} interleaved round(s) "
              f"x {args.cycles} cycles after {args.warmup} warm-up, perf_counter),",
              "   both drivers against the same emulator in this process on a wall-clock "
              "MemoryPort.",
              "   The emulator's own time (receive) is measured and SUBTRACTED from "
              "both sides,",
              f"   with {overhead * 1e9:.0f} ns per call for the accumulator itself. 'ours' "
              "works in raw ticks like the SDK;",
              "   'ours SI' converts radians both ways. Positions read back and goals written "
              "are checked.", ""]
    head = (f"{'':4}{'ours':>9}{'ours SI':>9}{'SDK':>9}{'ours/SDK':>10}"
            f"{'emulator (excluded)':>21}{'bytes/cycle':>13}{'instr/cycle':>12}")
    lines.append(head)
    for res in results:
        c, cpu = res["config"], res["cpu"]
        emu = f"{cpu['ours']['emulator_us']:.0f} / {cpu['sdk']['emulator_us']:.0f}"
        lines.append(
            f"({c.key}) {cpu['ours']['host_us']:>9.1f}{cpu['ours_si']['host_us']:>9.1f}"
            f"{cpu['sdk']['host_us']:>9.1f}{cpu['ratio_ours_sdk']:>10.2f}{emu:>21}"
            f"{cpu['bytes_out_per_cycle'] + cpu['bytes_in_per_cycle']:>13.0f}"
            f"{cpu['instructions_per_cycle']:>12.0f}")
    low = [f"({r['config'].key}) {side}" for r in results for side in ("ours", "ours_si", "sdk")
           if r["cpu"][side]["cpu_over_wall"] < 0.9]
    if low:
        lines.append(f"   warning: process_time < 90 % of perf_counter in {', '.join(low)}: "
                     "the machine was busy, figures are noisy")

    lines += [""]
    for res in results:
        c, cpu = res["config"], res["cpu"]
        lines.append(f"({c.key}) {c.label}: ratio ours/sdk = {cpu['ratio_ours_sdk']:.2f}")

    lines += ["", "What it means ('+ CPU': the wire at return delay 0 plus our host time per "
              "cycle;", "real USB adapters add their latency timer, >= 1 ms, to every answer on "
              "top):"]
    for res in results:
        c, wire, cpu = res["config"], res["wire"], res["cpu"]
        best_ms = wire[-1]["emulated_ms"] + cpu["ours"]["host_us"] / 1e3
        if c.key in ("a", "b"):
            rates = " / ".join(f"{w['max_rate_hz']:.1f} Hz (delay {w['return_delay_raw']})"
                               for w in wire)
            verdict = "reachable" if 1e3 / best_ms >= ARMSTRONG_RATE_HZ else "NOT reachable"
            lines.append(f"({c.key}) Armstrong needs {ARMSTRONG_RATE_HZ:.0f} Hz (a "
                         f"{1e3 / ARMSTRONG_RATE_HZ:.0f} ms cycle); the wire allows {rates}, "
                         f"{1e3 / best_ms:.1f} Hz + CPU: {verdict} at {c.baudrate} bps")
        else:
            frame_ms = CAMERA_FRAME_S * 1e3
            shares = " / ".join(f"{w['emulated_ms'] / frame_ms:.0%} (delay "
                                f"{w['return_delay_raw']})" for w in wire)
            lines.append(f"({c.key}) the fly treadmill's round trip takes {shares} of a "
                         f"{frame_ms:.0f} ms camera frame on the wire, "
                         f"{best_ms / frame_ms:.0%} + CPU")
    return "\n".join(lines)


def to_json(results: list[dict[str, Any]], args: argparse.Namespace,
            overhead: float) -> dict[str, Any]:
    return {
        "benchmark": "bus_cycle",
        "python": platform.python_version(),
        "platform": platform.platform(),
        "dynamixel_sdk": metadata.version("dynamixel-sdk") if sdk else None,
        "cycles": args.cycles, "rounds": args.rounds, "warmup": args.warmup,
        "live_physics": args.live_physics,
        "accumulator_overhead_ns": overhead * 1e9,
        "configs": {
            res["config"].key: {
                "label": res["config"].label, "model": res["config"].model.name,
                "protocol": res["config"].protocol, "baudrate": res["config"].baudrate,
                "ids": list(res["config"].ids), "instructions": res["config"].instructions,
                "purpose": res["config"].purpose, "wire": res["wire"], "cpu": res["cpu"],
            } for res in results
        },
    }


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cycles", type=int, default=200,
                        help="cycles per timed run (default 200)")
    parser.add_argument("--rounds", type=int, default=5,
                        help="timed runs per driver, interleaved; the best counts (default 5)")
    parser.add_argument("--warmup", type=int, default=20,
                        help="untimed cycles per driver first (default 20)")
    parser.add_argument("--quick", action="store_true",
                        help="3 cycles, 1 round, 1 warm-up: a smoke test, not a measurement")
    parser.add_argument("--json", type=Path, metavar="PATH", help="also write the figures here")
    parser.add_argument("--live-physics", action="store_true",
                        help="keep the emulated motors' physics running in the CPU measurement")
    args = parser.parse_args(argv)
    if args.quick:
        args.cycles, args.rounds, args.warmup = 3, 1, 1
    if args.cycles < 1 or args.rounds < 1 or args.warmup < 0:
        parser.error("--cycles and --rounds must be at least 1, --warmup at least 0")
    return args


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    if sdk is None:
        print("dynamixel_sdk is not installed: pip install -e '.[test]'", file=sys.stderr)
        return 2
    overhead = wrapper_overhead()
    results = []
    for config in CONFIGS:
        results.append({
            "config": config,
            "wire": wire_time(config),
            "cpu": cpu_time(config, args.cycles, args.rounds, args.warmup, overhead,
                            live_physics=args.live_physics),
        })
    print(report(results, args, overhead))
    if args.json:
        args.json.write_text(json.dumps(to_json(results, args, overhead), indent=2) + "\n")
        print(f"\nfigures written to {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
