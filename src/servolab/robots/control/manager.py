"""The ``controller_manager`` node, as ros2_control's (Jazzy) runs it.

One update loop at ``update_rate`` (Hz, default 100): read every configured hardware
component, update every active controller (each at its own ``update_rate`` when slower),
write every active component. The loop is background work of the node's executor
(:mod:`servolab.middleware.executor`): messages and service calls run between two updates and
never inside one, so a controller's command is taken at the next update and a switch happens
between updates, as ros2_control's realtime loop switches.

Its services, with controller_manager_msgs' types, under ``~/``: ``list_controllers``,
``list_controller_types``, ``list_hardware_interfaces``, ``list_hardware_components``,
``load_controller``, ``configure_controller``, ``cleanup_controller``, ``switch_controller``,
``unload_controller``, ``set_hardware_component_state``. Their checks and messages are the
original's (``controller_manager.cpp``), so ``ros2 control`` and its spawner read them as
they read ros2_control's: a command interface claimed by an active controller is refused
with "Unable to activate controller 'B' since the command interface 'j1/position' is
currently claimed by another controller."

A hardware read or write that fails sends its component to ``unconfigured`` and deactivates
the controllers using its interfaces (with ros2_control's two error lines); a Dynamixel keeps
its last goal, so the joints hold.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from ...middleware.node import Node
from ...middleware.parameters import STRING_ARRAY
from .components import Components, state_id
from .controller import ALL, INDIVIDUAL, ControllerError, ControllerInterface
from .hardware import SystemInterface
from .resources import ACTIVE, INACTIVE, STATE_LABELS, UNCONFIGURED
from .types import standard_types

if TYPE_CHECKING:
    from ...middleware.context import Context

SRV = "controller_manager_msgs/srv/"
#: SwitchController strictness values (controller_manager_msgs/srv/SwitchController)
BEST_EFFORT, STRICT, AUTO, FORCE_AUTO = 1, 2, 3, 4
#: updates whose timing :attr:`ControllerManager.achieved_rate` averages
RATE_WINDOW = 200


class ControllerManager(Node):
    """See the module docstring. ``hardware`` are the components (loaded and brought to their
    initial state here: active unless ``hardware_components_initial_state`` says otherwise);
    ``types`` the controller types it can load (default: :func:`.types.standard_types`)."""

    def __init__(self, context: Context, hardware: Sequence[SystemInterface], *,
                 name: str = "controller_manager", namespace: str = "/",
                 types: Mapping[str, type[ControllerInterface]] | None = None) -> None:
        super().__init__(context, name, namespace)
        rate = self.declare_parameter("update_rate", 100).value
        if not isinstance(rate, (int, float)) or isinstance(rate, bool) or rate <= 0:
            raise ControllerError(f"{self.get_name()}: update_rate {rate!r} is not a "
                                  "positive number (Hz)")
        self.update_rate = float(rate)
        self.default_strictness = str(self.declare_parameter(
            "defaults.switch_controller.strictness", "best_effort").value)
        self.types = dict(standard_types() if types is None else types)
        self.components = Components()
        self.interfaces = self.components.interfaces
        self.controllers: dict[str, ControllerInterface] = {}
        log = self.get_logger()
        initial = {state: set(self._strings(f"hardware_components_initial_state.{label}"))
                   for state, label in ((UNCONFIGURED, "unconfigured"), (INACTIVE, "inactive"))}
        for system in hardware:
            self.components.load(system)
            target = next((s for s, names in initial.items() if system.name in names), ACTIVE)
            if target != UNCONFIGURED:
                ok, message = self.components.set_state(system.name, target)
                if not ok:
                    raise ControllerError(message)
            log.info(f"Loaded hardware '{system.name}' ({system.info.plugin}): "
                     f"{STATE_LABELS[self.components.by_name[system.name].state]}")
        self._services()
        #: updates done, and those that came later than their period
        self.updates = 0
        self.overruns = 0
        self._stamps: deque[float] = deque(maxlen=RATE_WINDOW)
        self._last: float | None = None
        self._due = self.context.clock.now()
        self._closed = False
        self.context.executor.add_background(self)

    def _strings(self, name: str) -> list[str]:
        value = self.declare_parameter(name, [], kind=STRING_ARRAY).value
        return [v for v in value if v] if isinstance(value, list) else []

    # -- the update loop (executor background work) -------------------------------------

    def due(self) -> float | None:
        return None if self._closed else self._due

    def run(self) -> None:
        now = self.context.clock.now()
        period = 1.0 / self.update_rate if self._last is None else now - self._last
        self._last = now
        self.update_once(now, period)
        step = 1.0 / self.update_rate
        self._due += step
        if self._due < now:  # late by more than a period: go on from now, counted
            self.overruns += 1
            self._due = now + step
        self._stamps.append(now)

    def update_once(self, now: float, period: float) -> None:
        """One read -> update -> write."""
        failed = [c.name for c in self.components if c.state in (INACTIVE, ACTIVE)
                  and not c.system.read(now, period)]
        if failed:
            self._hardware_failed(failed, "read")
        self.updates += 1
        for controller in list(self.controllers.values()):
            if not controller.is_active:
                continue
            if controller.update_rate < self.update_rate:
                every = max(1, round(self.update_rate / controller.update_rate))
                if self.updates % every:
                    continue
                controller_period = period * every
            else:
                controller_period = period
            try:
                controller.update(now, controller_period)
            except Exception as exc:  # a controller's bug must not stop the others
                self.get_logger().error(f"Caught exception while updating controller "
                                        f"'{controller.name}': {exc}",
                                        throttle_duration_sec=1.0)
        failed = [c.name for c in self.components if c.state == ACTIVE
                  and not c.system.write(now, period)]
        if failed:
            self._hardware_failed(failed, "write")

    def _hardware_failed(self, names: list[str], cycle: str) -> None:
        log = self.get_logger()
        for name in names:
            error = self.components.by_name[name].system.error
            if error:
                log.error(error)
        interfaces: set[str] = set()
        for name in names:
            states, commands = self.components.interfaces_of(name)
            interfaces.update(states, commands)
            # the motors that still answer stop or hold now (a wheel must not keep turning
            # on a dead cable's neighbour): nothing is written to a failed component again
            if not self.components.by_name[name].system.on_deactivate():
                log.error(self.components.by_name[name].system.error)
            self.components.failed(name)
        users = [c.name for c in self.controllers.values() if c.is_active and
                 interfaces & {h.name for h in (*c.command_interfaces, *c.state_interfaces)}]
        log.error(f"Deactivating following hardware components as their {cycle} cycle "
                  f"resulted in an error: [ {' '.join(names)} ]")
        if users:
            log.error(f"Deactivating following controllers as their hardware components "
                      f"{cycle} cycle resulted in an error: [ {' '.join(users)} ]")
        for name in users:
            self._deactivate(self.controllers[name])

    @property
    def achieved_rate(self) -> float:
        """Updates a second over the last :data:`RATE_WINDOW` (0 before two)."""
        stamps = self._stamps
        if len(stamps) < 2 or stamps[-1] <= stamps[0]:
            return 0.0
        return (len(stamps) - 1) / (stamps[-1] - stamps[0])

    # -- controllers ----------------------------------------------------------------------

    def load_controller(self, name: str) -> tuple[bool, str]:
        log = self.get_logger()
        if name in self.controllers:
            message = f"Controller with name '{name}' already exists."
            log.error(message)
            return False, message
        key = f"{name}.type"
        kind = self.get_parameter(key).value if self.has_parameter(key) else \
            self.declare_parameter(key, "").value
        if not kind:
            message = f"The 'type' param was not defined for '{name}'."
            log.error(message)
            return False, message
        log.info(f"Loading controller : '{name}' of type '{kind}'")
        cls = self.types.get(str(kind))
        if cls is None:
            message = (f"Loader for controller '{name}' (type '{kind}') not found. Available "
                       f"classes: {', '.join(sorted(self.types))}")
            log.error(message)
            return False, message
        try:
            controller = cls(name, self.context, self.get_namespace(), self.update_rate)
        except Exception as exc:
            message = f"Could not initialize the controller named '{name}': {exc}"
            log.error(message)
            return False, message
        self.controllers[name] = controller
        return True, f"Loaded controller '{name}'"

    def configure_controller(self, name: str) -> tuple[bool, str]:
        log = self.get_logger()
        controller = self.controllers.get(name)
        if controller is None:
            message = f"Controller '{name}' can not be configured because it is not loaded."
            log.error(message)
            return False, message
        log.info(f"Configuring controller: '{name}'")
        if controller.state == ACTIVE:
            message = (f"Controller '{name}' can not be configured from 'active' state.")
            log.error(message)
            return False, message
        if controller.state == INACTIVE:
            controller.on_cleanup()
            controller.state = UNCONFIGURED
        try:
            controller.on_configure()
            self._required(controller)
        except Exception as exc:
            message = f"After configuring, controller '{name}' is in state 'unconfigured' , " \
                      f"expected inactive: {exc}"
            log.error(message)
            return False, message
        controller.state = INACTIVE
        return True, f"Configured controller '{name}'"

    def cleanup_controller(self, name: str) -> tuple[bool, str]:
        controller = self.controllers.get(name)
        if controller is None or controller.state != INACTIVE:
            what = "it is not loaded" if controller is None else \
                f"it is in state '{controller.label}'"
            message = f"Controller '{name}' can not be cleaned-up because {what}."
            self.get_logger().error(message)
            return False, message
        controller.on_cleanup()
        controller.state = UNCONFIGURED
        return True, f"Cleaned up controller '{name}'"

    def unload_controller(self, name: str) -> tuple[bool, str]:
        log = self.get_logger()
        log.info(f"Unloading controller: '{name}'")
        controller = self.controllers.get(name)
        if controller is None:
            message = (f"Could not unload controller with name '{name}' because no controller "
                       "with this name exists")
            log.error(message)
            return False, message
        if controller.is_active:
            message = (f"Could not unload controller with name '{name}' because it is still "
                       "active")
            log.error(message)
            return False, message
        del self.controllers[name]
        controller.destroy()
        return True, f"Unloaded controller '{name}'"

    def _required(self, controller: ControllerInterface) -> tuple[list[str], list[str]]:
        """The command and state interfaces ``controller`` needs, all or individual."""
        table = self.interfaces
        commands = controller.command_interface_configuration()
        states = controller.state_interface_configuration()
        command_names = list(table.commands) if commands.type == ALL else \
            list(commands.names) if commands.type == INDIVIDUAL else []
        state_names = list(table.states) if states.type == ALL else \
            list(states.names) if states.type == INDIVIDUAL else []
        return command_names, state_names

    def _activate(self, controller: ControllerInterface) -> str | None:
        commands, states = self._required(controller)
        table = self.interfaces
        missing = [n for n in states if n not in table.available_states]
        if missing:
            return (f"Unable to activate controller '{controller.name}' since the state "
                    f"interface '{missing[0]}' is not available.")
        controller.command_interfaces = table.claim(commands, controller.name)
        controller.state_interfaces = [table.state(n) for n in states]
        try:
            controller.on_activate()
        except Exception as exc:
            table.release(controller.name)
            controller.command_interfaces, controller.state_interfaces = [], []
            return f"Could not activate controller : '{controller.name}' ({exc})"
        controller.state = ACTIVE
        return None

    def _deactivate(self, controller: ControllerInterface) -> None:
        try:
            controller.on_deactivate()
        finally:
            self.interfaces.release(controller.name)
            controller.command_interfaces, controller.state_interfaces = [], []
            controller.state = INACTIVE

    def switch_controller(self, activate: Sequence[str], deactivate: Sequence[str],
                          strictness: int = 0) -> tuple[bool, str]:
        """Deactivate then activate, between two updates, as ``switch_controller`` checks
        it: (ok, message)."""
        log = self.get_logger()
        if strictness == 0:
            strictness = STRICT if self.default_strictness.lower() == "strict" else BEST_EFFORT
        elif strictness in (AUTO, FORCE_AUTO):
            strictness = BEST_EFFORT
        if activate:
            log.info(f"Activating controllers: [ {' '.join(activate)} ]")
        if deactivate:
            log.info(f"Deactivating controllers: [ {' '.join(deactivate)} ]")
        to_activate: list[str] = []
        to_deactivate: list[str] = []

        def refuse(message: str) -> tuple[bool, str]:
            log.error("Aborting, no controller is switched! ('STRICT' switch)")
            return False, message

        for names, chosen, action in ((activate, to_activate, "activate"),
                                      (deactivate, to_deactivate, "deactivate")):
            for name in names:
                if name in self.controllers:
                    chosen.append(name)
                    continue
                missing = (f"Could not {action} controller with name '{name}' because no "
                           "controller with this name exists")
                log.warning(missing)
                if strictness == STRICT:
                    return refuse(missing)
        for name in list(to_activate):
            controller = self.controllers[name]
            message: str | None = None
            if controller.state == UNCONFIGURED:
                message = (f"Controller with name '{name}' is in 'unconfigured' state. The "
                           "controller needs to be configured to be in 'inactive' state before "
                           "it can be checked and activated.")
            elif controller.is_active and name not in to_deactivate:
                message = f"Controller with name '{name}' is already active."
            if message is not None:
                log.warning(message)
                if strictness == STRICT:
                    return refuse(message)
                to_activate.remove(name)
        for name in list(to_deactivate):
            if not self.controllers[name].is_active:
                message = (f"Controller with name '{name}' can not be deactivated since it is "
                           "not active.")
                log.warning(message)
                if strictness == STRICT:
                    return refuse(message)
                to_deactivate.remove(name)
        if not to_activate and not to_deactivate:
            message = ("After checking the controllers, no controllers need to be activated "
                       "or deactivated.")
            log.info(message)
            return True, message
        refused = self._check_availability(to_activate, to_deactivate)
        if refused is not None:
            log.warning(refused)
            return False, refused
        starting = [n for c in to_activate for n in self._required(self.controllers[c])[0]]
        stopping = [n for c in to_deactivate for n in
                    self.interfaces.claimed_by(self.controllers[c].name)]
        for component in self.components:
            if not component.system.prepare_command_mode_switch(starting, stopping):
                message = ("Could not switch controllers since prepare command mode switch "
                           "was rejected.")
                if component.system.error:
                    log.error(component.system.error)
                log.error(message)
                return False, message
        for name in to_deactivate:
            self._deactivate(self.controllers[name])
        for component in self.components:
            if not component.system.perform_command_mode_switch(starting, stopping):
                log.error("Error while performing mode switch.")
                if component.system.error:
                    log.error(component.system.error)
        failed = []
        for name in to_activate:
            refusal = self._activate(self.controllers[name])
            if refusal is not None:
                log.error(refusal)
                failed.append(name)
        if failed:
            return False, (f"Could not activate controllers: [ {' '.join(failed)} ]. Check the "
                           "controller manager's log.")
        log.info("Successfully switched controllers!")
        return True, "Successfully switched controllers!"

    def _check_availability(self, activate: list[str], deactivate: list[str]) -> str | None:
        """``check_for_interfaces_availability_to_activate``: None, or why not."""
        table = self.interfaces
        freed = {n for c in deactivate for n in table.claimed_by(c)}
        taken: set[str] = set()
        for name in activate:
            if name in deactivate:
                continue
            commands, states = self._required(self.controllers[name])
            for interface in commands:
                if interface not in table.commands or interface not in \
                        table.available_commands:
                    return (f"Unable to activate controller '{name}' since the command "
                            f"interface '{interface}' is not available.")
                if interface in table.claimed and interface not in freed:
                    return (f"Unable to activate controller '{name}' since the command "
                            f"interface '{interface}' is currently claimed by another "
                            "controller.")
                if interface in taken:
                    return (f"Unable to activate controller '{name}' since the command "
                            f"interface '{interface}' will be used by another controller "
                            "that is being activated.")
                taken.add(interface)
            for interface in states:
                if interface not in table.available_states:
                    return (f"Unable to activate controller '{name}' since the state "
                            f"interface '{interface}' is not available.")
        return None

    def set_hardware_component_state(self, name: str, target: int) -> tuple[bool, str]:
        if name not in self.components.by_name:
            return False, f"hardware component '{name}' is not loaded"
        ok, message = self.components.set_state(name, target)
        (self.get_logger().info if ok else self.get_logger().error)(message)
        return ok, message

    # -- services ---------------------------------------------------------------------------

    def _services(self) -> None:
        def simple(request_field: str, act: Any) -> Any:
            def handler(request: Any, response: Any) -> Any:
                response.ok = act(getattr(request, request_field))[0]
                return response
            return handler

        self.create_service(SRV + "ListControllers", "~/list_controllers",
                            self._on_list_controllers)
        self.create_service(SRV + "ListControllerTypes", "~/list_controller_types",
                            self._on_list_types)
        self.create_service(SRV + "ListHardwareInterfaces", "~/list_hardware_interfaces",
                            self._on_list_interfaces)
        self.create_service(SRV + "ListHardwareComponents", "~/list_hardware_components",
                            self._on_list_components)
        self.create_service(SRV + "LoadController", "~/load_controller",
                            simple("name", self.load_controller))
        self.create_service(SRV + "ConfigureController", "~/configure_controller",
                            simple("name", self.configure_controller))
        self.create_service(SRV + "CleanupController", "~/cleanup_controller",
                            simple("name", self.cleanup_controller))
        self.create_service(SRV + "UnloadController", "~/unload_controller",
                            simple("name", self.unload_controller))
        self.create_service(SRV + "SwitchController", "~/switch_controller", self._on_switch)
        self.create_service(SRV + "SetHardwareComponentState",
                            "~/set_hardware_component_state", self._on_set_component_state)

    def controller_state(self, controller: ControllerInterface) -> Any:
        """A ``controller_manager_msgs/ControllerState``."""
        try:
            commands, states = self._required(controller)
        except ControllerError:
            commands, states = [], []
        return self.message(
            "controller_manager_msgs/msg/ControllerState", name=controller.name,
            state=controller.label, type=controller.TYPE, is_async=controller.is_async,
            update_rate=int(min(controller.update_rate, 65535)),
            claimed_interfaces=self.interfaces.claimed_by(controller.name),
            required_command_interfaces=commands, required_state_interfaces=states)

    def _on_list_controllers(self, request: Any, response: Any) -> Any:
        response.controller = [self.controller_state(c) for c in self.controllers.values()]
        return response

    def _on_list_types(self, request: Any, response: Any) -> Any:
        response.types = sorted(self.types)
        response.base_classes = ["controller_interface::ControllerInterface"] * len(self.types)
        return response

    def _interface_messages(self, names: Sequence[str], available: set[str],
                            claimed: Mapping[str, str]) -> list[Any]:
        return [self.message("controller_manager_msgs/msg/HardwareInterface", name=n,
                             data_type="double", is_available=n in available,
                             is_claimed=n in claimed) for n in names]

    def _on_list_interfaces(self, request: Any, response: Any) -> Any:
        table = self.interfaces
        response.command_interfaces = self._interface_messages(
            list(table.commands), table.available_commands, table.claimed)
        response.state_interfaces = self._interface_messages(
            list(table.states), table.available_states, {})
        return response

    def _on_list_components(self, request: Any, response: Any) -> Any:
        table = self.interfaces
        found = []
        for component in self.components:
            states, commands = self.components.interfaces_of(component.name)
            found.append(self.message(
                "controller_manager_msgs/msg/HardwareComponentState", name=component.name,
                type=component.system.info.type, is_async=False,
                rw_rate=int(min(self.update_rate, 65535)),
                class_type=component.system.info.plugin,
                plugin_name=component.system.info.plugin,
                state=self.message("lifecycle_msgs/msg/State", id=component.state,
                                   label=component.label),
                command_interfaces=self._interface_messages(commands, table.available_commands,
                                                            table.claimed),
                state_interfaces=self._interface_messages(states, table.available_states, {})))
        response.component = found
        return response

    def _on_switch(self, request: Any, response: Any) -> Any:
        response.ok, response.message = self.switch_controller(
            list(request.activate_controllers), list(request.deactivate_controllers),
            int(request.strictness))
        return response

    def _on_set_component_state(self, request: Any, response: Any) -> Any:
        target = request.target_state
        wanted = target.id if target.id else state_id(target.label or "")
        if wanted is None:
            response.ok = False
        else:
            response.ok, _ = self.set_hardware_component_state(request.name, wanted)
        component = self.components.by_name.get(request.name)
        state = component.state if component is not None else 0
        response.state = self.message("lifecycle_msgs/msg/State", id=state,
                                      label=STATE_LABELS[state])
        return response

    def close(self) -> None:
        """Stop updating: active controllers deactivated, components deactivated (the
        joints hold), the loop off the executor."""
        if self._closed:
            return
        self._closed = True
        self.context.executor.remove_background(self)
        for controller in self.controllers.values():
            if controller.is_active:
                self._deactivate(controller)
        now = self.context.clock.now()
        for component in self.components:
            if component.state == ACTIVE:
                # what the controllers left on deactivation (a diff drive's zero wheel
                # speeds) reaches the motors before the component stops them itself
                component.system.write(now, 1.0 / self.update_rate)
                component.system.on_deactivate()
                component.state = INACTIVE

    def destroy(self) -> None:
        self.close()
        for controller in list(self.controllers.values()):
            controller.destroy()
        super().destroy()


def finite(values: Sequence[float]) -> bool:
    return all(math.isfinite(v) for v in values)
