"""ROS message types as Cyclone DDS types, built at run time from rosbags' definitions.

servolab writes and reads CDR bytes itself (rosbags' codec, byte-identical to what rclpy
writes), so a DDS type here serves one purpose: to register the topic under the right name
(``pkg::msg::dds_::Name_``) with the right structure, so that the XTypes type information
Cyclone DDS announces describes what is on the wire and a reader whose type disagrees does not
match. cyclonedds-python builds such types from annotations (``make_idl_struct``); this module
turns each rosbags field description into one.
"""

from __future__ import annotations

from typing import Any

from cyclonedds.idl import IdlStruct, make_idl_struct
from cyclonedds.idl import types as idl
from rosbags.interfaces import Nodetype

from .errors import MessageError
from .messages import MessageTypes
from .rmw_dds import dds_type_name

#: ROS 2 primitive types (rosidl ``.msg``) as IDL types; ``char`` is uint8 in ROS 2 IDL and
#: ``byte`` an octet (design article "Interface definition", "Field types").
_PRIMITIVES: dict[str, Any] = {
    "bool": bool, "byte": idl.byte, "char": idl.uint8,
    "int8": idl.int8, "uint8": idl.uint8, "int16": idl.int16, "uint16": idl.uint16,
    "int32": idl.int32, "uint32": idl.uint32, "int64": idl.int64, "uint64": idl.uint64,
    "float32": idl.float32, "float64": idl.float64,
}


class DdsTypes:
    """One Cyclone DDS type per ROS type name, made once."""

    def __init__(self, types: MessageTypes) -> None:
        self._types = types
        self._made: dict[tuple[str, bool], type[IdlStruct]] = {}

    def get(self, type_name: str, *, request_header: bool = False) -> type[IdlStruct]:
        """The type; with ``request_header``, a service half as a Cyclone DDS rmw puts it on
        the wire: the client id (uint64) and sequence number (int64) first, then the fields
        (rmw_cyclonedds ``serdata.hpp``, ``cdds_request_header_t``). Under the same DDS type
        name, so that Cyclone DDS checks each sample against what is really on the wire."""
        key = (type_name, request_header)
        made = self._made.get(key)
        if made is None:
            made = self._make(type_name, request_header)
            self._made[key] = made
        return made

    def _make(self, type_name: str, request_header: bool) -> type[IdlStruct]:
        try:
            _, fields = self._types.store.fielddefs[type_name]
        except KeyError:
            raise MessageError(f"no message type {type_name!r} to give DDS") from None
        annotations: dict[str, Any] = (
            {"rmw_client_id": idl.uint64, "rmw_sequence_number": idl.int64}
            if request_header else {})
        annotations.update({name: self._field(desc, f"{type_name}.{name}")
                            for name, desc in fields})
        short = type_name.rsplit("/", 1)[-1]
        return make_idl_struct(f"{short}_", dds_type_name(type_name), annotations)

    def _field(self, desc: tuple[Any, Any], where: str) -> Any:
        kind, detail = desc
        if kind == Nodetype.BASE:
            primitive, bound = detail
            if primitive == "string":
                return idl.bounded_str[bound] if bound else str  # type: ignore[misc]
            if primitive in _PRIMITIVES:
                return _PRIMITIVES[primitive]
            raise MessageError(f"{where}: {primitive} has no DDS type in servolab")
        if kind == Nodetype.NAME:
            return self.get(detail)
        if kind == Nodetype.ARRAY:
            element, count = detail
            return idl.array[self._field(element, where), count]  # type: ignore[misc]
        if kind == Nodetype.SEQUENCE:
            element, bound = detail
            inner = self._field(element, where)
            return (idl.sequence[inner, bound]  # type: ignore[misc]
                    if bound else idl.sequence[inner])  # type: ignore[misc]
        raise MessageError(f"{where}: field kind {kind!r} has no DDS type")
