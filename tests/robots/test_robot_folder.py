"""Robot folders and plug-ins that cannot be used are refused in one line naming the file and
the element, line or key — before anything moves — and never hide the other robots.

The ``<ros2_control>`` format is ros2_control's (hardware_interface's component_parser:
``<ros2_control name type>``, ``<hardware><plugin>``, ``<param name>``, ``<joint>`` with
``<command_interface>``/``<state_interface>``); the Dynamixel parameter names are those of the
community ``dynamixel_hardware`` (README: ``usb_port``, ``baud_rate``, joint ``id``) and of
ROBOTIS's ``dynamixel_hardware_interface`` (``port_name``, ``motor_type``).
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest

from servolab.cli import main
from servolab.errors import ConfigFileError
from servolab.robots.dynamixel_system import dynamixel_system
from servolab.robots.hardware_info import HardwareInfoError, parse_control_resources
from servolab.robots.registry import RobotPluginError, discover
from tests.clirun import one_line
from tests.robots.adding_a_robot import write_files

ARM = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base_link"/><link name="a"/><link name="b"/><link name="tip"/>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="a"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j2" type="continuous"><parent link="a"/><child link="b"/>
    <axis xyz="0 1 0"/></joint>
  <joint name="tip_joint" type="fixed"><parent link="b"/><child link="tip"/></joint>
  {blocks}
</robot>
"""

BLOCK = """<ros2_control name="arm_hw" type="system">
    <hardware>
      <plugin>dynamixel_hardware/DynamixelHardware</plugin>
      {hardware}
    </hardware>
    {joints}
  </ros2_control>"""


def joint(name: str, *params: str) -> str:
    return (f'<joint name="{name}">' + "".join(params) +
            '<command_interface name="position"><param name="min">-1</param></command_interface>'
            '<state_interface name="position"/><state_interface name="velocity"/></joint>')


def param(name: str, value: object) -> str:
    return f'<param name="{name}">{value}</param>'


def arm(hardware: str = param("usb_port", "/dev/ttyUSB0") + param("baud_rate", 1000000),
        joints: str | None = None) -> str:
    if joints is None:
        joints = (joint("j1", param("id", 1), param("motor_type", "XM430-W350")) +
                  joint("j2", param("id", 2), param("motor_type", "XL430-W250")))
    return ARM.format(blocks=BLOCK.format(hardware=hardware, joints=joints))


def test_a_ros2_control_block_reads_as_ros2_controls_parser_reads_it() -> None:
    (info,) = parse_control_resources(arm(), "arm.urdf")
    assert (info.name, info.type, info.plugin) == ("arm_hw", "system",
                                                  "dynamixel_hardware/DynamixelHardware")
    assert dict(info.hardware_parameters) == {"usb_port": "/dev/ttyUSB0", "baud_rate": "1000000"}
    assert [j.name for j in info.joints] == ["j1", "j2"]
    first = info.joints[0]
    assert dict(first.parameters) == {"id": "1", "motor_type": "XM430-W350"}
    assert [(i.name, dict(i.parameters)) for i in first.command_interfaces] == [
        ("position", {"min": "-1"})]
    assert [i.name for i in first.state_interfaces] == ["position", "velocity"]
    assert parse_control_resources(ARM.format(blocks=""), "none.urdf") == ()


def test_the_dynamixel_bus_of_a_block() -> None:
    system = dynamixel_system(arm(), "arm.urdf")
    assert (system.port_name, system.baudrate, system.protocol) == ("/dev/ttyUSB0", 1000000, 2)
    assert [(j.name, j.id, j.model.name, j.lower, j.upper) for j in system.joints] == [
        ("j1", 1, "XM430-W350", -1.0, 1.0), ("j2", 2, "XL430-W250", None, None)]
    assert str(system.bus()) == ("1 x XM430-W350 (ID 1) + 1 x XL430-W250 (ID 2), Protocol 2.0, "
                                 "1000000 bps")
    # ROBOTIS's spelling; no baud rate: the first model's factory rate (e-Manual, XM430-W350
    # Baud Rate(8): default 1, 57600 bps)
    robotis = dynamixel_system(arm(hardware=param("port_name", "/dev/ttyACM0")), "arm.urdf")
    assert (robotis.port_name, robotis.baudrate) == ("/dev/ttyACM0", 57600)


@pytest.mark.parametrize(("urdf", "message"), [
    ("<robot", r"^arm\.urdf: not XML \("),
    ("<sdf/>", r"^arm\.urdf: the root element is <sdf>, not <robot>$"),
    (arm().replace('type="system"', 'type="robot"'),
     r"""^arm\.urdf: <ros2_control name="arm_hw">: type 'robot' is not one of system, """),
    (arm().replace("<plugin>dynamixel_hardware/DynamixelHardware</plugin>", ""),
     r"""^arm\.urdf: <ros2_control name="arm_hw"> <hardware>: no <plugin> element$"""),
    (arm().replace("dynamixel_hardware/DynamixelHardware", "mock_components/GenericSystem"),
     r"^arm\.urdf: no <ros2_control> block with a Dynamixel hardware plugin \(plugins: "
     r"mock_components/GenericSystem\)"),
    (arm(hardware=param("baud_rate", 1) + param("baud_rate", 2)),
     r"""<hardware>: <param name="baud_rate"> is given twice$"""),
    (arm(hardware=param("usb_port", "a") + param("port_name", "b")),
     r"<hardware>: give one of the parameters port_name or usb_port$"),
    (arm(hardware=param("baud_rate", "fast")), r"<hardware>: baud rate 'fast' is not an integer"),
    (arm(joints=joint("j9", param("id", 1))),
     r"""<joint name="j9">: the URDF has no <joint> of that name$"""),
    (arm(joints=joint("tip_joint", param("id", 1))),
     r"""<joint name="tip_joint">: a fixed joint cannot be driven"""),
    (arm(joints=joint("j1", param("motor_type", "XM430-W350"))),
     r"""<joint name="j1">: no Dynamixel ID; add <param name="id">1</param> \(or give the """
     r"""motors as <gpio> elements with type dxl and ID, as dynamixel_hardware_interface """
     r"""does\)$"""),
    (arm(joints=joint("j1", param("id", 300), param("model", "XM430-W350"))),
     r"""<joint name="j1">: ID 300 is outside 0\.\.252$"""),
    (arm(joints=joint("j1", param("id", 1))),
     r"""<joint name="j1">: no Dynamixel model; add <param name="motor_type">"""),
    (arm(joints=joint("j1", param("id", 1), param("motor_type", "XM430-W305"))),
     r"""<joint name="j1">: unknown Dynamixel model 'XM430-W305' \(did you mean 'XM430-W350'"""),
    (arm(joints=joint("j1", param("id", 3), param("motor_type", "XM430-W350")) +
         joint("j2", param("id", 3), param("motor_type", "XM430-W350"))),
     r"""<ros2_control name="arm_hw">: ID 3 drives j1 and j2$"""),
    (arm(joints=joint("j1", param("id", 1), param("motor_type", "XM430-W350")) +
         joint("j2", param("id", 2), param("motor_type", "RX-28"))),
     r"its models speak Protocol 1\.0 and 2\.0 \(RX-28, XM430-W350\)"),
])
def test_a_block_servolab_cannot_drive_is_one_line_naming_the_element(urdf: str,
                                                                       message: str) -> None:
    with pytest.raises(HardwareInfoError, match=message) as caught:
        dynamixel_system(urdf, "arm.urdf")
    one_line(caught, "arm.urdf")


@pytest.fixture
def robot_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """docs/layout.md's pan_tilt folder in a robot path of the test's own."""
    write_files(tmp_path, "robots/")
    monkeypatch.setenv("SERVOLAB_ROBOT_PATH", str(tmp_path / "robots"))
    return tmp_path / "robots"


def test_a_bad_robot_yaml_names_its_line_and_the_others_are_still_found(
        robot_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    broken = robot_path / "broken"
    broken.mkdir()
    (broken / "broken.urdf").write_text(arm())
    (broken / "robot.yaml").write_text("summary: mine\non_stpo: hold\n")
    found = discover()
    assert "pan_tilt" in found.plugins and "armstrong" in found.plugins
    assert found.problems["broken"].startswith(
        f"robot folder {broken}: {broken / 'robot.yaml'}:2: unknown key 'on_stpo'")
    with pytest.raises(RobotPluginError, match="on_stpo"):
        found.entry("broken")
    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    assert "pan_tilt: a pan-tilt head" in out and "broken: cannot be loaded: " in out


def test_a_controllers_file_naming_a_joint_the_urdf_lacks_names_its_line(
        robot_path: Path) -> None:
    controllers = robot_path / "pan_tilt" / "controllers.yaml"
    controllers.write_text(controllers.read_text().replace("joints: [pan, tilt]",
                                                           "joints: [pan, roll]"))
    line = controllers.read_text().splitlines().index("    joints: [pan, roll]") + 1
    plugin = discover().entry("pan_tilt")
    with pytest.raises(ConfigFileError, match=rf"^{controllers}:{line}: joint 'roll' is not in the "
                       r"URDF \(its joints: pan, tilt\)$"):
        plugin.load()


def test_two_urdfs_without_robot_yaml_ask_which(robot_path: Path) -> None:
    (robot_path / "pan_tilt" / "robot.yaml").unlink()
    (robot_path / "pan_tilt" / "other.urdf").write_text(arm())
    problem = discover().problems["pan_tilt"]
    assert problem.endswith("holds 2 URDFs (other.urdf, pan_tilt.urdf); name one in robot.yaml")


def test_a_folder_taking_a_shipped_robots_name_is_refused_and_the_shipped_one_kept(
        robot_path: Path) -> None:
    (robot_path / "pan_tilt").rename(robot_path / "armstrong")
    found = discover()
    assert found.plugins["armstrong"].origin == "servolab"
    folder = robot_path / "armstrong"
    assert found.problems["armstrong"] == (f"robot 'armstrong' from folder {folder}: the name is "
                                           "taken by servolab; rename one of them")


def test_a_xacro_folder_expands_with_its_arguments(tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """ROS's own xacro expands the description: a property, an argument from robot.yaml."""
    folder = tmp_path / "robots" / "xarm"
    folder.mkdir(parents=True)
    xacro = arm(hardware=param("usb_port", "$(arg port)") + param("baud_rate", "${baud}"))
    xacro = xacro.replace('<robot name="arm">', '<robot name="arm" '
                          'xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
                          '  <xacro:arg name="port" default="/dev/ttyUSB0"/>\n'
                          '  <xacro:property name="baud" value="4000000"/>')
    (folder / "xarm.urdf.xacro").write_text(xacro)
    (folder / "robot.yaml").write_text("xacro_args: {port: /dev/ttyACM3}\n")
    monkeypatch.setenv("SERVOLAB_ROBOT_PATH", str(tmp_path / "robots"))
    plugin = discover().entry("xarm")
    assert plugin.description is not None
    system = dynamixel_system(plugin.description(), "xarm")
    assert (system.port_name, system.baudrate) == ("/dev/ttyACM3", 4000000)
    (folder / "xarm.urdf.xacro").write_text(xacro.replace("${baud}", "${missing}"))
    with pytest.raises(ValueError, match=r"xarm\.urdf\.xacro: xacro could not expand it \("
                       r".*missing"):
        plugin.description()


def test_a_broken_entry_point_is_one_line_and_hides_no_robot(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """An installed package whose entry point cannot be imported (its dist-info, as pip
    writes it, names a module that is not there)."""
    info = tmp_path / "site" / "broken_robots-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: broken-robots\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(textwrap.dedent("""\
        [servolab.robots]
        gone = broken_robots.arm:PLUGIN
        """))
    monkeypatch.syspath_prepend(str(tmp_path / "site"))
    found = discover({})
    assert "armstrong" in found.plugins and "gone" not in found.plugins
    assert found.problems["gone"] == ("entry point gone = 'broken_robots.arm:PLUGIN' "
                                      "(servolab.robots): ModuleNotFoundError: No module named "
                                      "'broken_robots'")


@pytest.mark.parametrize(("urdf", "controllers", "said"), [
    ("<robot name='arm'>", None, "not XML"),
    (ARM.format(blocks=""), None, "no <ros2_control>"),
    (arm(), "controller_manager:\n  ros__parameters: {}\nc:\n  ros__parameters:\n"
            "    joints: [roll]\n", "joint 'roll' is not in the URDF"),
], ids=["not-xml", "no-block", "controllers-joint"])
def test_a_robot_whose_description_is_broken_hides_no_other(
        robot_path: Path, capsys: pytest.CaptureFixture[str], urdf: str,
        controllers: str | None, said: str) -> None:
    """A folder is found by its files; its URDF and controllers file are read when the robot
    is listed, shown or opened. One that does not parse is listed as 'cannot be loaded' with
    its error, and every other robot is listed, shown and laid out as before."""
    broken = robot_path / "a_broken"   # listed before pan_tilt
    broken.mkdir()
    (broken / "a_broken.urdf").write_text(urdf)
    if controllers is not None:
        (broken / "controllers.yaml").write_text(controllers)
    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    assert "pan_tilt: a pan-tilt head" in out and "armstrong:" in out
    (line,) = [x for x in out.splitlines() if x.startswith("a_broken: ")]
    assert line.startswith("a_broken: cannot be loaded: ") and said in line, line
    assert main(["robots", "show", "pan_tilt.urdf"]) == 0
    assert capsys.readouterr().out == (robot_path / "pan_tilt" / "pan_tilt.urdf").read_text()
    from servolab.robots.registry import layout_named, layouts

    assert {"pan_tilt", "armstrong"} <= set(layouts())
    with pytest.raises(ValueError, match=said.replace("(", r"\(")):
        layout_named("a_broken")


def test_a_folder_named_twice_on_the_path_is_one_robot(robot_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    import os

    monkeypatch.setenv("SERVOLAB_ROBOT_PATH",
                       os.pathsep.join([str(robot_path), f"{robot_path}/", str(robot_path)]))
    found = discover()
    assert "pan_tilt" in found.plugins and "pan_tilt" not in found.problems
