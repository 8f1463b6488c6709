"""``emu://`` opens emulated motors the way pyserial opens its test ports: by URL, through the
same ``Bus.open`` and the same driver code as a serial port."""

from __future__ import annotations

from pathlib import Path

import pytest

from servolab.dynamixel import Bus, MemoryPort
from servolab.dynamixel.errors import ConfigError, NoResponse
from servolab.dynamixel.motorspec import parse_short
from servolab.sim import Simulation, emulated_port


def test_url_opens_the_spec_at_the_ports_baud_in_a_simulation_of_its_own() -> None:
    bus = Bus.open("emu://rx28:11-13", baudrate=57142)
    assert isinstance(bus.port, MemoryPort) and isinstance(bus.port.clock, Simulation)
    assert bus.proto.version == 1                       # the models' protocol
    assert [m.id for m in bus.emulator.motors] == [11, 12, 13]
    assert {m.baudrate for m in bus.emulator.motors} == {57142}
    assert [r.id for r in bus.scan(range(20))] == [11, 12, 13]
    other = Bus.open("emu://rx28:11-13", baudrate=57142)
    assert other.port.clock is not bus.port.clock       # separate buses, separate times


def test_the_same_session_through_url_and_through_a_spec_object() -> None:
    """``Bus.open("emu://...")`` and a port built from the same MotorSpec answer alike, byte
    for byte and in the same time."""
    def session(bus: Bus) -> tuple[object, ...]:
        bus.write(2, "torque_enable", 1)
        bus.write(2, {"goal_position": 0.5, "moving_speed": 1.0})
        bus.port.clock.advance(0.3)
        return (bus.read(2, ["present_position", "present_speed"], raw=True),
                bus.port.clock.now(), bus.stats)

    by_url = session(Bus.open("emu://rx28:1-3", baudrate=1_000_000))
    spec = parse_short("rx28:1-3", baudrate=1_000_000)
    by_spec = session(Bus(emulated_port(spec)))
    assert by_url == by_spec


def test_buses_share_a_simulation_when_given_one() -> None:
    sim = Simulation()
    a = Bus.open("emu://xm430-w210:1", baudrate=1_000_000, simulation=sim)
    b = Bus.open("emu://rx28:5", baudrate=57142, simulation=sim)
    assert a.port.clock is sim and b.port.clock is sim
    assert sim.emulators == [a.emulator, b.emulator]
    a.ping(1)
    t = sim.now()
    b.ping(5)
    assert sim.now() > t                    # one clock: the second bus's wire time adds on


def test_motors_at_another_baud_stay_silent() -> None:
    bus = Bus.open("emu://xm430-w210:1?baud=57600", baudrate=1_000_000, retries=0)
    with pytest.raises(NoResponse, match="motor 1"):
        bus.ping(1)
    assert bus.emulator.motor(1).baudrate == 57600


def test_faults_from_the_url() -> None:
    bus = Bus.open("emu://rx28:1?drop_rate=1&seed=3", baudrate=57142, retries=0)
    assert bus.emulator.faults.drop_rate == 1.0 and bus.emulator.faults.seed == 3
    with pytest.raises(NoResponse):
        bus.ping(1)


def test_a_yaml_spec_by_path(tmp_path: Path) -> None:
    spec = tmp_path / "legs.yaml"
    spec.write_text("motors:\n  - {model: RX-28, ids: 11-12}\n  - {model: RX-28, id: 21, "
                    "position: 0.5}\n")
    bus = Bus.open(f"emu://{spec}", baudrate=57142)
    assert [m.id for m in bus.emulator.motors] == [11, 12, 21]
    assert bus.read(21, "present_position") == pytest.approx(0.5, abs=0.006)


@pytest.mark.parametrize(("url", "message"), [
    ("emu://", "name the motors"),
    ("emu://rx28:1?speed=3", "unknown option 'speed'"),
    ("emu://rx28:1?drop_rate=lots", "drop_rate='lots' is not a number"),
    ("emu://rx28:1?baud=fast", "baud='fast' is not a whole number"),
    ("emu://rx99:1", "unknown Dynamixel model 'rx99'"),
    ("emu://rx28:1?drop_rate=2", "not a probability"),
    ("tcp://robot:7", "unknown scheme 'tcp'"),
])
def test_bad_urls_are_one_line_errors(url: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message) as info:
        Bus.open(url, baudrate=57142)
    assert "\n" not in str(info.value)


def test_which_baud_rate_the_motors_and_the_port_run_at(tmp_path: Path) -> None:
    """The motors: the URL's baud, else the file's, else the port's, else the factory rate;
    the port: the rate given, else the motors'."""
    spec = tmp_path / "ex.yaml"
    spec.write_text("baudrate: 1000000\nmotors:\n  - {model: EX-106+, ids: 1-2}\n")
    bus = Bus.open(f"emu://{spec}")                              # the file's rate, both ends
    assert (bus.baudrate, bus.emulator.motor(1).baudrate) == (1_000_000, 1_000_000)
    assert bus.ping(1).model_name == "EX-106+"
    bus = Bus.open(f"emu://{spec}?baud=57142")                   # the URL beats the file
    assert (bus.baudrate, bus.emulator.motor(2).baudrate) == (57142, 57142)
    bus = Bus.open("emu://rx28:1")                               # factory rate, both ends
    assert (bus.baudrate, bus.emulator.motor(1).baudrate) == (57142, 57142)
    assert bus.ping(1).model_name == "RX-28"
    assert Bus(emulated_port("xm430-w210:1")).ping(1).model_name == "XM430-W210"
    bus = Bus.open(f"emu://{spec}", baudrate=57600, retries=0)   # the file's motors, another
    with pytest.raises(NoResponse):                              # port rate: silence, as on
        bus.ping(1)                                              # a real wire


@pytest.mark.parametrize(("url", "message"), [
    ("emu://rx28:1?baud=57142&baud=1000000", "given twice"),
    ("emu://rx28:1?delay=nan", "not a finite time"),
    ("emu://rx28:1?baud=4000000", "not a baud rate this model can use"),
    ("emu://rx28:1?drop_rate", "KEY=VALUE"),
])
def test_more_bad_urls(url: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        Bus.open(url)


def test_a_second_port_to_a_bus_in_the_simulation() -> None:
    from servolab.sim import DiffDriveFloor, port_to

    sim = Simulation()
    DiffDriveFloor.example(sim)
    bus = Bus(port_to(sim.emulators[0], sim, 1_000_000))
    assert bus.proto.version == 2 and bus.ping(2).model_name == "XM430-W210"
    with pytest.raises(ConfigError, match="not in the simulation"):
        port_to(sim.emulators[0], Simulation(), 1_000_000)
