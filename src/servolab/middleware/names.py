"""ROS names: validation and resolution to fully qualified names.

The rules are ROS 2's ("Topic and Service name mapping" design article): a name is tokens of
letters, digits and underscores separated by ``/``; a token does not start with a digit; a
name starting with ``/`` is absolute, ``~`` is private to the node, anything else is relative
to the node's namespace. Resolving names once, here, is what lets two nodes in different
processes agree on a topic.
"""

from __future__ import annotations

import re

from .errors import MessageError

_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def validate_node_name(name: str) -> None:
    if not isinstance(name, str) or not _TOKEN.fullmatch(name):
        raise MessageError(f"node name {name!r} is not valid (letters, digits and underscores, "
                           "not starting with a digit)")


def _check_tokens(name: str, tokens: list[str]) -> None:
    for token in tokens:
        if not _TOKEN.fullmatch(token):
            why = "an empty token ('//' or a trailing '/')" if not token else f"token {token!r}"
            raise MessageError(f"name {name!r} is not a valid ROS name: {why}")


def resolve_name(name: str, namespace: str, node_name: str) -> str:
    """The fully qualified name of ``name`` for a node ``node_name`` in ``namespace``.

    >>> resolve_name("chatter", "/robot1", "talker")
    '/robot1/chatter'
    >>> resolve_name("~/state", "/robot1", "talker")
    '/robot1/talker/state'
    """
    if not isinstance(name, str) or not name:
        raise MessageError(f"name {name!r} is empty")
    ns = namespace.rstrip("/")
    if name == "~":
        full = f"{ns}/{node_name}"
    elif name.startswith("~/"):
        full = f"{ns}/{node_name}/{name[2:]}"
    elif name.startswith("/"):
        full = name
    else:
        full = f"{ns}/{name}"
    if full == "/":
        return full
    _check_tokens(name, full[1:].split("/"))
    return full
