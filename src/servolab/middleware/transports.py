"""The names of the transports a context can open, in one light module (the CLI's
``--transport`` choices read it without loading the middleware): in-process, Zenoh (rmw_zenoh's
layout), DDS (rmw_fastrtps' and rmw_cyclonedds' layout), and an installed ROS 2's own rmw
through its rclpy."""

TRANSPORTS = ("local", "zenoh", "dds", "ros2")
