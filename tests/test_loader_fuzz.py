"""The loaders of a user's files under random and mutated input: a motion CSV, a ROS 2
parameter file, a launch file. Whatever the bytes, the result is either what was parsed or
the project's one-line error (a :class:`~servolab.errors.ServolabError`), quoting at most a
few lines' worth of the file; never another exception, never a traceback.

Inputs are valid files cut, spliced and sprinkled with the characters each format cares
about (separators, quotes, brackets, tabs, line ends, bytes that are not UTF-8), and plain
random text."""

from __future__ import annotations

import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from servolab.errors import ServolabError
from servolab.gait.motionfile import MotionFile, read_motion_file
from servolab.limits import InputLimits
from servolab.middleware.launch_file import LaunchFile, load_launch
from servolab.middleware.parameters import ParameterOverrides
from tests.fuzzing import fuzzing

pytestmark = pytest.mark.fuzz

MOTION = b"m11,m12,m13\n0,1.5,-2\n3e1,+4,.5\n-27.666,0,1\n"
PARAMETERS = (b"talker:\n  ros__parameters:\n    rate: 4.5\n    names: [a, b]\n"
              b"    camera: {width: 640}\n/**:\n  ros__parameters: {use_sim_time: true}\n")
LAUNCH = (b"transport: zenoh\nzenoh: {listen: [tcp/127.0.0.1:7447]}\n"
          b"machines:\n  pc: {address: localhost, default: true}\n"
          b"nodes:\n  - name: talker\n    node: servolab.middleware.demo_nodes:Talker\n"
          b"    parameters: {rate: 10.0, camera: {width: 640}}\n"
          b"    remappings: {cmd_vel: /turtle/cmd_vel}\n    required: true\n"
          b"  - {name: rec, exec: [servolab, bag, record, -o, rec]}\n")
#: what the formats care about, and what they should refuse
SPICE = [b",", b";", b"\t", b"\n", b"\r\n", b"\r", b'"', b"'", b":", b": ", b"- ", b"[", b"]",
         b"{", b"}", b"#", b"&a", b"*a", b"!!int ", b"!x!", b"<<: ", b"\\", b"\xff", b"\x00",
         b"\xef\xbb\xbf", b"nan", b"1e999", b"x" * 300, b"ros__parameters", b"nodes",
         b"$(zenoh_endpoint)", b"\xe2\x80\xa6"]


@st.composite
def mutated(draw: st.DrawFn, valid: bytes) -> bytes:
    """``valid`` with a few cuts, splices and insertions, or random bytes."""
    if draw(st.integers(0, 9)) == 0:
        return draw(st.binary(max_size=300))
    data = bytearray(valid)
    for _ in range(draw(st.integers(1, 4))):
        at = draw(st.integers(0, len(data)))
        action = draw(st.integers(0, 3))
        if action == 0:
            data[at:at] = draw(st.sampled_from(SPICE))
        elif action == 1:
            data[at:at + draw(st.integers(1, 20))] = b""
        elif action == 2:
            data[at:at] = draw(st.text(max_size=12)).encode()
        else:
            start = draw(st.integers(0, len(data)))
            data[at:at] = data[start:start + draw(st.integers(1, 30))]
    return bytes(data)


def check(load: Callable[[Path], object], data: bytes, name: str) -> object:
    """``load`` on ``data`` written to a file: a result, or a one-line ServolabError."""
    with tempfile.TemporaryDirectory(prefix="servolab-fuzz-") as folder:
        path = Path(folder) / name
        path.write_bytes(data)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a headerless motion file warns, and is read
                return load(path)
        except ServolabError as error:
            text = str(error)
            assert "\n" not in text, text
            assert len(text.replace(folder, "")) < 600, text
            return error


@pytest.mark.fuzz
@fuzzing(100)
@given(mutated(MOTION))
def test_the_motion_file_reader_parses_or_refuses_in_one_line(data: bytes) -> None:
    result = check(lambda p: read_motion_file(p, input_limits=InputLimits(motion_rows=50)),
                   data, "walk.csv")
    assert isinstance(result, MotionFile | ServolabError)


@pytest.mark.fuzz
@fuzzing(100)
@given(mutated(PARAMETERS))
def test_the_parameter_file_reader_parses_or_refuses_in_one_line(data: bytes) -> None:
    result = check(ParameterOverrides.from_file, data, "params.yaml")
    assert isinstance(result, ParameterOverrides | ServolabError)


@pytest.mark.fuzz
@fuzzing(100)
@given(mutated(LAUNCH))
def test_the_launch_file_reader_parses_or_refuses_in_one_line(data: bytes) -> None:
    result = check(load_launch, data, "robot.launch.yaml")
    assert isinstance(result, LaunchFile | ServolabError)
