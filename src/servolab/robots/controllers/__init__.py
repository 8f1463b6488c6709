"""ROS ``dynamixel_motor`` (arebgun/dynamixel_motor) in servolab: the controller configuration
YAML of ``dynamixel_controllers``, the controller manager, joint position controllers and motor
states. Robot-agnostic: any robot of Dynamixel joints runs on them (Armstrong does)."""
