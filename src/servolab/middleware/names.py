"""ROS 2 names — node names, namespaces, enclaves, topic and service names — checked by ROS 2's
own rules and expanded as rcl expands them (pure functions: no session, no I/O).

The checks follow, step for step and in the same order, ros2/rmw's
``rmw/src/validate_node_name.c``, ``validate_namespace.c`` and ``validate_full_topic_name.c``
and ros2/rcl's ``rcl/src/rcl/validate_topic_name.c``, ``validate_enclave_name.c`` and
``expand_topic_name.c`` (``node.c`` for how a node's namespace is completed), so that a name
servolab accepts is one ROS 2 accepts, and the other way round. Their messages are rmw's and
rcl's ``*_validation_result_string``; a bad name raises
:class:`~servolab.middleware.errors.NameValidationError`, which shows the name with a caret
under its first bad character as rclpy's ``NameValidationException`` does.

- :func:`validate_node_name`, :func:`validate_namespace`, :func:`validate_topic_name` (a name
  as written: relative, ``~/private``, ``{node}``), :func:`validate_full_topic_name` (an
  expanded one): rclpy's ``rclpy.validate_*``, returning the name rather than True
- :func:`expand_topic_name`: rcl's expansion of ``~``, ``{node}``, ``{ns}`` / ``{namespace}``
  and relative names
- :func:`fully_qualified_name`, :func:`node_namespace`, :func:`check_node_name`: what a node
  and a launch file use
- :func:`frame_prefix` and :func:`in_namespace`: a robot in a namespace, as ROS 2 multi-robot
  setups run it (its tf frames prefixed, its topics in its namespace, the global ones shared)
"""

from __future__ import annotations

from .errors import NameValidationError

__all__ = [
    "BASE_FRAME",
    "ENCLAVE_NAME_MAX_LENGTH",
    "GLOBAL_TOPICS",
    "NAMESPACE_MAX_LENGTH",
    "NODE_NAME_MAX_LENGTH",
    "ODOM_FRAME",
    "TOPIC_NAME_MAX_LENGTH",
    "NameValidationError",
    "check_node_name",
    "expand_topic_name",
    "frame_prefix",
    "fully_qualified_name",
    "in_namespace",
    "node_namespace",
    "validate_enclave_name",
    "validate_full_topic_name",
    "validate_namespace",
    "validate_node_name",
    "validate_topic_name",
]

#: ``RMW_NODE_NAME_MAX_NAME_LENGTH`` (rmw/validate_node_name.h).
NODE_NAME_MAX_LENGTH = 255
#: ``RMW_TOPIC_MAX_NAME_LENGTH``: 255 less 8 for prefixes (rmw/validate_full_topic_name.h).
TOPIC_NAME_MAX_LENGTH = 255 - 8
#: ``RMW_NAMESPACE_MAX_LENGTH`` (rmw/validate_namespace.h).
NAMESPACE_MAX_LENGTH = TOPIC_NAME_MAX_LENGTH - 2
#: ``RCL_ENCLAVE_NAME_MAX_LENGTH`` (rcl/validate_enclave_name.h).
ENCLAVE_NAME_MAX_LENGTH = NODE_NAME_MAX_LENGTH

#: rcl's substitutions (expand_topic_name.c); its default map of others is empty.
SUBSTITUTIONS = ("{node}", "{ns}", "{namespace}")

# What is wrong with a name: the keys of the message tables below.
_EMPTY = "empty"
_NOT_ABSOLUTE = "not absolute"
_ENDS_WITH_SLASH = "ends with /"
_UNALLOWED = "unallowed character"
_REPEATED_SLASH = "repeated /"
_TOKEN_NUMBER = "token starts with a number"
_STARTS_WITH_NUMBER = "starts with a number"
_TOO_LONG = "too long"
_UNMATCHED_BRACE = "unmatched brace"
_MISPLACED_TILDE = "misplaced tilde"
_TILDE_NOT_SLASH = "tilde not followed by /"
_SUBSTITUTION_UNALLOWED = "substitution: unallowed character"
_SUBSTITUTION_NUMBER = "substitution starts with a number"

# rmw_node_name_validation_result_string (rmw/src/validate_node_name.c).
_NODE_NAME_MESSAGES = {
    _EMPTY: "node name must not be empty",
    _UNALLOWED: "node name must not contain characters other than alphanumerics or '_'",
    _STARTS_WITH_NUMBER: "node name must not start with a number",
    _TOO_LONG: f"node name length should not exceed '{NODE_NAME_MAX_LENGTH}'",
}
# rmw_full_topic_name_validation_result_string (rmw/src/validate_full_topic_name.c); rmw
# stringifies the macro, which prints as '255U - 8U': the number is given here.
_FULL_TOPIC_NAME_MESSAGES = {
    _EMPTY: "topic name must not be empty",
    _NOT_ABSOLUTE: "topic name must be absolute, it must lead with a '/'",
    _ENDS_WITH_SLASH: "topic name must not end with a '/'",
    _UNALLOWED: "topic name must not contain characters other than alphanumerics, '_', or '/'",
    _REPEATED_SLASH: "topic name must not contain repeated '/'",
    _TOKEN_NUMBER: "topic name must not have a token that starts with a number",
    _TOO_LONG: f"topic length should not exceed '{TOPIC_NAME_MAX_LENGTH}'",
}
# rmw_namespace_validation_result_string (rmw/src/validate_namespace.c); rmw stringifies an
# undefined macro there (RMW_NAMESPACE_MAX_NAME_LENGTH): the number is given here.
_NAMESPACE_MESSAGES = {
    _EMPTY: "namespace must not be empty",
    _NOT_ABSOLUTE: "namespace must be absolute, it must lead with a '/'",
    _ENDS_WITH_SLASH: "namespace must not end with a '/', unless only a '/'",
    _UNALLOWED: "namespace must not contain characters other than alphanumerics, '_', or '/'",
    _REPEATED_SLASH: "namespace must not contain repeated '/'",
    _TOKEN_NUMBER: "namespace must not have a token that starts with a number",
    _TOO_LONG: f"namespace should not exceed '{NAMESPACE_MAX_LENGTH}'",
}
# rcl_enclave_name_validation_result_string (rcl/src/rcl/validate_enclave_name.c).
_ENCLAVE_MESSAGES = {
    key: text.replace("namespace", "context name", 1)
    for key, text in _NAMESPACE_MESSAGES.items() if key != _TOO_LONG
} | {_TOO_LONG: f"context name should not exceed '{ENCLAVE_NAME_MAX_LENGTH}'"}
# rcl_topic_name_validation_result_string (rcl/src/rcl/validate_topic_name.c).
_TOPIC_NAME_MESSAGES = {
    _EMPTY: "topic name must not be empty string",
    _ENDS_WITH_SLASH: "topic name must not end with a forward slash",
    _UNALLOWED: "topic name must not contain characters other than alphanumerics, '_', '~', "
                "'{', or '}'",
    _TOKEN_NUMBER: "topic name token must not start with a number",
    _UNMATCHED_BRACE: "topic name must not have unmatched (unbalanced) curly braces '{}'",
    _MISPLACED_TILDE: "topic name must not have tilde '~' unless it is the first character",
    _TILDE_NOT_SLASH: "topic name must not have a tilde '~' that is not followed by a forward "
                      "slash '/'",
    _SUBSTITUTION_UNALLOWED: "substitution name must not contain characters other than "
                             "alphanumerics or '_'",
    _SUBSTITUTION_NUMBER: "substitution name must not start with a number",
}

Problem = tuple[str, int]  # what is wrong (a key above), and the index of the bad character


def _alnum(c: str) -> bool:
    """rcutils_isalnum_no_locale: ASCII letters and digits only."""
    return c.isascii() and c.isalnum()


def _digit(c: str) -> bool:
    """C's isdigit in the "C" locale."""
    return "0" <= c <= "9"


def _kind(is_service: bool) -> str:
    return "service name" if is_service else "topic name"


# -- the rules ------------------------------------------------------------------------------

def _node_name_problem(name: str) -> Problem | None:
    """rmw_validate_node_name."""
    if not name:
        return _EMPTY, 0
    for i, c in enumerate(name):
        if not (_alnum(c) or c == "_"):
            return _UNALLOWED, i
    if _digit(name[0]):
        return _STARTS_WITH_NUMBER, 0
    if len(name) > NODE_NAME_MAX_LENGTH:  # last: it might be a soft invalidation
        return _TOO_LONG, NODE_NAME_MAX_LENGTH - 1
    return None


def _full_topic_name_problem(name: str) -> Problem | None:
    """rmw_validate_full_topic_name."""
    if not name:
        return _EMPTY, 0
    if name[0] != "/":
        return _NOT_ABSOLUTE, 0
    if name[-1] == "/":  # catches both "/foo/" and "/"
        return _ENDS_WITH_SLASH, len(name) - 1
    for i, c in enumerate(name):
        if not (_alnum(c) or c in "_/"):
            return _UNALLOWED, i
    for i in range(len(name) - 1):
        if name[i] == "/":
            if name[i + 1] == "/":
                return _REPEATED_SLASH, i + 1
            if _digit(name[i + 1]):
                return _TOKEN_NUMBER, i + 1
    if len(name) > TOPIC_NAME_MAX_LENGTH:  # last: it might be a soft invalidation
        return _TOO_LONG, TOPIC_NAME_MAX_LENGTH - 1
    return None


def _namespace_problem(namespace: str) -> Problem | None:
    """rmw_validate_namespace: a full topic name, or ``/``, with a shorter length limit."""
    if namespace == "/":
        return None
    problem = _full_topic_name_problem(namespace)
    if problem is not None and problem[0] != _TOO_LONG:
        return problem
    if len(namespace) > NAMESPACE_MAX_LENGTH:
        return _TOO_LONG, NAMESPACE_MAX_LENGTH - 1
    return None


def _topic_name_problem(name: str) -> Problem | None:
    """rcl_validate_topic_name: a name as written, before expansion."""
    length = len(name)
    if length == 0:
        return _EMPTY, 0
    if _digit(name[0]):  # the first token of a relative name, e.g. 7foo/bar
        return _TOKEN_NUMBER, 0
    if name[-1] == "/":  # catches both "/foo/" and "/"
        return _ENDS_WITH_SLASH, length - 1
    in_braces = False
    opening = 0
    for i, c in enumerate(name):
        if _alnum(c):
            if _digit(c) and in_braces and i > 0 and i - 1 == opening:  # foo/{4bar}
                return _SUBSTITUTION_NUMBER, i
        elif c == "_":
            pass
        elif c == "/":
            if in_braces:
                return _SUBSTITUTION_UNALLOWED, i
        elif c == "~":
            if i != 0:
                return _MISPLACED_TILDE, i
        elif c == "{":
            opening = i
            if in_braces:  # nested: foo/{{bar}_baz}
                return _SUBSTITUTION_UNALLOWED, i
            in_braces = True
        elif c == "}":
            if not in_braces:
                return _UNMATCHED_BRACE, i
            in_braces = False
        else:
            return (_SUBSTITUTION_UNALLOWED if in_braces else _UNALLOWED), i
    if in_braces:  # never closed: foo/{bar
        return _UNMATCHED_BRACE, opening
    # Tokens other than the first that start with a number, and ~ not followed by /. As in
    # rcl, the last character is not looked at, so a two-character "~x" passes.
    for i in range(length - 1):
        if name[i] == "/":
            if _digit(name[i + 1]):
                return _TOKEN_NUMBER, i + 1
        elif i == 1 and name[0] == "~":
            return _TILDE_NOT_SLASH, 1
    return None


def _raise(kind: str, name: str, problem: Problem | None, messages: dict[str, str]) -> str:
    if problem is None:
        return name
    what, index = problem
    raise NameValidationError(kind, name, messages[what], index)


# -- validation -----------------------------------------------------------------------------

def validate_node_name(name: str) -> str:
    """``name`` if it is a valid node name, else a :class:`NameValidationError` (rmw's rules:
    ASCII letters, digits and ``_``, not starting with a digit, at most 255 characters)."""
    return _raise("node name", name, _node_name_problem(name), _NODE_NAME_MESSAGES)


def validate_namespace(namespace: str) -> str:
    """``namespace`` if it is a valid namespace, else a :class:`NameValidationError`. As in
    rclpy, it must be absolute and not empty; :func:`node_namespace` completes a node's."""
    return _raise("namespace", namespace, _namespace_problem(namespace), _NAMESPACE_MESSAGES)


def validate_enclave_name(enclave: str) -> str:
    """``enclave`` if it is a valid enclave (security context) name: a namespace's rules, but
    up to 255 characters (rcl's ``rcl_validate_enclave_name``)."""
    problem = _namespace_problem(enclave)
    if problem is not None and problem[0] == _TOO_LONG:
        too_long = len(enclave) > ENCLAVE_NAME_MAX_LENGTH
        problem = (_TOO_LONG, ENCLAVE_NAME_MAX_LENGTH - 1) if too_long else None
    return _raise("enclave name", enclave, problem, _ENCLAVE_MESSAGES)


def validate_topic_name(name: str, *, is_service: bool = False) -> str:
    """``name`` if it is a valid topic (or service) name as written — relative, absolute,
    ``~/private``, with ``{node}`` / ``{ns}`` substitutions —, else a
    :class:`NameValidationError`. It is not expanded: check the expansion with
    :func:`validate_full_topic_name`, or use :func:`fully_qualified_name`, which does both."""
    return _raise(_kind(is_service), name, _topic_name_problem(name), _TOPIC_NAME_MESSAGES)


def validate_full_topic_name(name: str, *, is_service: bool = False) -> str:
    """``name`` if it is a valid fully qualified, expanded topic (or service) name."""
    return _raise(_kind(is_service), name, _full_topic_name_problem(name),
                  _FULL_TOPIC_NAME_MESSAGES)


# -- expansion ------------------------------------------------------------------------------

def _expand(name: str, node_name: str, namespace: str, kind: str) -> str:
    """rcl_expand_topic_name on names already validated."""
    if name.startswith("/") and "{" not in name:
        return name
    output = name
    if name.startswith("~"):  # no separating "/" after the root namespace
        output = f"{namespace}{node_name}{name[1:]}" if namespace == "/" else \
            f"{namespace}/{node_name}{name[1:]}"
    while (opening := output.find("{")) >= 0:
        substitution = output[opening:output.index("}", opening) + 1]
        if substitution == "{node}":
            replacement = node_name
        elif substitution in ("{ns}", "{namespace}"):
            replacement = namespace
        else:
            raise NameValidationError(kind, name, f"unknown substitution: {substitution} "
                                      f"(known: {', '.join(SUBSTITUTIONS)})",
                                      name.find(substitution))
        output = output.replace(substitution, replacement)
    if not output.startswith("/"):
        output = f"{namespace}{output}" if namespace == "/" else f"{namespace}/{output}"
    return output


def expand_topic_name(name: str, node_name: str, namespace: str, *,
                      is_service: bool = False) -> str:
    """``name`` made absolute as rcl does it, without remapping: ``~`` is the node's own
    ``<namespace>/<node>``, ``{node}`` its name, ``{ns}`` and ``{namespace}`` its namespace, and
    a relative name is put in the namespace. ``name``, ``node_name`` and ``namespace`` (absolute)
    are checked first; the result may still be invalid (``{ns}/x`` at the root is ``//x``):
    check it with :func:`validate_full_topic_name`."""
    kind = _kind(is_service)
    validate_topic_name(name, is_service=is_service)
    validate_node_name(node_name)
    validate_namespace(namespace)
    return _expand(name, node_name, namespace, kind)


def fully_qualified_name(name: str, namespace: str = "/", node_name: str = "", *,
                         is_service: bool = False) -> str:
    """``/robot1/chatter`` for ``chatter`` in ``/robot1``; ``~/x`` is ``/<ns>/<node>/x``.

    rclpy's checks for a node's topic, in its order: the node name, the namespace (completed
    as :func:`node_namespace` does), the name as written, then its expansion. ``node_name`` may
    be left out for a name that has no ``~`` and no ``{node}``."""
    kind = _kind(is_service)
    if node_name:
        validate_node_name(node_name)
    namespace = node_namespace(namespace)
    validate_topic_name(name, is_service=is_service)
    if not node_name and (name.startswith("~") or "{node}" in name):
        raise NameValidationError(kind, name, "a name with '~' or {node} needs a node name to "
                                  "expand", max(name.find("{node}"), 0))
    return validate_full_topic_name(_expand(name, node_name, namespace, kind),
                                    is_service=is_service)


def node_namespace(namespace: str, node_name: str = "") -> str:
    """A node's namespace as ``rcl_node_init`` completes it — ``/`` for ``""``, ``/robot1``
    for ``robot1`` —, checked by rmw's namespace rules. ``node_name`` is not used (a namespace
    takes no ``~`` or substitutions in ROS 2); it is kept for the callers that pass it."""
    del node_name
    if not namespace:
        return "/"
    return validate_namespace(namespace if namespace.startswith("/") else f"/{namespace}")


def check_node_name(name: str) -> str:
    """A valid node name, or a :class:`NameValidationError` showing where it is not."""
    return validate_node_name(name)


# -- many robots in one graph ---------------------------------------------------------------

#: The topics every robot of a graph shares, which stay absolute whatever a node's namespace:
#: the clock, the parameter events and rosout (rclcpp and rclpy create them as "/clock",
#: "/parameter_events", "/rosout"), and the transforms: tf2_ros' broadcasters publish on
#: "/tf" and "/tf_static", so that one tree holds every robot's frames, each robot's prefixed
#: (:func:`frame_prefix`), as TurtleBot3's multi-robot launch runs its robots.
GLOBAL_TOPICS = ("/clock", "/parameter_events", "/rosout", "/tf", "/tf_static")


#: A mobile base's odometry frame and base frame, as REP-105 names them ("Coordinate Frames
#: for Mobile Platforms": ``odom``, and ``base_footprint`` under ``base_link``) and TurtleBot3's
#: turtlebot3_node publishes them; a namespaced robot's take :func:`frame_prefix`.
ODOM_FRAME, BASE_FRAME = "odom", "base_footprint"


def frame_prefix(namespace: str) -> str:
    """What goes before every tf frame a robot in ``namespace`` publishes: the namespace
    without its leading ``/``, with a trailing one (``/robot1`` -> ``robot1/``, so its frames
    are ``robot1/odom``, ``robot1/base_link``); nothing in the root namespace, so a robot
    alone keeps the frames it always had.

    The one place servolab decides it. It is robot_state_publisher's ``frame_prefix``
    parameter as turtlebot3_bringup's launch sets it (``namespace + '/'``), and
    diff_drive_controller's default ``tf_frame_prefix`` (its node's namespace, leading ``/``
    removed, trailing ``/`` added). A prefix already written that way (``robot1/``, or
    ``robot1``) gives the same."""
    if not namespace or namespace == "/":
        return ""
    stripped = namespace[1:] if namespace.startswith("/") else namespace
    return stripped if stripped.endswith("/") else f"{stripped}/"


def in_namespace(topic: str, namespace: str) -> str:
    """An absolute topic of a robot alone (``/odom``) as the same robot has it in
    ``namespace`` (``/robot1/odom``), as rcl resolves the relative name (``odom``) the robot's
    node uses; the :data:`GLOBAL_TOPICS` stay as they are. For lists of names written once
    for the root namespace: what a run records, what a layout shows."""
    namespace = node_namespace(namespace)
    if namespace == "/" or topic in GLOBAL_TOPICS:
        return validate_full_topic_name(topic)
    return fully_qualified_name(validate_full_topic_name(topic)[1:], namespace)
