"""The one class a user meets: :class:`Bus`, every part of the driver on one object.

Why the parts are mixins on one object and not objects of their own: a part's checks and
learning call the others through the bus's own methods (the guard reads a motor's limits with
:meth:`Bus.read`, a scan PINGs with :meth:`Bus.ping`, a write of ``id`` goes through
:meth:`Bus.change_id`), and :class:`~..mixed_bus.MixedBus` overrides those methods to speak
each motor's protocol, so every call across parts must reach the subclass's method. Their
state, which does separate, is in objects the bus owns (:mod:`.core`).
"""

from __future__ import annotations

from dataclasses import dataclass

from .raw import RawAccess


@dataclass
class Bus(RawAccess):
    """Motors on one port, one protocol, one baud rate.

    ``protocol`` None means the port's own (an emulated bus knows its models'), else 2.
    ``retries`` is how many times a transaction that got no valid answer is sent again.
    ``timeout`` (s), when given, replaces the computed wait for a reply (wire time of the
    expected bytes + return delays + twice the adapter latency + 2 ms); a broadcast ping
    listens at least :meth:`broadcast_ping_wait` all the same.

    Its parts, each a module of :mod:`servolab.dynamixel.bus`: the link (:mod:`.link`),
    discovery (:mod:`.discovery`), the status return level (:mod:`.status_return`), the
    guard (:mod:`.guard`), reads and writes through plans (:mod:`.reads`, :mod:`.writes`,
    :mod:`.plans`), commissioning (:mod:`.commissioning`) and raw access (:mod:`.raw`).
    """
