"""Armstrong shows itself to a 3D viewer: :class:`~servolab.robots.state_publisher.
RobotStatePublisher` given Armstrong's URDF and listening to its joint controllers.

:class:`ArmstrongStatePublisher` publishes, beside the joint controllers of
:mod:`servolab.robots.controllers`, ``/robot_description`` (latched), ``/joint_states`` (every
movable URDF joint's position in radians, from what the controllers report on
``/<controller>/state``, once a sweep of the manager), ``/tf`` and ``/tf_static`` (latched).
The controller of the URDF transmission whose actuator is ``m14`` is ``controller_m14`` (the
seed's naming, :func:`.control_node.controller_of`); Armstrong's transmissions' reductions
are its motors' directions (:mod:`.description`), so a joint's angle is its motor's over its
direction. A joint whose motor has no running controller (the camera, motor 62, absent)
stays at 0, its URDF zero.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..state_publisher import ControllerStates, RobotStatePublisher
from .control_node import controller_of

if TYPE_CHECKING:
    from ...middleware.context import Context
    from ..controllers.config import RobotConfig
    from .description import Assumptions


@dataclass(frozen=True)
class StatePublisherConfig:
    """What :class:`ArmstrongStatePublisher` publishes and listens to.

    ``urdf``: the robot description (its joints, and its transmissions, whose actuators name
    the motors); ``controllers``: the joint controllers that run, whose ``/<name>/state`` it
    hears; the controller of actuator ``m14`` is ``controller_m14`` (``controller_prefix``
    + the actuator's name, the seed's naming). ``frame_prefix`` goes before every link's name
    in the transforms (robot_state_publisher's parameter of that name)."""

    urdf: str
    controllers: tuple[str, ...] = ()
    controller_prefix: str = "controller_"
    frame_prefix: str = ""

    @classmethod
    def armstrong(cls, controllers: Iterable[str] = (),
                  assumptions: Assumptions | None = None,
                  config: RobotConfig | None = None) -> StatePublisherConfig:
        """Armstrong's URDF (:func:`.description.urdf` under ``assumptions``, with the motors
        of ``config``), listening to ``controllers``."""
        from .description import describe, urdf

        prefix = controller_of("")
        return cls(urdf(describe(assumptions, config)), tuple(controllers), prefix)


class ArmstrongStatePublisher(RobotStatePublisher):
    """A :class:`~servolab.robots.state_publisher.RobotStatePublisher` fed by Armstrong's
    joint controllers (see the module docstring)."""

    def __init__(self, context: Context, config: StatePublisherConfig, *,
                 name: str = "robot_state_publisher", namespace: str = "/") -> None:
        super().__init__(context, config.urdf, name=name, namespace=namespace,
                         frame_prefix=config.frame_prefix,
                         controllers=ControllerStates(config.controllers,
                                                      config.controller_prefix))
        self.config = config
