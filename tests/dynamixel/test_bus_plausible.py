"""The bus believes only plausible replies: a status that passed its checksum/CRC but carries
what no motor sends (a value its register cannot hold, an error bit its protocol keeps at 0)
is corrupt, retried, counted in ``BusStats.implausible`` and, when the retries run out, raised
as :class:`CorruptResponse`, never returned.

Why a checksum is not enough, from the e-Manual:

- Protocol 1.0 (https://emanual.robotis.com/docs/en/dxl/protocol1/, "Status Packet"):
  ``Check Sum = ~(ID + Length + Error + Parameter1 + ... + Parameter N)``, the lowest byte.
  An 8-bit additive sum: two flips that cancel in it (bit k set in one byte and cleared in
  another, bit 7 set in two bytes, a data bit and the same bit of the checksum) pass it.
- Protocol 2.0 (https://emanual.robotis.com/docs/en/dxl/protocol2/, "CRC"): CRC-16 of
  polynomial x^16 + x^15 + x^2 + 1 (0x8005) over the whole packet. It is (x + 1) times a
  primitive polynomial of degree 15, so it catches every odd number of flipped bits and every
  pair of flips less than 2^15 - 1 bits apart: every pair in any Dynamixel packet.

So on 1.0 the range check (:func:`servolab.dynamixel.models.read_limits`) is what stands
between a paired flip and the user; it catches those that leave the register's range. Those
that stay in range only a second reply can catch: ``Bus.confirm_reads``.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import random
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from hypothesis import event, given
from hypothesis import strategies as st

from servolab.clock import VirtualClock, WallClock
from servolab.dynamixel import (
    Bus,
    BusStats,
    CorruptResponse,
    DynamixelError,
    MemoryPort,
    NoResponse,
    motorspec,
    ports,
)
from servolab.dynamixel.bus import Names
from servolab.dynamixel.bus.plans import Fields
from servolab.dynamixel.emulator import Faults, build_emulator
from servolab.dynamixel.models import MODELS, Model, model, read_limits, width_range
from servolab.dynamixel.packets import Protocol, Status
from servolab.dynamixel.protocol1 import PROTOCOL1, checksum
from servolab.dynamixel.protocol2 import PROTOCOL2, crc16, encode_fast_status
from tests.fuzzing import fuzzing

AX12 = model("AX-12A")
MX28 = model("MX-28")
XM430 = model("XM430-W210")


@dataclass(frozen=True)
class Reply:
    start: float
    data: bytes


class Replier:
    """The far end of a wire that answers each instruction with the next bytes of its
    script (nothing once the script is used up); ``heard`` counts the instructions."""

    def __init__(self, script: Sequence[bytes]) -> None:
        self.script = list(script)
        self.heard = 0

    def receive(self, data: bytes, t: float, baudrate: float) -> list[Reply]:
        self.heard += 1
        return [Reply(t, self.script.pop(0))] if self.script else []


def scripted(script: Sequence[bytes], *models: tuple[int, Model], protocol: int = 1,
             retries: int = 2) -> tuple[Bus, Replier]:
    device = Replier(script)
    port = MemoryPort(device, 1_000_000, clock=VirtualClock(), protocol=protocol)
    bus = Bus(port, retries=retries)
    for motor_id, m in models:
        bus.declare(motor_id, m)
    return bus, device


def v1_status(motor_id: int, data: bytes, error: int = 0) -> bytes:
    return PROTOCOL1.encode_status(Status(motor_id, error, data))


def v2_status(motor_id: int, data: bytes, error: int = 0) -> bytes:
    return PROTOCOL2.encode_status(Status(motor_id, error, data))


def u16(value: int) -> bytes:
    return value.to_bytes(2, "little")


# -- the checksum and the CRC, every pair of flips ---------------------------------------------

def flipped_pairs(wire: bytes, first: int) -> list[bytes]:
    """``wire`` with every pair of single-bit flips from byte ``first`` on."""
    bits = range(8 * first, 8 * len(wire))
    out = []
    for a, b in itertools.combinations(bits, 2):
        data = bytearray(wire)
        data[a // 8] ^= 1 << (a % 8)
        data[b // 8] ^= 1 << (b % 8)
        out.append(bytes(data))
    return out


def test_paired_flips_pass_the_protocol1_checksum_and_the_range_check_catches_some() -> None:
    """An AX-12A's READ of Present Position (512) answered ``FF FF 01 04 00 00 02 F8``: of the
    1 128 ways to flip two of its 48 checked bits (ID to checksum), 50 keep the checksum
    right (e-Manual, Protocol 1.0: an 8-bit sum). 13 of them keep ID, LENGTH and error byte
    and change the data: the range check (0..1023, e-Manual AX-12A Present Position) refuses
    the 6 that leave it (2560 ... 33408) and cannot tell the 7 others (0, 2, 520 ... 640) from
    the truth. (Of the rest, those that change ID or LENGTH make another frame, which the bus
    drops as stale; the error byte's bit 7 is refused as implausible.)"""
    wire = v1_status(1, u16(512))
    assert wire == bytes.fromhex("FF FF 01 04 00 00 02 F8")
    pairs = flipped_pairs(wire, 2)
    passing = [w for w in pairs if checksum(w[2:-1]) == w[-1]]
    assert (len(pairs), len(passing)) == (1128, 50)
    held = read_limits(AX12, AX12.register("present_position"))
    assert held == (0, 1023, 0)
    values = sorted(int.from_bytes(w[5:7], "little") for w in passing
                    if w[2:5] == wire[2:5])
    caught = [v for v in values if not held[0] <= v <= held[1]]
    through = [v for v in values if held[0] <= v <= held[1]]
    assert caught == [2560, 4608, 8704, 16896, 33280, 33408]
    assert through == [0, 2, 520, 528, 544, 576, 640]     # 2: bit 1 up in D0, down in D1


def test_protocol2_crc_catches_every_pair_of_flips() -> None:
    """The same read on 2.0 (an XM430's Present Position, 4 bytes): every one of the 3 828
    pairs of flipped bits after the header ``FF FF FD 00`` (ID to CRC, 11 bytes) fails the
    CRC-16 (e-Manual, Protocol 2.0, CRC)."""
    wire = v2_status(1, (2048).to_bytes(4, "little"))
    assert len(wire) == 15
    pairs = flipped_pairs(wire, 4)
    assert len(pairs) == math.comb(8 * 11, 2) == 3828
    assert all(crc16(w[:-2]) != int.from_bytes(w[-2:], "little") for w in pairs)


# -- what a register can hold ---------------------------------------------------------------

@pytest.mark.parametrize(("m", "name", "held"), [
    (AX12, "present_position", (0, 1023, 0)),       # e-Manual AX-12A: 0 ~ 1,023
    (AX12, "goal_position", (0, 1023, 0)),
    (AX12, "present_speed", (0, 2047, 0)),          # bit 10 the direction
    (AX12, "present_load", (0, 2047, 0)),           # bit 10 the direction
    (AX12, "present_voltage", None),                # no figure: unchecked
    (MX28, "present_position", (-28672, 28672, 0)),  # joint 0 ~ 4,095, multi-turn ±28,672
    (model("EX-106+"), "present_position", None),   # wheel mode: 0 ~ 65,535
    (model("XL-320"), "present_position", (0, 1023, 0)),
    (model("XL-320"), "hardware_error_status", (0, 255, 0xF8)),   # its own three bits
    (model("XL-320"), "present_speed", (0, 2047, 0)),
    (model("XL-320"), "moving", (0, 1, 0)),
    (XM430, "present_position", None),              # multi-turn: any int32
    (XM430, "goal_position", None),                 # takes Present Position at power-up
    (XM430, "hardware_error_status", (0, 255, 0xC2)),   # bits 0, 2, 3, 4, 5
    (XM430, "moving_status", (0, 255, 0xC4)),       # bits 2, 6, 7 unused
    (XM430, "bus_watchdog", (-1, 127, 0)),          # the motor sets -1
    (XM430, "registered_instruction", (0, 1, 0)),
    (model("XL430-W250"), "present_load", (-1000, 1000, 0)),
])
def test_read_limits(m: Model, name: str, held: tuple[int, int, int] | None) -> None:
    assert read_limits(m, m.register(name)) == held


def test_what_a_register_can_hold_is_within_what_its_bytes_hold() -> None:
    for m in {m.name: m for m in MODELS.values()}.values():
        for reg in m.registers:
            held = read_limits(m, reg)
            if held is not None:
                low, high = width_range(reg)
                assert low <= held[0] <= held[1] <= high, (m.name, reg.name)


def test_the_fast_check_agrees_with_the_worded_one() -> None:
    """What every read pays (``Fields.holds``: the bits that must be 0 tested at once, other
    ranges compared) says yes exactly when the sentence that names a bad value says nothing:
    every shipped model's registers, one by one, in runs of three and all together, on blocks
    of random bytes, of bytes near each register's bounds, and of zeros."""
    rng = random.Random(5)
    for m in shipped_models():
        regs = sorted(m.registers, key=lambda r: r.address)
        groups = [[r.name] for r in regs] + [[r.name for r in regs[k:k + 3]]
                                             for k in range(0, len(regs), 3)]
        groups.append([r.name for r in regs if r.address < 256])
        for names in groups:
            fields = Fields(m, names)
            if fields.holds is None:
                assert all(read_limits(m, m.register(n)) is None for n in names)
                continue
            for trial in range(40):
                block = bytearray(rng.randbytes(fields.length) if trial % 4 else
                                  bytes(fields.length))
                if trial % 4 == 1:                     # each checked value at a bound, or past
                    for k, low, high, _ in fields.limits:
                        reg = fields.regs[k]
                        value = rng.choice([low, high, low - 1, high + 1])
                        low_w, high_w = width_range(reg)
                        value = min(max(value, low_w), high_w)
                        at = reg.address - fields.start
                        block[at:at + reg.size] = reg.encode(value)
                buf = b"\x00" * 3 + bytes(block)
                assert fields.holds(buf, 3) == (fields.implausible(buf, 3) is None), (
                    m.name, names, block.hex())


def shipped_models() -> list[Model]:
    return sorted({m.name: m for m in MODELS.values()}.values(), key=lambda m: m.name)


@pytest.mark.parametrize("m", shipped_models(), ids=lambda m: m.name)
def test_the_emulated_firmware_never_shows_what_the_bus_refuses(m: Model) -> None:
    """Every register of every shipped model, read by name through the bus (so checked)
    at rest, moving, in its other modes, with a hardware error and after the bus watchdog
    tripped: no reply is refused. The limits admit what the emulated firmware shows."""
    bus = Bus.open(f"emu://{Path(m.path).stem}:1", retries=0)
    clock = bus.port.clock
    names = [r.name for r in m.registers]

    def read_all() -> None:
        bus.read(1, names, raw=True)

    read_all()
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", 1.0)
    clock.advance(0.2)
    read_all()                                                 # on its way
    motor = bus.emulator.motor(1)
    if m.has("moving_speed"):                                  # AX-style tables: wheel mode
        bus.write(1, "torque_enable", 0)
        limits = ("cw_angle_limit", "ccw_angle_limit")
        if m.has("control_mode"):                              # XL-320
            bus.write(1, "control_mode", 1, raw=True)
        else:
            bus.write(1, dict.fromkeys(limits, 0), raw=True)
        bus.write(1, "torque_enable", 1)
        bus.write(1, "moving_speed", 0x400 | 1023, raw=True)
        clock.advance(3.0)
        read_all()
        if m.register("goal_position").signed:                 # MX: multi-turn
            bus.write(1, "torque_enable", 0)
            bus.write(1, dict.fromkeys(limits, 4095), raw=True)
            bus.write(1, "goal_position", -28000, raw=True)
            clock.advance(3.0)
            read_all()
    else:                                                      # X-style: operating modes
        for mode, goal, value in ((1, "goal_velocity", -1.0), (4, "goal_position", -100.0)):
            if mode not in m.operating_modes:
                continue
            bus.write(1, "torque_enable", 0)
            bus.write(1, "operating_mode", mode, raw=True)
            bus.write(1, "torque_enable", 1)
            bus.write(1, goal, value)
            clock.advance(2.0)
            read_all()
        if m.has("bus_watchdog"):
            bus.write(1, "bus_watchdog", 1, raw=True)          # 20 ms
            clock.advance(0.1)
            assert bus.read(1, "bus_watchdog", raw=True) == -1
    motor.inject_hardware_error("overload")
    read_all()
    assert bus.stats.implausible == 0


# -- crafted replies: in their checksum, out of their range ---------------------------------

def test_a_value_outside_the_range_in_a_right_checksum_is_retried_counted_and_raised() -> None:
    """A crafted Protocol 1.0 status with a right checksum and Present Position 33 000 (an
    AX-12A's is 0..1023): each of the three attempts is refused, counted, and the read
    raises CorruptResponse naming the motor, the register and the value. 33 000 is never
    returned."""
    bad = v1_status(1, u16(33_000))
    assert PROTOCOL1.decode_status(bad).params == u16(33_000)      # the checksum is right
    bus, device = scripted([bad] * 3, (1, AX12))
    with pytest.raises(CorruptResponse, match=r"motor 1: READ got present_position 33000, "
                       r"outside 0\.\.1023, what it holds on the AX-12A") as caught:
        bus.read(1, "present_position", raw=True)
    assert caught.value.motor_id == 1
    assert device.heard == 3
    assert (bus.stats.implausible, bus.stats.retries, bus.stats.corrupt) == (3, 2, 0)
    # the same value three times is no noise: the message says where to look
    assert "the same 3 times" in str(caught.value) and "read_address" in str(caught.value)
    bus, _ = scripted([bad, v1_status(1, u16(40_000)), bad], (1, AX12))
    with pytest.raises(CorruptResponse, match="present_position 33000") as caught:
        bus.read(1, "present_position", raw=True)
    assert "the same" not in str(caught.value)


def test_after_an_implausible_reply_the_retry_brings_the_truth() -> None:
    bus, device = scripted([v1_status(1, u16(33_000)), v1_status(1, u16(512))], (1, AX12))
    assert bus.read(1, "present_position", raw=True) == 512
    assert (device.heard, bus.stats.implausible, bus.stats.retries) == (2, 1, 1)


def test_in_si_units_too_and_with_several_registers() -> None:
    """The check is on the raw value, whatever the caller asks for: present_speed 0x0800
    (bit 11: no such bit in a 0..2047 register) among three registers read at once."""
    block = u16(512) + u16(0x0800) + u16(0)
    limits = v1_status(1, u16(0) + u16(1023))      # the bus first learns the mode: joint
    bus, _ = scripted([limits] + [v1_status(1, block)] * 3, (1, AX12))
    with pytest.raises(CorruptResponse, match="present_speed 2048"):
        bus.read(1, ["present_position", "present_speed", "present_load"])


@pytest.mark.parametrize(("protocol", "m", "error", "words"), [
    (1, AX12, 0x80, "error bit 7, which Protocol 1.0 keeps at 0"),
    (2, XM430, 0x08, "error number 8, which Protocol 2.0 does not define"),
    (2, XM430, 0xFF, "error number 127"),
])
def test_an_error_byte_no_motor_sends_is_corrupt(protocol: int, m: Model, error: int,
                                                 words: str) -> None:
    """e-Manual, Protocol 1.0 Status Packet: bit 7 of the error is 0; Protocol 2.0: error
    numbers 0x01..0x07. A status with anything else passed its checksum/CRC by chance."""
    status = v1_status if protocol == 1 else v2_status
    size = 2 if protocol == 1 else 4
    bus, _ = scripted([status(1, bytes(size), error)] * 3, (1, m), protocol=protocol)
    with pytest.raises(CorruptResponse, match=words):
        bus.read(1, "present_position", raw=True)
    assert bus.stats.implausible == 3


def test_a_bulk_read_refuses_one_motors_implausible_block() -> None:
    """MX-28s on 1.0 read many at once with BULK_READ: motor 2's Present Position -30 720
    (beyond the multi-turn -28 672), then its Present Load 0x8000 (no bit 15 in a 0..2047
    register), makes the whole reply corrupt; the retry brings it right."""
    good = {i: v1_status(i, u16(2048)) for i in (1, 2, 3)}
    bad = v1_status(2, u16(2048 | 0x8000))
    loads = {i: v1_status(i, u16(0)) for i in (1, 2, 3)}
    bad_load = v1_status(2, u16(0x8000))
    mx = [(i, MX28) for i in (1, 2, 3)]
    bus, device = scripted([good[1] + bad + good[3]], *mx, retries=0)
    with pytest.raises(CorruptResponse, match="motor 2: BULK_READ got present_position -30720"):
        bus.sync_read("present_position", [1, 2, 3], raw=True)
    bus.retries = 2
    device.script = [good[1] + bad + good[3], good[1] + good[2] + good[3]]
    assert bus.sync_read("present_position", [1, 2, 3], raw=True) == dict.fromkeys((1, 2, 3),
                                                                              2048)
    device.script = [loads[1] + bad_load, loads[1] + loads[2]]
    assert bus.bulk_read({1: "present_load", 2: "present_load"}, raw=True) == {
        1: {"present_load": 0}, 2: {"present_load": 0}}
    assert bus.stats.implausible == 3


def test_sync_read_and_bulk_read_on_protocol2_refuse_unused_bits() -> None:
    """XM430s: Hardware Error Status with bit 1 set (unused on the X-series) in a status whose
    CRC is right; SYNC_READ and BULK_READ both refuse it."""
    xm = [(1, XM430), (2, XM430)]
    ok, bad = v2_status(1, b"\x00"), v2_status(2, b"\x02")
    bus, device = scripted([ok + bad] * 3, *xm, protocol=2)
    with pytest.raises(CorruptResponse, match="hardware_error_status 0x02, whose bits 0x02 "
                       "the XM430-W210 keeps at 0"):
        bus.sync_read("hardware_error_status", [1, 2], raw=True)
    device.script = [ok + bad, ok + v2_status(2, b"\x20")]
    assert bus.bulk_read({1: "hardware_error_status", 2: "hardware_error_status"},
                         raw=True) == {1: {"hardware_error_status": 0},
                                       2: {"hardware_error_status": 0x20}}
    assert bus.stats.implausible == 4


def test_fast_sync_and_fast_bulk_read_refuse_unused_bits() -> None:
    """One fast status packet for both motors (X-series firmware 46): Moving Status with bit
    6 set in motor 2's block, its running CRC right, is refused; then the truth."""
    xm = [(1, XM430), (2, XM430)]
    bad = encode_fast_status([(1, 0, b"\x01"), (2, 0, b"\x40")])
    good = encode_fast_status([(1, 0, b"\x01"), (2, 0, b"\x31")])
    bus, _ = scripted([bad, good], *xm, protocol=2)
    assert bus.fast_sync_read("moving_status", [1, 2], raw=True) == {1: 0x01, 2: 0x31}
    bus2, _ = scripted([bad, bad, bad], *xm, protocol=2)
    with pytest.raises(CorruptResponse, match="FAST_BULK_READ got moving_status 0x40"):
        bus2.fast_bulk_read({1: "moving_status", 2: "moving_status"}, raw=True)
    assert (bus.stats.implausible, bus2.stats.implausible) == (1, 3)


def test_a_status_from_another_motor_or_of_another_length_is_never_the_answer() -> None:
    """Right checksums, wrong frame: motor 2's status to a READ of motor 1, and motor 1's
    with 4 data bytes to a READ of 2 bytes: no value is returned, whatever the retries."""
    bus, _ = scripted([v1_status(2, u16(100))] * 3, (1, AX12))
    with pytest.raises(NoResponse):
        bus.read(1, "present_position", raw=True)
    assert bus.stats.stale == 3
    bus, _ = scripted([v1_status(1, u16(100) + u16(100))] * 3, (1, AX12))
    with pytest.raises(CorruptResponse, match="4 data bytes from motor 1, expected 2"):
        bus.read(1, "present_position", raw=True)


def test_confirm_reads_takes_only_two_replies_alike() -> None:
    """An in-range paired flip (512 read as 2: bit 1 up in the low byte, down in the high
    byte, the checksum unchanged) passes every check of one reply; with ``confirm_reads`` the
    next reply must bring the same bytes: 2 is refused, 512 (twice) returned."""
    truth, flipped = v1_status(1, u16(512)), v1_status(1, u16(2))
    assert truth[-1] == flipped[-1]                              # the same checksum
    bus, _ = scripted([flipped, truth], (1, AX12))
    assert bus.read(1, "present_position", raw=True) == 2      # one reply: taken
    bus, device = scripted([flipped, truth, truth], (1, AX12))
    bus.confirm_reads = True
    assert bus.read(1, "present_position", raw=True) == 512
    assert (device.heard, bus.stats.implausible, bus.stats.retries) == (3, 1, 0)
    bus, _ = scripted([truth, flipped, truth, flipped], (1, AX12), retries=2)
    bus.confirm_reads = True
    with pytest.raises(CorruptResponse, match="no two replies alike in 4"):
        bus.read(1, "present_position", raw=True)


# -- fuzzing the replies ----------------------------------------------------------------------

@dataclass(frozen=True)
class Case:
    """A read to fuzz: its protocol, the motors (ID, model), the call (returning {ID:
    {name: raw value}}) and the registers it reads of each."""

    protocol: int
    models: tuple[tuple[int, Model], ...]
    call: Callable[[Bus], dict[int, dict[str, int]]]
    names: tuple[str, ...]


def _read(motor_id: int, names: tuple[str, ...]) -> Callable[[Bus], dict[int, dict[str, int]]]:
    return lambda bus: {motor_id: bus.read(motor_id, list(names), raw=True)}


AX_NAMES = ("present_position", "present_speed", "present_load")
XM_NAMES = ("moving", "moving_status")
CASES = {
    "1.0 READ": Case(1, ((1, AX12),), _read(1, AX_NAMES), AX_NAMES),
    "1.0 BULK_READ": Case(1, ((1, MX28), (2, MX28)),
                          lambda bus: bus.sync_read(list(AX_NAMES), [1, 2], raw=True), AX_NAMES),
    "2.0 READ": Case(2, ((1, XM430),), _read(1, XM_NAMES), XM_NAMES),
    "2.0 SYNC_READ": Case(2, ((1, XM430), (2, XM430)),
                          lambda bus: bus.sync_read(list(XM_NAMES), [1, 2], raw=True),
                          XM_NAMES),
}


@st.composite
def reply(draw: st.DrawFn, case: Case) -> bytes:
    """One attempt's bytes: each motor's status with data drawn at random (right checksum
    or CRC: what the range check alone must judge), then perhaps broken: bits flipped,
    bytes cut, noise, another ID or length; or noise alone."""
    proto: Protocol = PROTOCOL1 if case.protocol == 1 else PROTOCOL2
    if draw(st.integers(0, 9)) == 0:
        return draw(st.binary(max_size=40))
    wire = b""
    for motor_id, m in case.models:
        _, length = m.span(list(case.names))
        motor_id = draw(st.sampled_from([motor_id] * 8 + [motor_id + 1, 0xFE]))
        length = draw(st.sampled_from([length] * 8 + [0, length + 1]))
        data = draw(st.one_of(st.binary(min_size=length, max_size=length),
                              st.just(bytes(length))))
        error = draw(st.sampled_from([0] * 6 + [0x80, 0x20, 0x08, 0x7F]))
        wire += proto.encode_status(Status(motor_id, error, data))
    out = bytearray(wire)
    for _ in range(draw(st.integers(0, 3))):
        kind = draw(st.sampled_from(["flip", "flip", "cut", "noise"]))
        at = draw(st.integers(0, max(0, len(out) - 1)))
        if kind == "flip" and out:
            out[at] ^= 1 << draw(st.integers(0, 7))
        elif kind == "cut":
            del out[at:at + draw(st.integers(1, 4))]
        else:
            out[at:at] = draw(st.binary(min_size=1, max_size=6))
    return bytes(out)


@pytest.mark.fuzz
@pytest.mark.parametrize("case_name", list(CASES))
@fuzzing(100)
@given(data=st.data())
def test_whatever_comes_back_a_read_raises_a_dynamixel_error_or_returns_a_plausible_value(
        case_name: str, data: st.DataObject) -> None:
    """Random and mutated status packets through the link and the stream parser: a read
    raises nothing but the DynamixelError family, and what it returns is within what each
    register can hold and is the data of a status that came, from the motor asked, with the
    length asked (never invented, never another motor's)."""
    case = CASES[case_name]
    script = data.draw(st.lists(reply(case), min_size=3, max_size=3))  # one an attempt
    bus, _ = scripted(script, *case.models, protocol=case.protocol, retries=2)
    try:
        got = case.call(bus)
    except DynamixelError as exc:
        event(type(exc).__name__)
        return
    event("returned")
    proto: Protocol = PROTOCOL1 if case.protocol == 1 else PROTOCOL2
    framed = set()
    for wire in script:
        for frame in proto.parser().feed(wire):
            status = proto.as_status(frame) if case.protocol == 1 else _status_or_none(frame)
            if status is not None:
                framed.add((status.id, status.params))
    for motor_id, m in case.models:
        values = got[motor_id]
        start, length = m.span(list(case.names))
        block = bytearray(length)
        for name in case.names:
            reg = m.register(name)
            held = read_limits(m, reg)
            value = values[name]
            if held is not None:
                assert held[0] <= value <= held[1] and not value & held[2], (name, value)
            at = reg.address - start
            block[at:at + reg.size] = reg.encode(value)
        assert (motor_id, bytes(block)) in framed


def _status_or_none(frame: object) -> Status | None:
    try:
        return PROTOCOL2.as_status(frame)  # type: ignore[arg-type]
    except DynamixelError:
        return None


# -- 5 % of the bytes corrupted, on a pseudo-terminal -------------------------------------------

CORRUPTION = 0.05
#: reads a protocol, 20 000 in all; each protocol's run split between PAIRS bus-and-pty pairs
#: at once (a failed attempt waits out its reply's longest time, about 3 ms: the waits overlap)
OPERATIONS = 10_000
PAIRS = 5

Wrong = tuple[int, str, int, int, list[tuple[bytes, bytes]]]


@dataclass
class Run:
    """What reads against the truth found: operations, how many returned values, values
    compared with the motors' registers, failures by kind, and the wrong values (motor,
    register, truth, value returned, the replies of the operation and of the one before it,
    as sent and as corrupted)."""

    operations: int = 0
    returned: int = 0
    values: int = 0
    failed: dict[str, int] = field(default_factory=dict)
    wrong: list[Wrong] = field(default_factory=list)
    stats: BusStats = field(default_factory=BusStats)

    def add(self, other: Run) -> None:
        self.operations += other.operations
        self.returned += other.returned
        self.values += other.values
        for kind, n in other.failed.items():
            self.failed[kind] = self.failed.get(kind, 0) + n
        self.wrong += other.wrong
        for counter in dataclasses.fields(BusStats):
            setattr(self.stats, counter.name, getattr(self.stats, counter.name)
                    + getattr(other.stats, counter.name))


def _calls(version: int) -> list[Callable[[Bus], dict[int, dict[str, int]]]]:
    """The reads of a run, in turn: single and multi-motor, every kind the motors have."""
    ids = (1, 2, 3)

    def sync(bus: Bus) -> dict[int, dict[str, int]]:
        return {i: {"present_position": int(v)} for i, v in
                bus.sync_read("present_position", ids, raw=True).items()}

    if version == 1:
        mixed: dict[int, Names] = {1: "present_position", 2: ["present_speed"],
                                   3: ["torque_limit"]}
        return [_read(1, AX_NAMES), _read(2, ("goal_position",)), _read(3, AX_NAMES), sync,
                lambda bus: bus.bulk_read(mixed, raw=True)]  # type: ignore[return-value]

    def fast_sync(bus: Bus) -> dict[int, dict[str, int]]:
        return {i: {"present_position": int(v)} for i, v in
                bus.fast_sync_read("present_position", ids, raw=True).items()}

    bulk: dict[int, Names] = {1: ["present_position"], 2: list(XM_NAMES),
                              3: ["hardware_error_status"]}
    return [_read(1, ("present_position",)), _read(2, XM_NAMES), sync,
            lambda bus: bus.bulk_read(bulk, raw=True),  # type: ignore[return-value]
            fast_sync,
            lambda bus: bus.fast_bulk_read(bulk, raw=True)]  # type: ignore[return-value]


def read_on_a_pty(version: int, operations: int, *, confirm: bool, seed: int) -> Run:
    """``operations`` reads from a bus on the pty that ``servolab sim --pty`` serves
    (:class:`PtyServer`), three emulated motors at rest at 1 Mbps and return delay 0, their
    :class:`Faults` flipping a bit in 5 % of their status bytes. Each value returned is
    compared with the emulated register; the replies of an operation that returned a wrong
    one are kept with it."""
    spec = motorspec.load("mx28:1-3" if version == 1 else "xm430-w210:1-3",
                          baudrate=1_000_000)
    emulator = build_emulator(spec)
    for motor in emulator.motors:
        motor.set_raw("return_delay_time", 0)     # no wait before each answer: a faster run
    calls = _calls(version)
    sent: list[tuple[bytes, bytes]] = []
    faults = Faults(corrupt_rate=CORRUPTION, seed=seed)
    corrupt = faults.apply

    def apply(data: bytes) -> bytes:                # the server's thread: what it sent
        out = corrupt(data)
        sent.append((data, out))
        return out

    run = Run()
    with ports.PtyServer(emulator, 1_000_000, clock=WallClock()) as server, \
            Bus.open(server.device, protocol=version, baudrate=1_000_000,
                     latency=0.0) as bus:
        for i in (1, 2, 3):
            _until_it_answers(bus, i)
        bus.confirm_reads = confirm
        emulator.faults = faults
        faults.apply = apply  # type: ignore[method-assign]
        earlier: list[tuple[bytes, bytes]] = []
        for k in range(operations):
            # the replies sent for the read before, kept: on a loaded machine one may come
            # after that read gave up, and this one takes it (1.0 has no transaction id)
            earlier = list(sent)
            sent.clear()
            run.operations += 1
            try:
                got = calls[k % len(calls)](bus)
            except DynamixelError as exc:
                kind = type(exc).__name__
                run.failed[kind] = run.failed.get(kind, 0) + 1
                continue
            run.returned += 1
            for motor_id, values in got.items():
                for name, value in values.items():
                    run.values += 1
                    truth = emulator.motor(motor_id).get_raw(name)
                    if value != truth:
                        run.wrong.append((motor_id, name, truth, value, earlier + sent))
        run.stats = bus.stats
    return run


def _until_it_answers(bus: Bus, motor_id: int, attempts: int = 50) -> None:
    """PING until the motor answers: with return delay 0 a PING waits 2.7 ms, which the
    pty server's thread may miss on a machine loaded by the rest of the suite (before the
    faults are on, so nothing of the test is skipped)."""
    for _ in range(attempts - 1):
        try:
            bus.ping(motor_id)
            return
        except NoResponse:
            continue
    bus.ping(motor_id)


def reads_on_ptys(version: int, operations: int, *, confirm: bool) -> Run:
    """:func:`read_on_a_pty` on :data:`PAIRS` buses at once, ``operations`` in all."""
    total = Run()
    with ThreadPoolExecutor(PAIRS) as pool:
        runs = [pool.submit(read_on_a_pty, version, operations // PAIRS, confirm=confirm,
                            seed=10 * version + k) for k in range(PAIRS)]
        for future in runs:
            total.add(future.result())
    return total


def paired_flip(version: int, wrong: Wrong) -> bool:
    """Whether a wrong value came in a reply that no receiver of one reply could refuse: a
    corrupted status with a right checksum/CRC, from the motor asked, carrying the value, and
    the value one its register can hold. The reply may be one sent for the read before, come
    late (a clean-clone run on a loaded machine: 2176 for 2048 in a status sent before the
    read that took it)."""
    motor_id, name, _, value, sent = wrong
    proto: Protocol = PROTOCOL1 if version == 1 else PROTOCOL2
    m = MX28 if version == 1 else XM430
    reg = m.register(name)
    held = read_limits(m, reg)
    if held is not None and not (held[0] <= value <= held[1] and not value & held[2]):
        return False                           # out of range: the bus should have refused it
    for original, corrupted in sent:
        if original != corrupted:
            for frame in proto.parser().feed(corrupted):
                status = proto.as_status(frame)
                if status.id == motor_id and reg.encode(value) in status.params:
                    return True
    return False


@pytest.mark.slow
@pytest.mark.parametrize("version", [1, 2])
def test_no_wrong_value_in_10000_reads_a_protocol_at_five_percent_corruption(
        version: int) -> None:
    """10 000 reads a protocol, 20 000 in all (READ, BULK_READ on 1.0; READ, SYNC_READ,
    BULK_READ and their fast forms on 2.0), 5 % of the status bytes corrupted: every value
    returned is the motor's own, every read that fails raises a DynamixelError. On 2.0 the
    CRC and the checks suffice; on 1.0 ``confirm_reads`` is needed, because an in-range
    paired flip passes every check of one reply (see the next test)."""
    run = reads_on_ptys(version, OPERATIONS, confirm=version == 1)
    print(f"\nprotocol {version}.0{' with confirm_reads' if version == 1 else ''}: "
          f"{len(run.wrong)} wrong of {run.values} values, {run.returned} of "
          f"{run.operations} reads returned, failed {run.failed}; {run.stats}")
    assert run.operations == OPERATIONS
    assert run.wrong == []
    assert run.returned > OPERATIONS // 4 and run.values > OPERATIONS // 2
    assert set(run.failed) <= {"CorruptResponse", "NoResponse", "MotorError"}
    assert run.stats.corrupt > 0 and run.stats.retries > 0


@pytest.mark.slow
def test_with_one_reply_a_read_protocol1_lets_only_in_range_paired_flips_through() -> None:
    """The same on 1.0 without ``confirm_reads``: a few wrong values come through, and every
    one is a value its register can hold, carried by a corrupted status whose checksum is
    right, from the motor asked: a paired flip that no check of one reply can catch. None is
    out of range (those are refused, counted in ``implausible``), none another motor's or
    another read's."""
    run = reads_on_ptys(1, OPERATIONS // 2, confirm=False)
    print(f"\nprotocol 1.0, one reply a read: {len(run.wrong)} wrong of {run.values} values "
          f"in {run.operations} reads; {run.stats}")
    assert run.values > OPERATIONS // 4
    unexplained = [wrong for wrong in run.wrong if not paired_flip(1, wrong)]
    assert not unexplained, "\n".join(  # whole: pytest would cut the bytes that tell why
        f"motor {m} {name}: {value} for {truth}, replies {[(a.hex(), b.hex()) for a, b in sent]}"
        for m, name, truth, value, sent in unexplained)
