"""ros2_control for Dynamixel robots: a controller manager, the standard controllers, and the
hardware a URDF's ``<ros2_control>`` block describes (docs/control.md).

- :mod:`.resources`: the interfaces (``joint/position``), who claims them, the hardware
  components and their lifecycle states — ros2_control's ResourceManager;
- :mod:`.hardware`: the hardware component interface; :mod:`.mock_system` (ros2_control's
  ``mock_components/GenericSystem``) and :mod:`.dynamixel_hardware` (a servolab bus) behind it;
- :mod:`.controller`: the controller interface and its lifecycle; the standard controllers
  of ros2_controllers in :mod:`.joint_state_broadcaster`, :mod:`.forward_command` and
  :mod:`.joint_trajectory` (their names in :mod:`.types`);
- :mod:`.manager`: the ``controller_manager`` node (update loop and services);
- :mod:`.bringup`: a robot brought up from its URDF and controllers file, as a launch file
  with ``ros2_control_node`` and spawners does.
"""
