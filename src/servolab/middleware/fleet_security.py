"""Who may join a fleet's router and what each member may publish, from a servolab file,
turned into Zenoh's own TLS and access control (``servolab router --security FILE``).

Zenoh and DDS let in any peer that can reach them. A fleet's router closes that door with
Zenoh's two mechanisms (its manual, "TLS authentication" and "Access Control"):

* **mutual TLS**: the router listens on ``tls/`` endpoints only, shows its certificate, and
  asks each client for one signed by the fleet's authority (``enable_mtls``); a client
  without one never gets a session (the handshake fails);
* **access control** on what comes in, by the common name of the client's certificate
  (``cert_common_names``): only the ``members`` listed may exchange anything (Zenoh's
  ``default_permission: deny``; a certificate of the same authority with another name
  connects but every message it sends or asks for is dropped), and each member may
  *publish* only the topics it is given: its other publications are dropped at the router.

Why a list of what each member may publish, not of what it may not: Zenoh's decision point
applies a rule to a message when the rule's key expression *includes* the message's
(``policy_decision_point``, ``nodes_including``), and a publication may be made on a wildcard
key. A rule "deny ``*/*/cmd_vel/*/*``" does not include a put on ``0/robot1/**``, which still
reaches the robot's ``cmd_vel`` subscriber; an allow-list is sound, since nothing but the
allowed expressions includes it.

The file (YAML; paths are relative to it)::

    tls:
      ca: certs/ca.pem                   # the fleet's authority (servolab certs)
      certificate: certs/router.pem      # the router's own
      private_key: certs/router-key.pem
    members:                             # certificate name: the topics it may publish
      fleet_manager: [/**]               # anything
      robot1: [/robot1/**, /tf, /tf_static, /rosout, /parameter_events]
      operator: [/operator/**, /rosout]

Topics are named as ROS names them (``*`` one name, ``**`` any number) and matched on the keys
rmw_zenoh puts them at (``<domain>/<name>/<type>/<hash>``,
:func:`~.rmw_zenoh.topic_keyexpr`), in every domain and for every type: ``/*/cmd_vel`` becomes
``*/*/cmd_vel/*/*``, ``/**`` every key. Everything but publishing -- subscribing, services,
actions' goals (queries and replies), the graph (liveliness) -- is every member's.
"""

from __future__ import annotations

import base64
import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import zenoh

from .. import configfile
from ..configfile import ConfigValue
from ..errors import ConfigFileError
from .certificates import CertificateError, check_name
from .errors import MiddlewareValueError

#: A ROS name's token (rcl's rules: letters, digits and underscores, no digit first).
_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
#: Every message kind Zenoh's access control knows (its manual, "rules").
ALL_MESSAGES = ("put", "delete", "declare_subscriber", "query", "declare_queryable", "reply",
                "liveliness_token", "declare_liveliness_subscriber", "liveliness_query")
#: What publishing is, to Zenoh.
PUBLISH = ("put", "delete")


@dataclass(frozen=True)
class RouterTls:
    """The router's side of mutual TLS: the authority clients must be signed by, and the
    router's own certificate and key."""

    ca: Path
    certificate: Path
    private_key: Path


@dataclass(frozen=True)
class FleetSecurity:
    """A fleet's security file, checked (:func:`load`)."""

    source: Path
    tls: RouterTls
    #: certificate common name -> the ROS topic patterns it may publish
    members: tuple[tuple[str, tuple[str, ...]], ...]


def topic_keyexpr_pattern(pattern: str) -> str:
    """The Zenoh key expression that matches what rmw_zenoh puts for topics matching the ROS
    name pattern (``/*/cmd_vel`` -> ``*/*/cmd_vel/*/*``: any domain, any type and hash;
    ``/**``: every key)."""
    if pattern == "/**":
        return "**"
    if not pattern.startswith("/") or pattern.endswith("/") or "//" in pattern:
        raise MiddlewareValueError("is not an absolute ROS name such as /robot1/cmd_vel or "
                                   "/*/cmd_vel")
    for part in pattern[1:].split("/"):
        if part not in ("*", "**") and not _TOKEN.fullmatch(part):
            raise MiddlewareValueError(f"has {part!r}: each name is letters, digits and '_' "
                                       "(not starting with a digit), or * (one name) or ** "
                                       "(any number)")
    return str(zenoh.KeyExpr.autocanonize(f"*{pattern}/*/*"))


def _file(value: ConfigValue, base: Path) -> Path:
    path = base / value.as_str(nonempty=True)
    if not path.is_file():
        raise value.error(f"{path}: no such file (make the fleet's certificates with "
                          "'servolab certs')")
    return path


def _member(value: ConfigValue) -> str:
    """A member's name, checked as ``servolab certs`` checks a certificate's name."""
    try:
        return check_name(value.as_str(nonempty=True))
    except CertificateError as exc:
        raise value.error(str(exc)) from None


def load(path: Path) -> FleetSecurity:
    """Read and check a security file; every problem is one line naming the file, line and
    key, before the router opens anything."""
    root = configfile.load(path, what="fleet security file").as_mapping("the security file")
    root.check_keys(("tls", "members"), required=("tls", "members"))
    base = path.parent
    tls_value = root.require("tls").as_mapping("tls")
    tls_value.check_keys(("ca", "certificate", "private_key"),
                         required=("ca", "certificate", "private_key"), what="tls")
    tls = RouterTls(*(_file(tls_value.require(k), base)
                      for k in ("ca", "certificate", "private_key")))
    members_value = root.require("members").as_mapping("members")
    if not len(members_value):
        raise members_value.error("no members: name the certificates that may join, each "
                                  "with the topics it may publish")
    members = []
    for name, topics in members_value.items():
        _member(members_value.key_of(name))
        patterns = []
        for item in topics.as_list(f"member {name!r}: the topics it may publish"):
            pattern = item.as_str(nonempty=True)
            try:
                topic_keyexpr_pattern(pattern)
            except MiddlewareValueError as exc:
                raise item.error(f"member {name!r}: topic {pattern!r} {exc}") from None
            patterns.append(pattern)
        members.append((name, tuple(patterns)))
    return FleetSecurity(path, tls, tuple(members))


def tls_json(tls: RouterTls) -> str:
    """The router's ``transport/link/tls`` (Zenoh's keys), mutual."""
    return json.dumps({"root_ca_certificate": str(tls.ca.resolve()),
                       "listen_certificate": str(tls.certificate.resolve()),
                       "listen_private_key": str(tls.private_key.resolve()),
                       "enable_mtls": True})


def access_control(security: FleetSecurity) -> dict[str, Any]:
    """Zenoh's ``access_control`` for the file (module docstring): deny by default; each
    member one subject (its certificate's common name), allowed everything but publishing,
    the router's deliveries to it, and publishing on its own topics."""
    rules: list[dict[str, Any]] = [
        {"id": "member", "permission": "allow", "flows": ["ingress", "egress"],
         "messages": [m for m in ALL_MESSAGES if m not in PUBLISH], "key_exprs": ["**"]},
        {"id": "delivered", "permission": "allow", "flows": ["egress"],
         "messages": list(PUBLISH), "key_exprs": ["**"]}]
    subjects, policies = [], []
    for number, (name, topics) in enumerate(security.members):
        rule = ["member", "delivered"]
        if topics:
            rules.append({"id": f"publishes_{number}", "permission": "allow",
                          "flows": ["ingress"], "messages": list(PUBLISH),
                          "key_exprs": sorted({topic_keyexpr_pattern(t) for t in topics})})
            rule.append(f"publishes_{number}")
        subjects.append({"id": name, "cert_common_names": [name]})
        policies.append({"id": f"policy_{number}", "rules": rule, "subjects": [name]})
    return {"enabled": True, "default_permission": "deny", "rules": rules,
            "subjects": subjects, "policies": policies}


def secure(config: zenoh.Config, security: FleetSecurity) -> None:
    """Put the file's TLS and access control into a router's configuration."""
    try:
        config.insert_json5("transport/link/tls", tls_json(security.tls))
        config.insert_json5("access_control", json.dumps(access_control(security)))
    except zenoh.ZError as exc:   # a bug here, not the user's: say which file led to it
        raise ConfigFileError(security.source, 0, "", f"Zenoh refused the configuration made "
                              f"from it: {exc}") from None


def client_json5(ca: Path, certificate: Path, private_key: Path) -> str:
    """A client's session configuration for ``$ZENOH_SESSION_CONFIG_URI``: a client of the
    fleet's router (rmw_zenoh's way for a node on another host) that shows its certificate.
    The three files go in it whole (Zenoh's ``*_base64`` keys), so the one file is all a
    member's machine needs, wherever it is put; it holds the private key, so it is as
    private as the key."""
    def encoded(path: Path) -> str:
        return base64.b64encode(path.read_bytes()).decode("ascii")

    tls = {"root_ca_certificate_base64": encoded(ca),
           "connect_certificate_base64": encoded(certificate),
           "connect_private_key_base64": encoded(private_key),
           "enable_mtls": True}
    return ("// a client of the fleet's router, showing its certificate (servolab certs);\n"
            "// it holds the member's private key: keep it private\n"
            + json.dumps({"mode": "client", "transport": {"link": {"tls": tls}}}, indent=2)
            + "\n")
