"""The sockets a process listens on, as ``ss -ltun -p`` lists them (Linux's ``/proc``).

What servolab says it opens and what the kernel says it opened are two facts; a library may
bind more widely than it was asked (Cyclone DDS binds its unicast ports to every interface
when it uses one: ``ddsi_init.c``, ``make_uc_sockets``, ``m_bind_to_any = !per_interface_uc``).
So where it matters servolab reads the kernel's table, not its own configuration: the DDS
transport names its sockets at start from here, and a test checks that nothing listens beyond
loopback by default. Elsewhere than Linux the table is not there, and nothing is listed.
"""

from __future__ import annotations

import ipaddress
import os
import socket
from dataclasses import dataclass
from pathlib import Path

#: TCP state LISTEN in /proc/net/tcp (include/net/tcp_states.h: TCP_LISTEN = 10)
_TCP_LISTEN = "0A"
#: UDP sockets are all "unconnected" (TCP_CLOSE = 7) while they only receive
_UDP_UNCONNECTED = "07"


@dataclass(frozen=True, order=True)
class ListeningSocket:
    """One socket that accepts connections (TCP) or datagrams (UDP) from others."""

    protocol: str  # "tcp" or "udp"
    address: str   # "127.0.0.1", "0.0.0.0", "::1", "::"
    port: int

    @property
    def loopback_only(self) -> bool:
        return ipaddress.ip_address(self.address).is_loopback

    def __str__(self) -> str:
        host = f"[{self.address}]" if ":" in self.address else self.address
        return f"{self.protocol.upper()} {host}:{self.port}"


def _address(hex_address: str) -> tuple[str, int]:
    """``0100007F:1CF2`` (little-endian words, as /proc writes them) -> ("127.0.0.1", 7410)."""
    host, port = hex_address.split(":")
    raw = bytes.fromhex(host)
    # /proc writes each 32-bit word in host byte order
    raw = b"".join(raw[i:i + 4][::-1] for i in range(0, len(raw), 4)) \
        if socket.htonl(1) != 1 else raw
    family = socket.AF_INET if len(raw) == 4 else socket.AF_INET6
    return socket.inet_ntop(family, raw), int(port, 16)


def _socket_inodes(pid: int) -> set[str]:
    inodes: set[str] = set()
    fd_dir = Path(f"/proc/{pid}/fd")
    try:
        entries = list(fd_dir.iterdir())
    except OSError:
        return inodes
    for fd in entries:
        try:
            target = os.readlink(fd)
        except OSError:
            continue  # closed meanwhile
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    return inodes


def listening(pid: int | None = None) -> list[ListeningSocket]:
    """Every TCP socket in LISTEN and UDP socket bound to a port of process ``pid`` (this
    one by default), sorted; ``[]`` where ``/proc`` is not there."""
    pid = os.getpid() if pid is None else pid
    inodes = _socket_inodes(pid)
    found: set[ListeningSocket] = set()
    for protocol, state in (("tcp", _TCP_LISTEN), ("udp", _UDP_UNCONNECTED)):
        for table in (protocol, protocol + "6"):
            try:
                lines = Path(f"/proc/{pid}/net/{table}").read_text().splitlines()[1:]
            except OSError:
                continue
            for line in lines:
                fields = line.split()
                if len(fields) > 9 and fields[3] == state and fields[9] in inodes:
                    address, port = _address(fields[1])
                    if port:
                        found.add(ListeningSocket(protocol, address, port))
    return sorted(found)


def beyond_loopback(sockets: list[ListeningSocket]) -> list[ListeningSocket]:
    """The sockets another computer could reach."""
    return [s for s in sockets if not s.loopback_only]
