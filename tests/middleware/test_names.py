"""ROS 2 names, checked against ROS 2's own rules and test cases.

Where the rules and cases come from (ros2/rmw, ros2/rcl and ros2/rclpy, rolling):

- node names: rmw ``rmw/src/validate_node_name.c``, cases from
  ``rmw/test/test_validate_node_name.cpp``
- namespaces: rmw ``rmw/src/validate_namespace.c``, cases from
  ``rmw/test/test_validate_namespace.cpp``; a node's namespace completed as rcl's
  ``rcl/src/rcl/node.c`` (``rcl_node_init``) and rclpy's ``rclpy/node.py`` do
- names as written (relative, ``~``, ``{}``): rcl ``rcl/src/rcl/validate_topic_name.c``, cases
  from ``rcl/test/rcl/test_validate_topic_name.cpp``
- expanded names: rmw ``rmw/src/validate_full_topic_name.c``, cases from
  ``rmw/test/test_validate_full_topic_name.cpp``; expansion as rcl's
  ``rcl/src/rcl/expand_topic_name.c``, cases from ``rcl/test/rcl/test_expand_topic_name.cpp``
- enclaves: rcl ``rcl/src/rcl/validate_enclave_name.c``
- the message layout: rclpy ``rclpy/exceptions.py`` (``NameValidationException``), raised by
  ``rclpy/validate_node_name.py``, ``validate_namespace.py``, ``validate_topic_name.py`` and
  ``validate_full_topic_name.py``; the rule texts are rmw's and rcl's
  ``*_validation_result_string``.
"""

from __future__ import annotations

import pickle
from pathlib import Path

import pytest

from servolab.middleware import Context, MiddlewareError, NameValidationError, Node
from servolab.middleware.errors import LaunchError, MessageError
from servolab.middleware.launch_file import load_launch
from servolab.middleware.names import (
    ENCLAVE_NAME_MAX_LENGTH,
    NAMESPACE_MAX_LENGTH,
    NODE_NAME_MAX_LENGTH,
    TOPIC_NAME_MAX_LENGTH,
    check_node_name,
    expand_topic_name,
    fully_qualified_name,
    node_namespace,
    validate_enclave_name,
    validate_full_topic_name,
    validate_namespace,
    validate_node_name,
    validate_topic_name,
)


def caret_index(error: NameValidationError) -> int:
    """The index into the name that the caret of the message points at."""
    _, shown, caret = str(error).split("\n")
    assert shown.startswith("  '") and shown.endswith("'")
    assert caret.strip() == "^"
    return len(caret) - len("   ^")


def refused(check: object, name: str, **kwargs: object) -> NameValidationError:
    assert callable(check)
    with pytest.raises(NameValidationError) as info:
        check(name, **kwargs)
    return info.value


# -- the error ------------------------------------------------------------------------------

def test_the_message_is_rclpys_with_the_caret_under_the_bad_character() -> None:
    error = refused(validate_node_name, "my-node")
    assert str(error) == (
        "Invalid node name: node name must not contain characters other than alphanumerics "
        "or '_':\n"
        "  'my-node'\n"
        "     ^")
    assert (error.kind, error.name, error.index) == ("node name", "my-node", 2)
    assert error.reason == ("node name must not contain characters other than alphanumerics "
                            "or '_'")
    assert error.summary == ("invalid node name 'my-node': node name must not contain "
                             "characters other than alphanumerics or '_' (index 2)")
    assert "\n" not in error.summary


def test_the_error_is_a_middleware_and_value_error_not_a_message_error() -> None:
    error = refused(check_node_name, "1talker")
    assert isinstance(error, MiddlewareError) and isinstance(error, ValueError)
    assert not isinstance(error, MessageError)


def test_unprintable_characters_are_shown_escaped_so_the_display_keeps_its_lines() -> None:
    error = refused(validate_node_name, "a\nb-c")
    assert str(error).split("\n")[1:] == ["  'a\\nb-c'", "    ^"]
    error = refused(validate_node_name, "ab\tc")
    assert str(error).split("\n")[1:] == ["  'ab\\tc'", "     ^"]


def test_the_error_pickles() -> None:
    error = refused(validate_namespace, "/a//b")
    again = pickle.loads(pickle.dumps(error))
    assert type(again) is NameValidationError and str(again) == str(error)


# -- node names (rmw validate_node_name.c) --------------------------------------------------

@pytest.mark.parametrize("name", ["nodename", "node_name", "_hidden", "N0de", "a" * 255])
def test_valid_node_names(name: str) -> None:
    assert validate_node_name(name) == check_node_name(name) == name


@pytest.mark.parametrize(("name", "reason", "index"), [
    ("", "node name must not be empty", 0),
    ("node/name", "must not contain characters other than alphanumerics or '_'", 4),
    ("node_{name}", "must not contain characters other than alphanumerics or '_'", 5),
    ("~node_name", "must not contain characters other than alphanumerics or '_'", 0),
    ("with spaces", "must not contain characters other than alphanumerics or '_'", 4),
    ("with.periods", "must not contain characters other than alphanumerics or '_'", 4),
    ("nöde", "must not contain characters other than alphanumerics or '_'", 1),  # ASCII only
    ("42node", "node name must not start with a number", 0),
    ("4-2", "must not contain characters", 1),  # characters are checked first
    ("a" * 256, "node name length should not exceed '255'", NODE_NAME_MAX_LENGTH - 1),
])
def test_invalid_node_names(name: str, reason: str, index: int) -> None:
    error = refused(validate_node_name, name)
    assert str(error).startswith("Invalid node name: ") and reason in error.reason
    assert error.index == index == caret_index(error)


# -- namespaces (rmw validate_namespace.c) --------------------------------------------------

@pytest.mark.parametrize("namespace", ["/", "/basename_only", "/with_one/heirarchy",
                                       "/_private", "/" + "a" * (NAMESPACE_MAX_LENGTH - 1)])
def test_valid_namespaces(namespace: str) -> None:
    assert validate_namespace(namespace) == namespace


@pytest.mark.parametrize(("namespace", "reason", "index"), [
    ("", "namespace must not be empty", 0),
    ("not_absolute", "namespace must be absolute, it must lead with a '/'", 0),
    ("/ends/with/", "namespace must not end with a '/', unless only a '/'", 10),
    ("/~/unexpanded_tilde", "characters other than alphanumerics, '_', or '/'", 1),
    ("/unexpanded_sub/{node}", "characters other than alphanumerics, '_', or '/'", 16),
    ("/question?", "characters other than alphanumerics, '_', or '/'", 9),
    ("/with spaces", "characters other than alphanumerics, '_', or '/'", 5),
    ("/repeated//slashes", "namespace must not contain repeated '/'", 10),
    ("/9starts_with_number", "namespace must not have a token that starts with a number", 1),
    ("/starts/42with/number", "namespace must not have a token that starts with a number", 8),
    ("/" + "a" * NAMESPACE_MAX_LENGTH, f"should not exceed '{NAMESPACE_MAX_LENGTH}'",
     NAMESPACE_MAX_LENGTH - 1),
])
def test_invalid_namespaces(namespace: str, reason: str, index: int) -> None:
    error = refused(validate_namespace, namespace)
    assert str(error).startswith("Invalid namespace: ") and reason in error.reason
    assert error.index == index == caret_index(error)


@pytest.mark.parametrize(("given", "expected"), [
    ("", "/"), ("/", "/"), ("robot1", "/robot1"), ("/robot1", "/robot1"), ("a/b", "/a/b"),
])
def test_a_nodes_namespace_is_completed_as_rcl_node_init_does(given: str,
                                                              expected: str) -> None:
    assert node_namespace(given) == node_namespace(given, "talker") == expected


@pytest.mark.parametrize(("given", "shown", "index"), [
    ("robot-1", "/robot-1", 6),   # shown completed, as rclpy shows it
    ("/robot1/", "/robot1/", 7),
    ("~/x", "/~/x", 1),           # no ~ in a namespace: only topic names expand it
    ("1robot", "/1robot", 1),
])
def test_bad_node_namespaces(given: str, shown: str, index: int) -> None:
    error = refused(node_namespace, given)
    assert error.name == shown and error.index == index == caret_index(error)


# -- enclaves (rcl validate_enclave_name.c) -------------------------------------------------

def test_enclaves_follow_namespace_rules_with_their_own_length_and_words() -> None:
    assert validate_enclave_name("/secure") == "/secure"
    long_enclave = "/" + "a" * (ENCLAVE_NAME_MAX_LENGTH - 1)  # too long for a namespace
    assert validate_enclave_name(long_enclave) == long_enclave
    error = refused(validate_enclave_name, long_enclave + "a")
    assert error.index == ENCLAVE_NAME_MAX_LENGTH - 1
    assert refused(validate_enclave_name, "secure").reason == (
        "context name must be absolute, it must lead with a '/'")


# -- topic names as written (rcl validate_topic_name.c) -------------------------------------

@pytest.mark.parametrize("name", [
    "chatter", "foo/bar", "~", "~/foo", "{node}", "{node}/foo", "{ns}/foo", "/foo",
    "/bar/baz", "/_private/thing", "/public_namespace/_private/thing", "{foo1}", "{foo_bar}",
    "{_bar}", "a//b",  # repeated / is only caught once expanded
    "~x",  # rcl does not look at the last character, so a two-character ~x passes
])
def test_valid_topic_names_as_written(name: str) -> None:
    assert validate_topic_name(name) == validate_topic_name(name, is_service=True) == name


@pytest.mark.parametrize(("name", "reason", "index"), [
    ("123abc", "topic name token must not start with a number", 0),
    ("123", "topic name token must not start with a number", 0),
    (" ", "characters other than alphanumerics, '_', '~', '{', or '}'", 0),
    ("foo bar", "characters other than alphanumerics, '_', '~', '{', or '}'", 3),
    ("/~", "must not have tilde '~' unless it is the first character", 1),
    ("~foo", "tilde '~' that is not followed by a forward slash '/'", 1),
    ("foo~", "must not have tilde '~' unless it is the first character", 3),
    ("foo~/bar", "must not have tilde '~' unless it is the first character", 3),
    ("foo/~bar", "must not have tilde '~' unless it is the first character", 4),
    ("foo/~/bar", "must not have tilde '~' unless it is the first character", 4),
    ("foo/", "topic name must not end with a forward slash", 3),
    ("", "topic name must not be empty string", 0),
    ("foo/123bar", "topic name token must not start with a number", 4),
    ("foo/bar}/baz", "unmatched (unbalanced) curly braces '{}'", 7),
    ("foo/{bar", "unmatched (unbalanced) curly braces '{}'", 4),
    ("{$}", "substitution name must not contain characters other than alphanumerics", 1),
    ("{{bar}_baz}", "substitution name must not contain characters other than alphanumerics",
     1),
    ("foo/{bar/baz}", "substitution name must not contain characters other than alphanumerics",
     8),
    ("{1foo}", "substitution name must not start with a number", 1),
])
def test_invalid_topic_names_as_written(name: str, reason: str, index: int) -> None:
    error = refused(validate_topic_name, name)
    assert str(error).startswith("Invalid topic name: ") and reason in error.reason
    assert error.index == index == caret_index(error)
    assert str(refused(validate_topic_name, name, is_service=True)).startswith(
        "Invalid service name: ")


# -- expanded names (rmw validate_full_topic_name.c) ----------------------------------------

@pytest.mark.parametrize("name", ["/basename_only", "/with_one/namespace", "/_x",
                                  "/" + "a" * (TOPIC_NAME_MAX_LENGTH - 1)])
def test_valid_full_topic_names(name: str) -> None:
    assert validate_full_topic_name(name) == name


@pytest.mark.parametrize(("name", "reason", "index"), [
    ("", "topic name must not be empty", 0),
    ("not_absolute", "topic name must be absolute, it must lead with a '/'", 0),
    ("/ends/with/", "topic name must not end with a '/'", 10),
    ("/", "topic name must not end with a '/'", 0),
    ("/~/unexpanded_tilde", "characters other than alphanumerics, '_', or '/'", 1),
    ("/unexpanded_sub/{node}", "characters other than alphanumerics, '_', or '/'", 16),
    ("/question?", "characters other than alphanumerics, '_', or '/'", 9),
    ("/with spaces", "characters other than alphanumerics, '_', or '/'", 5),
    ("/repeated//slashes", "topic name must not contain repeated '/'", 10),
    ("/9starts_with_number", "topic name must not have a token that starts with a number", 1),
    ("/starts/42with/number", "topic name must not have a token that starts with a number", 8),
    ("/" + "a" * TOPIC_NAME_MAX_LENGTH, f"should not exceed '{TOPIC_NAME_MAX_LENGTH}'",
     TOPIC_NAME_MAX_LENGTH - 1),
])
def test_invalid_full_topic_names(name: str, reason: str, index: int) -> None:
    error = refused(validate_full_topic_name, name)
    assert reason in error.reason and error.index == index == caret_index(error)


# -- expansion (rcl expand_topic_name.c) ----------------------------------------------------

@pytest.mark.parametrize(("name", "node", "namespace", "expected"), [
    ("/chatter", "my_node", "/my_ns", "/chatter"),
    ("chatter", "my_node", "/my_ns", "/my_ns/chatter"),
    ("{node}/chatter", "my_node", "/my_ns", "/my_ns/my_node/chatter"),
    ("/{node}", "my_node", "/my_ns", "/my_node"),
    ("{node}", "my_node", "/my_ns", "/my_ns/my_node"),
    ("{ns}", "my_node", "/my_ns", "/my_ns"),
    ("{namespace}", "my_node", "/my_ns", "/my_ns"),
    ("{namespace}/{node}/chatter", "my_node", "/my_ns", "/my_ns/my_node/chatter"),
    ("/foo/{namespace}", "my_node", "/my_ns", "/foo//my_ns"),  # valid until checked in full
    ("ping", "my_node", "/", "/ping"),
    ("ping", "my_node", "/my_ns", "/my_ns/ping"),
    ("/ping", "my_node", "/", "/ping"),
    ("~", "my_node", "/", "/my_node"),
    ("~", "my_node", "/my_ns", "/my_ns/my_node"),
    ("~/ping", "my_node", "/", "/my_node/ping"),
    ("~/ping", "my_node", "/my_ns", "/my_ns/my_node/ping"),
])
def test_expansion_is_rcls(name: str, node: str, namespace: str, expected: str) -> None:
    assert expand_topic_name(name, node, namespace) == expected


def test_expansion_checks_its_inputs_and_knows_only_rcls_substitutions() -> None:
    assert refused(expand_topic_name, "x", node_name="1n", namespace="/").kind == "node name"
    assert refused(expand_topic_name, "x", node_name="n", namespace="ns").kind == "namespace"
    error = refused(expand_topic_name, "a/{foo}", node_name="n", namespace="/")
    assert error.reason.startswith("unknown substitution: {foo}") and caret_index(error) == 2


# -- what a node resolves -------------------------------------------------------------------

@pytest.mark.parametrize(("name", "namespace", "node", "expected"), [
    ("chatter", "/robot1", "", "/robot1/chatter"),
    ("chatter", "/", "", "/chatter"),
    ("chatter", "", "", "/chatter"),
    ("chatter", "robot1", "", "/robot1/chatter"),
    ("a/b", "/r/s", "", "/r/s/a/b"),
    ("/chatter", "/robot1", "talker", "/chatter"),
    ("~/x", "/robot1", "talker", "/robot1/talker/x"),
    ("~/x", "/", "talker", "/talker/x"),
    ("~", "/robot1", "talker", "/robot1/talker"),
    ("{node}/x", "/robot1", "talker", "/robot1/talker/x"),
    ("{ns}/x", "/robot1", "", "/robot1/x"),
    ("_hidden", "/", "", "/_hidden"),
])
def test_fully_qualified_name(name: str, namespace: str, node: str, expected: str) -> None:
    assert fully_qualified_name(name, namespace, node) == expected


@pytest.mark.parametrize(("bad", "shown", "index"), [
    ("", "", 0),
    ("a//b", "/robot1/a//b", 10),   # found in the expansion, which is what is shown
    ("a/", "a/", 1),
    ("1abc", "1abc", 0),
    ("a/2b", "a/2b", 2),
    ("chat-ter", "chat-ter", 4),
    ("~y/x", "~y/x", 1),
    ("{foo}", "{foo}", 0),
    ("a b", "a b", 1),
])
def test_bad_names_are_refused_showing_where(bad: str, shown: str, index: int) -> None:
    error = refused(fully_qualified_name, bad, namespace="/robot1", node_name="talker")
    assert error.kind == "topic name"
    assert (error.name, error.index) == (shown, index) and caret_index(error) == index


def test_ns_substitution_at_the_root_gives_a_repeated_slash() -> None:
    # rcl puts the namespace in as it is: at the root, {ns}/x is "/" + "/x".
    error = refused(fully_qualified_name, "{ns}/x", namespace="/", node_name="talker")
    assert (error.name, error.index) == ("//x", 1)
    assert "repeated '/'" in error.reason


def test_service_names_are_called_so() -> None:
    error = refused(fully_qualified_name, "add two", namespace="/", is_service=True)
    assert str(error).startswith("Invalid service name: ")


def test_bad_namespaces_and_node_names_are_refused() -> None:
    assert refused(fully_qualified_name, "chatter", namespace="/robot1/").kind == "namespace"
    error = refused(fully_qualified_name, "~/x", namespace="/", node_name="1talker")
    assert error.kind == "node name" and error.name == "1talker"
    assert "needs a node name" in refused(fully_qualified_name, "~/x",
                                          namespace="/robot1").reason
    assert "needs a node name" in refused(fully_qualified_name, "{node}",
                                          namespace="/robot1").reason


# -- through a node and a launch file -------------------------------------------------------

def test_a_node_with_a_bad_name_raises_name_validation_error() -> None:
    with Context.open() as ctx:
        with pytest.raises(NameValidationError) as info:
            Node(ctx, "bad-name")
        assert str(info.value).split("\n") == [
            "Invalid node name: node name must not contain characters other than "
            "alphanumerics or '_':", "  'bad-name'", "      ^"]
        with pytest.raises(NameValidationError, match="Invalid namespace"):
            Node(ctx, "good", "/bad ns")
        node = Node(ctx, "n", "/robot1")
        with pytest.raises(NameValidationError) as info:
            node.create_publisher("std_msgs/msg/Empty", "cmd//vel")
        assert info.value.name == "/robot1/cmd//vel" and caret_index(info.value) == 12
        assert node.resolve("~/state") == "/robot1/n/state"


def test_a_launch_file_names_a_bad_node_name_in_one_line(tmp_path: Path) -> None:
    path = tmp_path / "bad.launch.yaml"
    path.write_text("nodes:\n  - name: bad-name\n    node: m:C\n")
    with pytest.raises(LaunchError) as info:
        load_launch(path)
    assert str(info.value) == (
        f"{path}:2: node 'bad-name': key 'name': invalid node name 'bad-name': node name must "
        "not contain characters other than alphanumerics or '_' (index 3)")
