"""rclpy programs print the same under the real rclpy and under servolab (issue 32).

Each program of ``tests/rclpy_programs`` (one per program of ros2/examples' ``rclpy`` folder
and of ``demo_nodes_py``, in rclpy's idiom) runs with its partner as separate processes:

- under the real ROS 2 Jazzy rclpy (Fast DDS), whose output is kept in
  ``tests/rclpy_programs/expected/<program>.txt`` and checked again here (slow: it needs the
  oracle's venv, ``make ros-oracle``);
- under servolab with only the import lines rewritten, on each servolab transport between
  processes, which must print exactly those lines.

``SERVOLAB_WRITE_EXPECTED=1`` with the slow test writes the expected files from the real
rclpy's output (once per program: a program that runs in two runs is written by the first).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from tests.rclpy.programs import EXPECTED, RUNS, expected, run, run_id, servolabify

#: Every test here runs two or three interpreters at once, which keeps both cores busy: the
#: wall-clock tests must not run beside them (tests/conftest.py)
pytestmark = pytest.mark.realtime

#: servolab's transports between processes
TRANSPORTS = ["zenoh", "dds"]


def _check(outputs: dict[str, list[str]]) -> None:
    for program, lines in outputs.items():
        assert lines == expected(program), (
            f"{program} printed\n" + "\n".join(lines) + "\nwhere the real rclpy printed\n"
            + "\n".join(expected(program)))


@pytest.mark.parametrize("transport", TRANSPORTS)
@pytest.mark.parametrize("programs", RUNS, ids=run_id)
def test_servolab_prints_what_rclpy_prints(programs: tuple[str, ...], transport: str,
                                           tmp_path: Path) -> None:
    _check(run(programs, transport, tmp_path))


@pytest.mark.slow
@pytest.mark.parametrize("programs", RUNS, ids=run_id)
def test_the_real_rclpy_prints_the_expected_lines(programs: tuple[str, ...],
                                                  tmp_path: Path) -> None:
    outputs = run(programs, "ros", tmp_path)
    if os.environ.get("SERVOLAB_WRITE_EXPECTED"):
        EXPECTED.mkdir(exist_ok=True)
        for program, lines in outputs.items():
            path = EXPECTED / f"{program}.txt"
            if not path.exists():
                path.write_text("".join(f"{line}\n" for line in lines))
    _check(outputs)


#: The pairs where one side calls the other's services: a Fast DDS client gets no answer from
#: a servolab server (docs/middleware.md, "DDS": rmw_fastrtps matches replies by inline QoS,
#: which Cyclone DDS cannot write; tests/middleware/test_dds_rclpy.py shows it), so these run
#: mixed only with the real rclpy serving and servolab calling.
SERVICE_PAIRS = {("service_member_function", "client_async_member_function"),
                 ("service_member_function", "client_async_callback"),
                 ("service_member_function", "client_sync"),
                 ("trigger_server", "trigger_client_async"),
                 ("param_server", "async_param_client")}
#: And the other pairs run mixed with servolab publishing to the real rclpy only: the upstream
#: publishers send their few messages the moment Fast DDS reports a matched subscription,
#: which comes before Cyclone DDS (servolab's side) has discovered the Fast DDS writer and
#: accepts its data, so a volatile message sent then is lost (docs/middleware.md, "DDS").
#: servolab hearing a real rclpy talker that keeps talking is test_dds_rclpy.py's.
#: One pair of each kind (the suite's time is bounded): topics, a service with an async
#: client and with a sync one, parameters over their services, parameter events, sim time.
MIXED = [(programs, ("ros", "dds")) for programs in RUNS if programs in {
    ("listener", "talker"),
    ("service_member_function", "client_async_member_function"),
    ("service_member_function", "client_sync"),
    ("param_server", "async_param_client"),
    ("parameter_events_listener", "parameter_events_talker"),
    ("sim_time_listener", "clock_source")}]


@pytest.mark.slow
@pytest.mark.parametrize(("programs", "sides"), MIXED,
                         ids=[f"{run_id(p)}-{'+'.join(s)}" for p, s in MIXED])
def test_mixed_real_rclpy_and_servolab_print_what_rclpy_prints(
        programs: tuple[str, ...], sides: tuple[str, str], tmp_path: Path) -> None:
    """One program under the real rclpy (Fast DDS), its partner under servolab on DDS: each
    prints what it prints when both are the real rclpy."""
    _check(run(programs, sides, tmp_path))


def test_only_the_import_lines_are_rewritten() -> None:
    """The programs servolab runs differ from rclpy's in their import lines only."""
    for path in sorted(Path(EXPECTED).parent.glob("*.py")):
        source = path.read_text()
        rewritten = servolabify(source)
        changed = [(a, b) for a, b in zip(source.splitlines(), rewritten.splitlines(),
                                          strict=True) if a != b]
        assert changed, f"{path.name}: no import of rclpy rewritten"
        assert all(a.startswith(("import ", "from ")) for a, _ in changed), changed
        assert all("servolab" in b for _, b in changed), changed


def test_every_program_is_run() -> None:
    names = {p.stem for p in Path(EXPECTED).parent.glob("*.py")}
    assert names == {name for programs in RUNS for name in programs}
