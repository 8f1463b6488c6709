"""``rclpy.action``: action servers and clients with rclpy's API (:mod:`.server`,
:mod:`.client`), and the graph's actions, as ``rclpy.action.graph`` lists them: an action is
known by its ``send_goal`` service (``<name>/_action/send_goal``, ``<Action>_SendGoal``)."""

from __future__ import annotations

from typing import Any

from .client import ActionClient, ClientGoalHandle
from .server import ActionServer, CancelResponse, GoalResponse, ServerGoalHandle

_SEND_GOAL = "/_action/send_goal"
_SEND_GOAL_TYPE = "_SendGoal"


def _actions(names_and_types: list[tuple[str, list[str]]]) -> list[tuple[str, list[str]]]:
    found = [(name[:-len(_SEND_GOAL)], [t[:-len(_SEND_GOAL_TYPE)] for t in types
                                        if t.endswith(_SEND_GOAL_TYPE)])
             for name, types in names_and_types if name.endswith(_SEND_GOAL)]
    return sorted((name, types) for name, types in found if types)


def get_action_names_and_types(node: Any) -> list[tuple[str, list[str]]]:
    """Every action in the graph (servers' and clients'), with its types."""
    return _actions(node.get_service_names_and_types())


def get_action_server_names_and_types_by_node(node: Any, remote_node_name: str,
                                              remote_node_namespace: str
                                              ) -> list[tuple[str, list[str]]]:
    return _actions(node.get_service_names_and_types_by_node(remote_node_name,
                                                             remote_node_namespace))


def get_action_client_names_and_types_by_node(node: Any, remote_node_name: str,
                                              remote_node_namespace: str
                                              ) -> list[tuple[str, list[str]]]:
    return _actions(node.get_client_names_and_types_by_node(remote_node_name,
                                                            remote_node_namespace))


__all__ = ["ActionClient", "ActionServer", "CancelResponse", "ClientGoalHandle", "GoalResponse",
           "ServerGoalHandle", "get_action_client_names_and_types_by_node",
           "get_action_names_and_types", "get_action_server_names_and_types_by_node"]
