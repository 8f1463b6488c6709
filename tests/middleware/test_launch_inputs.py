"""What a launch file gives a node is checked like everything else it says: a rate of 0 is
refused in one line, as -1 and NaN always were (it was a ZeroDivisionError traceback), and a
node built from a value it cannot use says so in one line quoting little of the value."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from servolab.middleware.context import Context
from servolab.middleware.demo_nodes import HEARD_KEPT, Listener, Talker
from servolab.middleware.errors import LaunchError, ParameterError
from servolab.middleware.launch import load_launch, run_launch
from servolab.middleware.node import Node
from tests.clirun import refusal

DEMO = "servolab.middleware.demo_nodes"


def launch_file(tmp_path: Path, node: str, parameters: str) -> Path:
    path = tmp_path / "robot.launch.yaml"
    path.write_text(textwrap.dedent(f"""\
        nodes:
          - name: talker
            node: {node}
            parameters: {parameters}
        """))
    return path


@pytest.mark.parametrize(("rate", "shown"), [("0.0", "0.0"), ("0", "0.0"), ("-1.0", "-1.0"),
                                             (".nan", "nan"), (".inf", "inf")])
def test_a_talker_rate_that_is_not_a_positive_number_is_refused_in_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], rate: str, shown: str) -> None:
    path = launch_file(tmp_path, f"{DEMO}:Talker", f"{{rate: {rate}}}")
    status, line = refusal(["launch", str(path)], capsys)
    assert status == 2
    assert line == (f"servolab launch: error: {path}:4: node 'talker': key 'parameters': parameter "
                    f"rate: must be a finite number > 0 Hz, not {shown}")


def test_a_negative_count_is_refused(tmp_path: Path) -> None:
    with Context.open() as context, pytest.raises(ParameterError, match="count: must be >= 0"):
        Talker(context, parameter_overrides={"count": -1})


def test_a_long_value_a_node_refuses_is_cut(tmp_path: Path) -> None:
    path = launch_file(tmp_path, f"{DEMO}:Talker", "{rate: '" + "x" * 100_000 + "'}")
    with pytest.raises(LaunchError) as info:
        run_launch(load_launch(path), out=lambda line: None)
    message = str(info.value).replace(str(tmp_path), "")
    assert "\n" not in message and len(message) < 260 and message.endswith("…")


class Divides(Node):
    """A node whose constructor divides by a parameter, as many do: ``1.0 / rate``."""

    def __init__(self, context: Context, name: str = "divides", namespace: str = "/", **kw: object
                 ) -> None:
        super().__init__(context, name, namespace, **kw)  # type: ignore[arg-type]
        self.period = 1.0 / self.declare_parameter("camera_rate", 10.0).value


def test_a_node_dividing_by_a_zero_parameter_is_one_line_not_a_traceback(tmp_path: Path) -> None:
    path = launch_file(tmp_path, f"{__name__}:Divides", "{camera_rate: 0.0}")
    with pytest.raises(LaunchError) as info:
        run_launch(load_launch(path), out=lambda line: None)
    assert str(info.value) == (f"{path}:4: node 'talker': key 'parameters': {__name__}:Divides "
                               "could not be built: ZeroDivisionError: float division by zero "
                               "(is a rate or period 0?)")


def test_the_listener_keeps_the_newest_messages_and_counts_them_all() -> None:
    with Context.open() as context:
        listener = Listener(context)
        for k in range(HEARD_KEPT + 5):
            listener._on_cmd_vel(listener.message("geometry_msgs/msg/Twist", linear={"x": k}))
        assert listener.count == HEARD_KEPT + 5 and len(listener.heard) == HEARD_KEPT
        assert listener.heard[-1].linear.x == HEARD_KEPT + 4
