"""Junk on the line does not deafen the emulated bus: the unmodified ROBOTIS dynamixel-sdk,
through its own PortHandler on the pseudo-terminal of ``servolab sim``, interleaves its calls
with junk written raw to the port, and after every burst the bus answers again, with the
right values and never a late status.

The junk (from a seeded ``random.Random``): headers cut short, whole packets with a bad
checksum/CRC, absurd length fields (2.0: ``FF FF FD 00 id FF FF``; 1.0: a length below 2 or
ID 0xFF), and random bytes, one to three of them a burst. The SDK's next call is made at once,
with no pause to synchronise on. The rule that makes this deterministic: the emulated motors
drop a packet they are partway through after 10 ms of silence
(:attr:`servolab.dynamixel.emulator.Emulator.idle_timeout`), and the SDK's own packet timeout
is longer (2 x LATENCY_TIMER 16 ms + 2 ms plus the status's wire time), so

* if the junk leaves the motors inside a packet (a cut header), the SDK's first call is read
  as the rest of it and times out (COMM_RX_TIMEOUT); if it holds a whole packet with a bad
  checksum to a motor on the bus, that motor's checksum-error status may reach the SDK as the
  answer (an error byte; the SDK then fails to pick data out of it, an IndexError) -- both as
  on a real bus. After any other junk the first call must succeed;
* the call after a failed one starts on a line that has been silent for longer than the idle
  timeout, so it starts a fresh packet and must succeed.

So each burst is followed by a recovery within two calls; the tests count the recoveries and
assert one per burst: 40 bursts and 40 recoveries each (with these seeds the first call fails
after 31 of the 40 bursts on 1.0 and 18 on 2.0). Every value the SDK returns as a success is
checked, so a late status taken for the answer to a later call would fail the test: PING and
model_number give the model number, goal_position what was last written (a write in a packet
with a bad checksum must not count), present_position lies between the start and the goals
written. Finally the ``servolab sim`` process is still alive and uses well under one core over
an idle second (its simulation thread steps the motors at 1 kHz: about 5 %). The two tests
take about 8 s together.
"""

from __future__ import annotations

import os
import random
import subprocess
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import dynamixel_sdk as sdk
import pytest

from servolab.dynamixel.packets import Protocol
from servolab.dynamixel.protocol1 import PROTOCOL1
from servolab.dynamixel.protocol2 import PROTOCOL2
from tests.simproc import sim_process

#: realtime: the recoveries hold the wall clock to the SDK's packet timeout, so no test that
#: keeps every core busy (busy_cpu) may run beside them
pytestmark = [pytest.mark.slow, pytest.mark.realtime]

BURSTS = 40
IDS = (1, 2, 3)
ABSENT = 200            # an ID no motor has: a cut header to it is harmless however it ends
FAILURES = (sdk.COMM_RX_TIMEOUT, sdk.COMM_RX_CORRUPT)


class Failed(Exception):
    """An SDK call that did not succeed, in a way a bus that just carried junk may fail."""


class Rig:
    """One protocol's SDK calls with the expected answers."""

    def __init__(self, version: int, port: Any, number: int, proto: Protocol) -> None:
        self.version = version
        self.port = port
        self.ph = sdk.PacketHandler(float(version))
        self.number = number        # model number
        self.proto = proto
        self.goal_address, self.present_address = (30, 36) if version == 1 else (116, 132)
        self.size = 2 if version == 1 else 4
        self.goals: dict[int, int] = {}
        self.hull: dict[int, tuple[int, int]] = {}

    def _ok(self, result: tuple[Any, ...]) -> tuple[Any, ...]:
        *values, comm, error = result
        if comm in FAILURES or (comm == sdk.COMM_SUCCESS and error):
            raise Failed(f"comm {comm}, error {error}")
        assert comm == sdk.COMM_SUCCESS, f"unexpected SDK result {comm}"
        return tuple(values)

    def read(self, motor_id: int, address: int, size: int | None = None) -> int:
        size = size or self.size
        read = self.ph.read2ByteTxRx if size == 2 else self.ph.read4ByteTxRx
        try:
            (value,) = self._ok(read(self.port, motor_id, address))
        except IndexError:   # the SDK took a checksum-error status (no data) as the answer
            raise Failed("status without data") from None
        return int(value)

    def signed(self, value: int) -> int:
        return value - (1 << 32) if self.size == 4 and value >= 1 << 31 else value

    # -- the calls, each checking what it got --------------------------------------------
    def ping(self, rng: random.Random) -> None:
        motor_id = rng.choice(IDS)
        (number,) = self._ok(self.ph.ping(self.port, motor_id))
        assert number == self.number, f"PING {motor_id} returned model {number}"

    def model_number(self, rng: random.Random) -> None:
        motor_id = rng.choice(IDS)
        value = self.read(motor_id, 0, 2)
        assert value == self.number, f"model_number of {motor_id} read as {value}"

    def goal(self, rng: random.Random) -> None:
        motor_id = rng.choice(IDS)
        value = self.signed(self.read(motor_id, self.goal_address))
        assert value == self.goals[motor_id], \
            f"goal_position of {motor_id} read as {value}, last written {self.goals[motor_id]}"

    def present(self, rng: random.Random) -> None:
        motor_id = rng.choice(IDS)
        self.check_present(motor_id, self.signed(self.read(motor_id, self.present_address)))

    def check_present(self, motor_id: int, value: int) -> None:
        lo, hi = self.hull[motor_id]
        assert lo - 2 <= value <= hi + 2, \
            f"present_position of {motor_id} read as {value}, outside {lo}..{hi}"

    def write(self, rng: random.Random) -> None:
        motor_id = rng.choice(IDS)
        value = rng.randrange(300, 700) if self.version == 1 else rng.randrange(1500, 2600)
        write = self.ph.write2ByteTxRx if self.size == 2 else self.ph.write4ByteTxRx
        self._ok(write(self.port, motor_id, self.goal_address, value))
        self.goals[motor_id] = value
        lo, hi = self.hull[motor_id]
        self.hull[motor_id] = (min(lo, value), max(hi, value))

    def sync_read(self, rng: random.Random) -> None:
        reader = sdk.GroupSyncRead(self.port, self.ph, self.present_address, 4)
        for motor_id in IDS:
            assert reader.addParam(motor_id)
        comm = reader.txRxPacket()
        if comm in FAILURES:
            raise Failed(f"comm {comm}")
        assert comm == sdk.COMM_SUCCESS, f"unexpected SDK result {comm}"
        for motor_id in IDS:
            assert reader.isAvailable(motor_id, self.present_address, 4)
            self.check_present(motor_id, self.signed(reader.getData(motor_id,
                                                                     self.present_address, 4)))

    def calls(self) -> list[Callable[[random.Random], None]]:
        calls = [self.ping, self.model_number, self.goal, self.present, self.write]
        return calls + ([self.sync_read] if self.version == 2 else [])

    def setup(self) -> None:
        """Torque on and the starting positions. Not what the test checks: a call that a
        loaded machine made the real-time sim miss is tried again, up to three times."""
        def again(call: Callable[..., Any], *args: Any) -> Any:
            for attempt in range(3):
                try:
                    return call(*args)
                except Failed:
                    if attempt == 2:
                        raise
            return None

        def torque_on(motor_id: int) -> None:
            address = 64 if self.version == 2 else 24
            self._ok(self.ph.write1ByteTxRx(self.port, motor_id, address, 1))

        for motor_id in IDS:
            again(torque_on, motor_id)
            start = self.signed(again(self.read, motor_id, self.present_address))
            self.goals[motor_id] = self.signed(again(self.read, motor_id, self.goal_address))
            self.hull[motor_id] = (min(start, self.goals[motor_id]),
                                   max(start, self.goals[motor_id]))

    # -- junk ------------------------------------------------------------------------------
    def junk(self, rng: random.Random) -> tuple[bytes, bool]:
        """One to three pieces of junk; and whether the SDK's next call may fail after it: if
        the junk leaves the motors inside a packet (a cut header, whose rest the call's bytes
        become), or holds a whole packet with a bad checksum to a motor on the bus (which
        answers it with its checksum error, as a real one does)."""
        out = b""
        for _ in range(rng.randint(1, 3)):
            kind = rng.choice(["cut", "cut", "bad", "absurd", "random"])
            if kind == "cut":
                out += self.cut_header(rng)
            elif kind == "bad":
                out += self.bad_checksum(rng)
            elif kind == "absurd":
                out += self.absurd_length(rng)
            else:
                out += self.random_bytes(rng)
        parser = self.proto.parser(keep_rejected=True)
        parser.feed(out)
        return out, bool(parser.pending) or any(bad.id in IDS for bad in parser.rejected)

    def cut_header(self, rng: random.Random) -> bytes:
        tail = rng.randbytes(rng.randint(0, 3))
        if self.version == 1:
            return bytes([0xFF, 0xFF, ABSENT, rng.randint(2, 250)]) + tail
        length = rng.randint(3, 300)
        return bytes([0xFF, 0xFF, 0xFD, 0x00, ABSENT, length & 0xFF, length >> 8]) + tail

    def bad_checksum(self, rng: random.Random) -> bytes:
        motor_id = rng.choice([*IDS, ABSENT])
        proto = self.proto
        inst = rng.choice([
            proto.ping(motor_id),
            proto.read(motor_id, self.present_address, self.size),
            proto.write(motor_id, self.goal_address,
                        rng.randrange(300, 700).to_bytes(self.size, "little")),
        ])
        packet = bytearray(proto.encode_instruction(inst))
        packet[-1] ^= rng.randint(1, 255)
        return bytes(packet)

    def absurd_length(self, rng: random.Random) -> bytes:
        motor_id = rng.choice([*IDS, ABSENT])
        if self.version == 1:
            return rng.choice([bytes([0xFF, 0xFF, motor_id, rng.randint(0, 1)]),
                               bytes([0xFF, 0xFF, 0xFF, motor_id])]) + rng.randbytes(2)
        length = rng.choice([0xFFFF, 0xFFFE, rng.randint(1025, 0xFFFF), rng.randint(0, 2)])
        return bytes([0xFF, 0xFF, 0xFD, 0x00, motor_id, length & 0xFF, length >> 8]) \
            + rng.randbytes(rng.randint(0, 4))

    def random_bytes(self, rng: random.Random) -> bytes:
        while True:
            data = rng.randbytes(rng.randint(1, 24))
            parser = self.proto.parser()
            if not parser.feed(data):   # no valid packet by chance
                return data


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def fuzz(rig: Rig, rng: random.Random, proc: subprocess.Popen[str]) -> dict[str, int]:
    calls = rig.calls()
    rig.setup()
    recoveries = first_failures = 0
    lost: list[str] = []
    for _ in range(BURSTS):
        for _ in range(rng.randint(1, 3)):           # a healthy bus: every call succeeds
            rng.choice(calls)(rng)
        junk, may_fail = rig.junk(rng)
        rig.port.writePort(junk)
        call = rng.choice(calls)
        # Recovered: the call after the burst succeeds, at the latest the second time (the
        # first may be swallowed by what the junk left; the line was silent since, so the
        # second is a fresh packet).
        for attempt in (1, 2):
            try:
                call(rng)
            except Failed as failure:
                assert may_fail, f"{call.__name__} failed ({failure}) after {junk.hex(' ')}"
                if attempt == 1:
                    first_failures += 1
                else:
                    lost.append(f"{call.__name__} ({failure}) after {junk.hex(' ')}")
            else:
                recoveries += 1
                break
    assert recoveries == BURSTS, f"no recovery from {len(lost)} bursts: {lost}"
    assert first_failures > 0, "no burst ever swallowed a call: the junk tested nothing"
    # The server is alive and does not spin while nobody talks.
    assert proc.poll() is None
    before = cpu_seconds(proc.pid)
    time.sleep(1.0)                                  # the window measured, not a wait
    used = cpu_seconds(proc.pid) - before
    assert used < 0.5, f"servolab sim used {used:.2f} s of CPU in an idle second"
    assert proc.poll() is None
    return {"recoveries": recoveries, "first_failures": first_failures}


def open_port(device: str) -> Any:
    port = sdk.PortHandler(device)
    assert port.openPort()
    assert port.setBaudRate(57600)
    return port


def test_sdk_survives_junk_on_protocol1_rx28(tmp_path: Path) -> None:
    with sim_process("--motors", "rx28:1-3", out_dir=tmp_path) as (device, proc):
        port = open_port(device)
        try:
            fuzz(Rig(1, port, 28, PROTOCOL1), random.Random(1), proc)
        finally:
            port.closePort()


def test_sdk_survives_junk_on_protocol2_xm430(tmp_path: Path) -> None:
    with sim_process("--motors", "xm430-w210:1-3", "--baud", "57600",
                     out_dir=tmp_path) as (device, proc):
        port = open_port(device)
        try:
            rig = Rig(2, port, 1030, PROTOCOL2)
            fuzz(rig, random.Random(2), proc)
            # Broadcast PING after all that: every motor, in its slot.
            found, comm = rig.ph.broadcastPing(port)
            assert comm == sdk.COMM_SUCCESS
            assert sorted(found) == list(IDS)
            assert all(found[i][0] == 1030 for i in IDS)
        finally:
            port.closePort()
