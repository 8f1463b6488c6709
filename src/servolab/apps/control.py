"""``servolab control``: bring a robot up under ros2_control and manage its controllers, as
``ros2 control`` and ``ros2 run controller_manager spawner`` do.

``run`` brings a robot up (its URDF's ``<ros2_control>`` block, its controllers file) and
serves its controller manager until Ctrl-C; the other verbs reach a running controller manager
from any process through its services and print what ``ros2 control`` prints (without the
colours). The work is :mod:`servolab.robots.control`; this module parses and prints.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from servolab.errors import UsageError

from .arguments import add_namespace, add_transport, positive_float, transport_options
from .registry import Command

if TYPE_CHECKING:
    from servolab.robots.control.bringup import ControlSystem
    from servolab.robots.control.remote import RemoteManager

Say = Callable[[str], None]
VERBS = ("run", "spawner", "list_controllers", "list_controller_types",
         "list_hardware_interfaces", "list_hardware_components", "load_controller",
         "set_controller_state", "switch_controllers", "unload_controller",
         "set_hardware_component_state")


# -- run --------------------------------------------------------------------------------------

def robot_files(robot: str, params: str | None) -> tuple[str, str, Path | None, Any]:
    """(URDF text, its name for errors, the controllers file, the plug-in or None) of
    ``robot``: a URDF file (``.urdf`` or ``.urdf.xacro``) or a robot's name (its URDF and,
    without ``--params``, its own controllers file)."""
    from servolab.robots.control.bringup import load_urdf

    path = Path(robot)
    if path.suffix in (".urdf", ".xacro") or path.is_file():
        if not path.is_file():
            raise UsageError(f"{robot}: no such URDF file")
        return load_urdf(path), str(path), Path(params) if params else None, None
    from servolab.robots.registry import entry

    plugin = entry(robot)
    if plugin.description is None:
        raise UsageError(f"robot {plugin.name} has no URDF, so no <ros2_control> block")
    controllers = Path(params) if params else None
    if controllers is None:
        shown = plugin.shown_files()
        found = [v for k, v in shown.items() if k.endswith(".controllers")
                 and isinstance(v, Path)]
        controllers = found[0] if found else None
    return plugin.description(), f"{plugin.name}.urdf", controllers, plugin


def bring_up(args: argparse.Namespace) -> ControlSystem:
    from servolab.middleware.parameters import ParameterOverrides
    from servolab.robots.control.bringup import BringUpOptions, ControlSystem

    urdf, source, controllers, plugin = robot_files(args.robot, args.params)
    if controllers is None:
        raise UsageError("give the controllers file: --params CONTROLLERS.yaml (a ros2_control "
                         "controllers file: controller_manager: ros__parameters: ...)")
    parameters = ParameterOverrides.from_file(controllers)
    parameters.merge(ParameterOverrides.from_assignments(args.param or []))
    place = None
    if args.world == "robot":
        if plugin is None:
            raise UsageError("--world robot takes a robot's name (its plug-in has the world), "
                             "not a URDF file")
        place = plugin.serve(None).place
    options = BringUpOptions(port=args.port, world=args.world, spawn=tuple(args.spawn),
                             inactive=tuple(args.inactive), namespace=args.namespace,
                             transport=transport_options(args), place=place,
                             default_model=args.model or (plugin.default_model if plugin
                                                          else None))
    return ControlSystem(urdf, source, parameters, options)


def control_run(args: argparse.Namespace, say: Say) -> int:
    from servolab.apps.view import view_request

    request = view_request(args)
    system = bring_up(args)
    server = None
    try:
        manager = system.manager
        where = args.port or {"emulated": "emulated motors", "mujoco": "emulated motors in "
                              "MuJoCo", "robot": "emulated motors in the robot's world"}[args.world]
        say(f"controller manager {manager.get_fully_qualified_name()} at "
            f"{manager.update_rate:g} Hz on {where}")
        for controller in manager.controllers.values():
            say(f"  {controller.name} [{controller.TYPE}] {controller.label}")
        if request is not None:
            from servolab.middleware.view.run_view import serve_run

            server = serve_run(system.context, request, say, name="servolab control")
        say("running; Ctrl-C stops it (the joints hold)")
        with system.context.stop_on_signals():
            system.spin()
        return 128 + system.context.stopped_by if system.context.stopped_by else 0
    finally:
        try:
            if server is not None:
                server.close()
        finally:
            system.close()


# -- the verbs that call a running manager ----------------------------------------------------

def list_controllers(remote: RemoteManager, say: Say, *, verbose: bool = False,
                     claimed: bool = False, required_command: bool = False,
                     required_state: bool = False) -> list[Any]:
    found = remote.list_controllers()
    if not found:
        say("No controllers are currently loaded!")
        return found
    name_w = max(len(c.name) for c in found)
    type_w = max(len(c.type) for c in found)
    state_w = max(len(c.state) for c in found)
    for c in found:
        say(f"{c.name:<{name_w}} {c.type:<{type_w}}  {c.state:<{state_w}}")
        if verbose:
            say(f"\tupdate_rate: {c.update_rate} Hz")
            say(f"\tis_async: {c.is_async}")
        for wanted, title, names in (
                (claimed, "claimed interfaces", c.claimed_interfaces),
                (required_command, "required command interfaces",
                 c.required_command_interfaces),
                (required_state, "required state interfaces", c.required_state_interfaces)):
            if wanted or verbose:
                say(f"\t{title}:")
                for name in names:
                    say(f"\t\t{name}")
    return found


def list_hardware_interfaces(remote: RemoteManager, say: Say, verbose: bool = False) -> Any:
    response = remote.call("list_hardware_interfaces")
    say("command interfaces")
    for i in sorted(response.command_interfaces, key=lambda i: i.name):
        kind = f" [{i.data_type}]" if verbose else ""
        if i.is_available:
            say(f"\t{i.name}{kind} [available] [{'claimed' if i.is_claimed else 'unclaimed'}]")
        else:
            say(f"\t{i.name}{kind} [unavailable] [unclaimed]")
    say("state interfaces")
    for i in sorted(response.state_interfaces, key=lambda i: i.name):
        say(f"\t{i.name}{f' [{i.data_type}]' if verbose else ''}")
    return response


def list_hardware_components(remote: RemoteManager, say: Say, verbose: bool = False) -> Any:
    response = remote.call("list_hardware_components")
    for n, component in enumerate(response.component):
        say(f"Hardware Component {n + 1}")
        say(f"\tname: {component.name}")
        say(f"\ttype: {component.type}")
        say(f"\tplugin name: {component.plugin_name}")
        say(f"\tstate: id={component.state.id} label={component.state.label}")
        say(f"\tread/write rate: {component.rw_rate} Hz")
        say(f"\tis async: {component.is_async}")
        say("\tcommand interfaces")
        for i in component.command_interfaces:
            say(f"\t\t{i.name} [{'available' if i.is_available else 'unavailable'}] "
                f"[{'claimed' if i.is_claimed else 'unclaimed'}]")
        if verbose:
            say("\tstate interfaces")
            for i in component.state_interfaces:
                say(f"\t\t{i.name} [{'available' if i.is_available else 'unavailable'}]")
    return response


def load_controller(remote: RemoteManager, name: str, say: Say,
                    set_state: str | None = None) -> int:
    if any(c.name == name for c in remote.list_controllers()):
        say(f"Controller : {name} already loaded, skipping load_controller!")
    else:
        if not remote.call("load_controller", name=name).ok:
            say(f"Failed loading controller {name} check controller_manager logs")
            return 1
        say(f"Successfully loaded controller {name}")
    if set_state:
        if not remote.call("configure_controller", name=name).ok:
            say(f"Error configuring controller : {name}")
            return 1
        if set_state == "active" and not remote.switch([name], [], 1).ok:
            say(f"Error activating controller : {name}, check controller_manager logs")
            return 1
        say(f"Successfully loaded controller {name} into state {set_state}")
    return 0


def set_controller_state(remote: RemoteManager, name: str, state: str, say: Say) -> int:
    found = [c for c in remote.list_controllers() if c.name == name]
    if not found:
        raise UsageError(f"controller {name} does not seem to be loaded")
    now = found[0].state
    if state == "unconfigured":
        if now != "inactive":
            raise UsageError(f"cannot cleanup {name} from its current state {now}")
        if not remote.call("cleanup_controller", name=name).ok:
            raise UsageError("Error cleaning up controller, check controller_manager logs")
        say(f"successfully cleaned up {name}")
    elif state == "inactive":
        if now == "unconfigured":
            if not remote.call("configure_controller", name=name).ok:
                raise UsageError("Error configuring controller, check controller_manager logs")
            say(f"Successfully configured {name}")
        elif now == "active":
            if not remote.switch([], [name], 1).ok:
                raise UsageError("Error stopping controller, check controller_manager logs")
            say(f"Successfully deactivated {name}")
        else:
            raise UsageError(f"cannot put {name} in 'inactive' state from its current state "
                             f"{now}")
    else:
        if now != "inactive":
            raise UsageError(f"cannot activate {name} from its current state {now}")
        if not remote.switch([name], [], 1).ok:
            raise UsageError("Error activating controller, check controller_manager logs")
        say(f"Successfully activated {name}")
    return 0


def switch_controllers(remote: RemoteManager, say: Say, activate: list[str],
                       deactivate: list[str], strictness: int, asap: bool,
                       timeout: float) -> int:
    response = remote.switch(activate, deactivate, strictness, asap=asap, timeout=timeout)
    say(response.message)
    return 0 if response.ok else 1


def unload_controller(remote: RemoteManager, name: str, say: Say) -> int:
    if not remote.call("unload_controller", name=name).ok:
        say(f"Failed to unload controller {name}, check controller_manager logs")
        return 1
    say(f"Successfully unloaded controller {name}")
    return 0


def set_hardware_component_state(remote: RemoteManager, name: str, state: str,
                                 say: Say) -> int:
    from servolab.robots.control.components import state_id
    from servolab.robots.control.resources import STATE_LABELS

    number = state_id(state)
    if number is None:
        raise UsageError(f"state {state!r}: one of unconfigured, inactive, active, finalized")
    response = remote.call("set_hardware_component_state", name=name,
                           target_state={"id": number, "label": STATE_LABELS[number]})
    if not response.ok:
        say(f"Error setting state of component {name} to {state}, check controller_manager "
            "logs")
        return 1
    say(f"Successfully set component {name} to state {response.state.label}")
    return 0


def spawner(remote: RemoteManager, names: list[str], say: Say, *, inactive: bool = False,
            load_only: bool = False, manager_timeout: float = 0.0,
            activate_as_group: bool = False) -> int:
    """What ``ros2 run controller_manager spawner`` does: each controller loaded (unless it
    is), configured and activated — one by one, or all at once with ``activate_as_group``."""
    if manager_timeout > 0 and not remote.wait(manager_timeout):
        say(f"Controller manager not available: {remote.name} did not answer within "
            f"{manager_timeout:g} s")
        return 1
    loaded = {c.name for c in remote.list_controllers()}
    group: list[str] = []
    for name in names:
        if name in loaded:
            say("Controller already loaded, skipping load_controller")
        else:
            if not remote.call("load_controller", name=name).ok:
                say(f"Failed loading controller {name}")
                return 1
            say(f"Loaded {name}")
        if load_only:
            continue
        if not remote.call("configure_controller", name=name).ok:
            say("Failed to configure controller")
            return 1
        if inactive:
            say(f"Configured {name}")
            continue
        if activate_as_group:
            group.append(name)
            continue
        if not remote.switch([name], [], 2).ok:
            say(f"Failed to activate controller : {name}")
            return 1
        say(f"Configured and activated {name}")
    if group:
        if not remote.switch(group, [], 2).ok:
            say(f"Failed to activate the parsed controllers list : {group}")
            return 1
        say(f"Configured and activated all the parsed controllers list : {group}!")
    return 0


# -- the parser -------------------------------------------------------------------------------

def manager_name(given: str | None, namespace: str) -> str:
    """The controller manager ``-c`` and ``--namespace`` name, as the spawner resolves its
    ``--controller-manager`` in its node's namespace: an absolute name as given, a relative
    one (or the default ``controller_manager``) in ``namespace``."""
    from servolab.middleware.errors import NameValidationError
    from servolab.middleware.names import fully_qualified_name
    from servolab.robots.control.defaults import DEFAULT_MANAGER

    try:
        return fully_qualified_name(given or DEFAULT_MANAGER.lstrip("/"), namespace)
    except NameValidationError as exc:
        raise UsageError(f"-c {given!r}: {exc.reason}") from None


def _manager_options(p: argparse.ArgumentParser) -> None:
    from servolab.robots.control.defaults import CALL_TIMEOUT, DEFAULT_MANAGER

    p.add_argument("-c", "--controller-manager", default=None, metavar="NAME",
                   help=f"the controller manager's node name (default {DEFAULT_MANAGER}; a "
                   "relative name is in --namespace)")
    add_namespace(p, "the robot whose controller manager to reach (the one 'control run "
                  "--namespace' brought up)")
    p.add_argument("--service-call-timeout", type=positive_float, default=CALL_TIMEOUT,
                   metavar="S", help=f"s to wait for each answer (default {CALL_TIMEOUT:g})")
    add_transport(p)


def _add_arguments(parser: argparse.ArgumentParser) -> None:
    verbs = parser.add_subparsers(dest="verb", required=True, metavar="VERB")
    _add_run(verbs)
    _add_verbs(verbs)


def _add_run(verbs: Any) -> None:
    from servolab.apps.view import add_view_flag

    p = verbs.add_parser("run", help="bring a robot up under ros2_control and serve it",
                         description="Bring a robot up from its URDF's <ros2_control> block "
                         "and a controllers file, as a launch file with ros2_control_node and "
                         "spawners does, and serve its controller manager until Ctrl-C.")
    p.add_argument("robot", metavar="ROBOT_OR_URDF",
                   help="a robot's name (servolab robots) or a .urdf / .urdf.xacro file")
    p.add_argument("--params", metavar="CONTROLLERS.yaml",
                   help="the ros2_control controllers file (default: the robot's own)")
    p.add_argument("--spawn", nargs="+", default=[], metavar="NAME",
                   help="controllers to load, configure and activate, in order")
    p.add_argument("--inactive", nargs="+", default=[], metavar="NAME",
                   help="controllers to load and configure only")
    p.add_argument("--port", default=None,
                   help="the robot's serial port or pyserial URL (default: emulated motors); "
                   "'urdf' uses the port its <ros2_control> block names")
    p.add_argument("--world", choices=("emulated", "mujoco", "robot"), default="emulated",
                   help="emulated motors alone; the URDF moved in MuJoCo under them; or the "
                   "robot's own world, as servolab sim --robot serves it (a base on its floor) "
                   "(default: emulated)")
    add_namespace(p, "every node of the robot (controller manager, controllers, "
                  "robot_state_publisher)")
    p.add_argument("--model", default=None, metavar="MODEL",
                   help="the Dynamixel model of motors the URDF names no model for (ROBOTIS's "
                   "dynamixel_hardware_interface files name none), e.g. XM430-W350")
    p.add_argument("-p", "--param", action="append", metavar="NODE:NAME:=VALUE",
                   help="a parameter, as --ros-args -p (e.g. controller_manager:update_rate:=200)")
    add_view_flag(p)
    add_transport(p)


def _add_verbs(verbs: Any) -> None:
    p = verbs.add_parser("spawner", help="load, configure and activate controllers, as ros2 "
                         "run controller_manager spawner")
    p.add_argument("controller_names", nargs="+", metavar="NAME")
    p.add_argument("--inactive", action="store_true",
                   help="load and configure them, do not activate them")
    p.add_argument("--load-only", action="store_true", help="only load them")
    p.add_argument("--activate-as-group", action="store_true",
                   help="activate them together, in one switch")
    p.add_argument("--controller-manager-timeout", type=float, default=10.0, metavar="S",
                   help="s to wait for the controller manager (default 10)")
    _manager_options(p)
    p = verbs.add_parser("list_controllers", help="loaded controllers, their type and state")
    for flag in ("--claimed-interfaces", "--required-command-interfaces",
                 "--required-state-interfaces"):
        p.add_argument(flag, action="store_true")
    p.add_argument("-v", "--verbose", action="store_true")
    _manager_options(p)
    p = verbs.add_parser("list_controller_types", help="the controller types it can load")
    _manager_options(p)
    for verb in ("list_hardware_interfaces", "list_hardware_components"):
        p = verbs.add_parser(verb, help=verb.replace("_", " "))
        p.add_argument("-v", "--verbose", action="store_true")
        _manager_options(p)
    p = verbs.add_parser("load_controller", help="load a controller (and set its state)")
    p.add_argument("controller_name", metavar="NAME")
    p.add_argument("--set-state", choices=("inactive", "active"), default=None)
    _manager_options(p)
    p = verbs.add_parser("set_controller_state", help="configure, activate, deactivate or "
                         "clean up a controller")
    p.add_argument("controller_name", metavar="NAME")
    p.add_argument("state", choices=("unconfigured", "inactive", "active"))
    _manager_options(p)
    p = verbs.add_parser("switch_controllers", help="activate and deactivate controllers in "
                         "one switch")
    p.add_argument("--activate", nargs="*", default=[], metavar="NAME")
    p.add_argument("--deactivate", nargs="*", default=[], metavar="NAME")
    strictness = p.add_mutually_exclusive_group()
    strictness.add_argument("--strict", action="store_true")
    strictness.add_argument("--best-effort", action="store_true")
    p.add_argument("--activate-asap", action="store_true")
    p.add_argument("--switch-timeout", type=positive_float, default=5.0, metavar="S")
    _manager_options(p)
    p = verbs.add_parser("unload_controller", help="unload a controller")
    p.add_argument("controller_name", metavar="NAME")
    _manager_options(p)
    p = verbs.add_parser("set_hardware_component_state", help="configure, activate or "
                         "deactivate a hardware component")
    p.add_argument("component", metavar="NAME")
    p.add_argument("state", metavar="STATE", help="unconfigured, inactive, active, finalized")
    _manager_options(p)


def _run(args: argparse.Namespace) -> int:
    from servolab.middleware.context import Context
    from servolab.robots.control.remote import RemoteManager

    from ._graph import say

    if args.verb == "run":
        return control_run(args, say)
    with Context.open(transport_options(args)) as ctx:
        remote = RemoteManager(ctx, manager_name(args.controller_manager, args.namespace),
                               timeout=args.service_call_timeout)
        if args.verb != "spawner" and not remote.wait(args.service_call_timeout):
            raise UsageError(f"no controller manager {remote.name} answered within "
                             f"{args.service_call_timeout:g} s (start one with: servolab "
                             "control run ROBOT --params CONTROLLERS.yaml)")
        verb = args.verb
        if verb == "spawner":
            return spawner(remote, args.controller_names, say, inactive=args.inactive,
                           load_only=args.load_only,
                           manager_timeout=args.controller_manager_timeout,
                           activate_as_group=args.activate_as_group)
        if verb == "list_controllers":
            list_controllers(remote, say, verbose=args.verbose, claimed=args.claimed_interfaces,
                             required_command=args.required_command_interfaces,
                             required_state=args.required_state_interfaces)
            return 0
        if verb == "list_controller_types":
            response = remote.call("list_controller_types")
            for kind, base in zip(response.types, response.base_classes, strict=True):
                say(f"{kind:<70} {base}")
            return 0
        if verb == "list_hardware_interfaces":
            list_hardware_interfaces(remote, say, args.verbose)
            return 0
        if verb == "list_hardware_components":
            list_hardware_components(remote, say, args.verbose)
            return 0
        if verb == "load_controller":
            return load_controller(remote, args.controller_name, say, args.set_state)
        if verb == "set_controller_state":
            return set_controller_state(remote, args.controller_name, args.state, say)
        if verb == "switch_controllers":
            strictness = 2 if args.strict else 1 if args.best_effort else 0
            return switch_controllers(remote, say, args.activate, args.deactivate, strictness,
                                      args.activate_asap, args.switch_timeout)
        if verb == "unload_controller":
            return unload_controller(remote, args.controller_name, say)
        return set_hardware_component_state(remote, args.component, args.state, say)


COMMAND = Command(
    name="control", group="robots",
    help="ros2_control: bring a robot up from its URDF, list and switch its controllers",
    description="Bring a robot up under ros2_control (a controller manager, the standard "
    "controllers, the hardware its URDF's <ros2_control> block describes) and manage its "
    "controllers from any process, as 'ros2 control' and the spawner do. docs/control.md "
    "walks through it.",
    examples=(
        "servolab control run arm.urdf --params arm_controllers.yaml --spawn "
        "joint_state_broadcaster forward_position_controller",
        "servolab control run turtlebot3_waffle --world robot --namespace /robot1 --spawn "
        "joint_state_broadcaster diff_drive_controller",
        "servolab control list_controllers",
        "servolab control list_controllers --namespace /robot1",
        "servolab control switch_controllers --activate joint_trajectory_controller "
        "--deactivate forward_position_controller",
        "servolab control load_controller joint_trajectory_controller --set-state active",
        "servolab control list_hardware_interfaces"),
    add_arguments=_add_arguments, run=_run)
