"""``rclpy.qos``: profiles and policies in rclpy's names (servolab's :mod:`~.middleware.qos`)."""

from servolab.middleware.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
    qos_profile_system_default,
)

# rclpy's older names for the same policies
QoSDurabilityPolicy = DurabilityPolicy
QoSHistoryPolicy = HistoryPolicy
QoSReliabilityPolicy = ReliabilityPolicy

__all__ = ["DurabilityPolicy", "HistoryPolicy", "QoSDurabilityPolicy", "QoSHistoryPolicy",
           "QoSProfile", "QoSReliabilityPolicy", "ReliabilityPolicy", "qos_profile_sensor_data",
           "qos_profile_system_default"]
