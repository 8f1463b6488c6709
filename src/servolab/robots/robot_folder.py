"""A robot made of data only: a folder whose name is the robot's, holding

- its URDF (``*.urdf``, or ``*.urdf.xacro`` run through ROS's own ``xacro``), whose
  ``<ros2_control>`` block names each joint's Dynamixel ID and model (:mod:`.dynamixel_system`);
- its controllers file (``controllers.yaml`` or ``*_controllers.yaml``: the ros2_control
  controllers YAML a ROS 2 lab already has; its joints are checked against the URDF);
- optionally an arm's MoveIt ``*.srdf`` and ``joint_limits.yaml`` (``servolab arm`` reads its
  tool link, home and gripper states, and its acceleration and jerk limits there);
- optionally ``robot.yaml``, a few lines of metadata::

      summary: a two-joint XM430 arm          # the line servolab robots prints
      urdf: arm.urdf.xacro                     # when the folder holds several
      controllers: arm_controllers.yaml
      on_stop: hold                            # or torque_off
      default_model: XM430-W350                # for joints whose block names no motor_type
      xacro_args: {prefix: ""}                 # xacro's name:=value arguments
      aliases: [arm]

Put the folder inside a folder named by ``SERVOLAB_ROBOT_PATH`` and ``servolab robots`` lists it,
``servolab.robots.load(NAME)`` opens it, ``servolab sim --robot NAME --pty`` serves it — with
no Python written. Errors name the file, line and key (robot.yaml, the controllers file) or the
file and element (the URDF).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from ..configfile import ConfigMapping, ConfigValue
from ..configfile import load as load_yaml
from ..errors import ConfigFileError
from ..limits import InputLimits, read_limited, too_big
from .errors import RobotValueError
from .plugin import RobotPlugin, ShownFile
from .urdf_robot import ON_STOP, urdf_plugin

#: the metadata file's name
METADATA = "robot.yaml"
_METADATA_KEYS = ("summary", "urdf", "controllers", "on_stop", "default_model", "xacro_args",
                  "aliases")


class RobotFolderError(ConfigFileError):
    """A robot folder's file that cannot be used (robot.yaml, the controllers file)."""


class RobotDescriptionError(RobotValueError):
    """A robot folder's URDF that cannot be read or expanded."""


def urdf_files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir()
                  if p.is_file() and (p.name.endswith(".urdf") or p.name.endswith(".urdf.xacro")))


def controllers_files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.is_file() and
                  (p.name == "controllers.yaml" or p.name.endswith("_controllers.yaml")))


def is_robot_folder(path: Path) -> bool:
    """A folder holding a URDF or a robot.yaml (a robot.yaml without its URDF is then
    reported, not skipped)."""
    return path.is_dir() and (bool(urdf_files(path)) or (path / METADATA).is_file())


@dataclass(frozen=True)
class FolderMetadata:
    """robot.yaml, with what the folder itself says where robot.yaml is silent."""

    summary: str
    urdf: Path
    controllers: Path | None
    on_stop: str = "hold"
    default_model: str | None = None
    xacro_args: Mapping[str, str] = field(default_factory=dict)
    aliases: tuple[str, ...] = ()


def _file(folder: Path, value: ConfigValue | None, found: list[Path], what: str,
          required: bool) -> Path | None:
    if value is not None:
        path = folder / value.as_str(nonempty=True)
        if not path.is_file():
            raise value.error(f"no {what} {path.name!r} in {folder}")
        return path
    if len(found) > 1:
        raise RobotFolderError(folder / METADATA, 0, "", f"{folder} holds {len(found)} "
                               f"{what}s ({', '.join(p.name for p in found)}); name one in "
                               f"{METADATA}")
    if not found and required:
        raise RobotFolderError(folder, 0, "", f"no {what} (a *.urdf or *.urdf.xacro file)")
    return found[0] if found else None


def read_metadata(folder: Path) -> FolderMetadata:
    """The folder's robot.yaml (if any) and files, checked."""
    meta: ConfigMapping | None = None
    if (folder / METADATA).is_file():
        top = load_yaml(folder / METADATA, what="robot metadata", error=RobotFolderError)
        meta = top.as_mapping("robot metadata") if top.plain() is not None else None
        if meta is not None:
            meta.check_keys(_METADATA_KEYS)
    get = meta.get if meta is not None else (lambda _key: None)
    urdf = _file(folder, get("urdf"), urdf_files(folder), "URDF", required=True)
    assert urdf is not None
    controllers = _file(folder, get("controllers"), controllers_files(folder),
                        "controllers file", required=False)
    on_stop = get("on_stop")
    if on_stop is not None and on_stop.as_str() not in ON_STOP:
        raise on_stop.error(f"on_stop {on_stop.as_str()!r}: one of {', '.join(ON_STOP)}")
    summary = get("summary")
    default_model = get("default_model")
    args = get("xacro_args")
    aliases = get("aliases")
    return FolderMetadata(
        summary.as_str(nonempty=True) if summary is not None
        else f"a robot folder ({urdf.name}{f', {controllers.name}' if controllers else ''})",
        urdf, controllers, on_stop.as_str() if on_stop is not None else "hold",
        default_model.as_str(nonempty=True) if default_model is not None else None,
        {k: str(v.plain()) for k, v in args.as_mapping("xacro arguments").items()}
        if args is not None else {},
        tuple(aliases.as_strings(nonempty=True)) if aliases is not None else ())


def urdf_text(path: Path, xacro_args: Mapping[str, str] | None = None, *,
              limits: InputLimits | None = None) -> str:
    """The URDF in ``path``: read, or expanded by ``xacro`` (ROS's own, from the package
    index) when its name ends in ``.xacro``, with ``xacro_args`` as its ``name:=value``s.
    A file over the URDF limit (:mod:`servolab.limits`, ``SERVOLAB_MAX_URDF_MB``) is refused
    before it is read (what xacro makes is checked again, by :func:`.description.read_urdf`)."""
    limits = InputLimits.current() if limits is None else limits

    def too_large(message: str) -> RobotDescriptionError:
        return RobotDescriptionError(f"{path}: {message}")

    if not path.name.endswith(".xacro"):
        try:
            return read_limited(path, "urdf_mb", "URDF", too_large, limits).decode("utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise RobotDescriptionError(f"{path}: cannot read the URDF ({exc})") from None
    if (message := too_big(path, "urdf_mb", "URDF", limits)) is not None:
        raise too_large(message)
    import xacro

    try:
        document = xacro.process_file(str(path), mappings=dict(xacro_args or {}))
    except Exception as exc:  # xacro raises its own XacroException, and XML and OS errors
        message = " ".join(str(exc).split()) or type(exc).__name__
        raise RobotDescriptionError(f"{path}: xacro could not expand it ({message})") from None
    return str(document.toxml())


def check_controllers(path: Path, joints: set[str]) -> None:
    """The controllers file is a ros2_control controllers YAML whose controllers name only
    joints the URDF has (``ros__parameters.joints``, ``joint``, ``left/right_wheel_names``)."""
    top = load_yaml(path, what="controllers file", error=RobotFolderError)
    mapping = top.as_mapping("a controllers file (controller_manager: ros__parameters: ...)")
    if mapping.get("controller_manager") is None:
        raise RobotFolderError(path, top.line, "", "no controller_manager: a ros2_control "
                               "controllers file names its controllers under "
                               "controller_manager: ros__parameters:")
    for name, controller in mapping.items():
        parameters = controller.as_mapping(name).get("ros__parameters")
        if parameters is None:
            continue
        for key in ("joints", "joint", "left_wheel_names", "right_wheel_names"):
            value = parameters.as_mapping("ros__parameters").get(key)
            if value is None:
                continue
            for joint in value.one_or_many():
                if joint.as_str() not in joints:
                    raise joint.error(f"joint {joint.as_str()!r} is not in the URDF (its joints: "
                                      f"{', '.join(sorted(joints))})")


def folder_plugin(folder: Path) -> RobotPlugin:
    """The robot of ``folder`` (named after it), as a plug-in."""
    meta = read_metadata(folder)

    def urdf() -> str:
        text = urdf_text(meta.urdf, meta.xacro_args)
        if meta.controllers is not None:
            from .hardware_info import parse_control_resources

            parse_control_resources(text, str(meta.urdf))  # XML, before the joints are read
            import xml.etree.ElementTree as ET

            check_controllers(meta.controllers, {j.get("name", "") for j in
                                                 ET.fromstring(text).findall("joint")})
        return text

    def files() -> Mapping[str, ShownFile]:
        shown: dict[str, ShownFile] = {}
        if meta.controllers:
            shown[f"{folder.name}.controllers"] = meta.controllers
        # MoveIt's two files, when the folder has them: what servolab arm reads of an arm
        srdf = sorted(folder.glob("*.srdf"))
        if len(srdf) == 1:
            shown[f"{folder.name}.srdf"] = srdf[0]
        if (folder / "joint_limits.yaml").is_file():
            shown[f"{folder.name}.joint_limits"] = folder / "joint_limits.yaml"
        return shown

    config = folder / METADATA if (folder / METADATA).is_file() else meta.urdf
    return urdf_plugin(folder.name, meta.summary, urdf, source=str(meta.urdf),
                       config=lambda: config, files=files, default_model=meta.default_model,
                       on_stop=meta.on_stop, aliases=meta.aliases)
