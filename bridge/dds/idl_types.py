"""Cyclone DDS topic types built at run time from the registry's ROS message specs.

Cyclone's Python binding registers a topic type from an `IdlStruct` class: its name and its
XTypes type information go into discovery, and incoming samples are checked against it. The
mirror never builds or reads instances of these classes: it writes rosbags' CDR bytes and
takes CDR bytes (`bridge.dds.participant`). The classes exist so that Cyclone announces the
ROS 2 type name (`sensor_msgs::msg::dds_::Imu_`) with the structure ROS 2 uses, which is what
other participants match on (by name, or by XTypes assignability when they send type
information too).

Primitive mapping follows ROS 2's rosidl: `byte` is an octet, `char` a uint8, `string<=N` a
bounded string, `T[N]` an array, `T[]`/`T[<=N]` a (bounded) sequence. A message without
fields gets ROS 2's `uint8 structure_needs_at_least_one_member`. A service's request and
reply types carry rmw_cyclonedds's 16-byte request header in front of their fields.
"""

from __future__ import annotations

import threading
from typing import Any

import cyclonedds.idl.types as idl
from cyclonedds.idl import IdlStruct, make_idl_struct

from bridge.dds.naming import type_to_dds
from schemas.specs import FieldSpec, MessageSpec

# cyclonedds's `array[T, N]`, `sequence[T]` and `bounded_str[N]` are typing-style subscripts
# at run time; mypy does not know them as generics.
_array: Any = idl.array
_sequence: Any = idl.sequence
_bounded_str: Any = idl.bounded_str

PRIMITIVES: dict[str, Any] = {
    "bool": bool,
    "byte": idl.byte,
    "char": idl.uint8,
    "int8": idl.int8,
    "uint8": idl.uint8,
    "int16": idl.int16,
    "uint16": idl.uint16,
    "int32": idl.int32,
    "uint32": idl.uint32,
    "int64": idl.int64,
    "uint64": idl.uint64,
    "float32": idl.float32,
    "float64": idl.float64,
    "string": str,
}
EMPTY_PLACEHOLDER = "structure_needs_at_least_one_member"
# rmw_cyclonedds_cpp's cdds_request_header_t, under its member names (peers that send XTypes
# type information compare them): the client's writer handle, then its sequence number.
REQUEST_HEADER_FIELDS = {"guid": idl.uint64, "seq": idl.int64}


class UnsupportedTypeError(ValueError):
    """A field the DDS mapping cannot express (wstring)."""


class IdlTypes:
    """Builds and caches one IdlStruct class per ROS type (thread-safe)."""

    def __init__(self) -> None:
        self._classes: dict[tuple[str, bool], type[IdlStruct]] = {}
        self._lock = threading.Lock()

    def message(self, spec: MessageSpec) -> type[IdlStruct]:
        """The class announcing `spec` as `pkg::msg::dds_::T_`."""
        with self._lock:
            return self._build(spec, with_request_header=False)

    def service_part(self, spec: MessageSpec) -> type[IdlStruct]:
        """The class for a `…_Request`/`…_Response` spec with the request header in front."""
        with self._lock:
            return self._build(spec, with_request_header=True)

    def _build(self, spec: MessageSpec, with_request_header: bool) -> type[IdlStruct]:
        key = (spec.name, with_request_header)
        cached = self._classes.get(key)
        if cached is not None:
            return cached
        fields: dict[str, Any] = dict(REQUEST_HEADER_FIELDS) if with_request_header else {}
        for field in spec.fields:
            if field.name in fields:
                raise UnsupportedTypeError(
                    f"{spec.name} has a field {field.name} that clashes with the request header"
                )
            fields[field.name] = self._field_type(field)
        if not spec.fields:
            fields[EMPTY_PLACEHOLDER] = idl.uint8
        dds_name = type_to_dds(spec.name)
        class_name = dds_name.replace("::", "_") + (
            "_with_request_header" if with_request_header else ""
        )
        built = make_idl_struct(class_name, dds_name, fields)
        self._classes[key] = built
        return built

    def _field_type(self, field: FieldSpec) -> Any:
        if field.is_message:
            assert field.message is not None
            element = self._build(field.message, with_request_header=False)
        elif field.base == "string" and field.string_bound:
            element = _bounded_str[field.string_bound]
        elif field.base in PRIMITIVES:
            element = PRIMITIVES[field.base]
        else:
            raise UnsupportedTypeError(
                f"field {field.name} of type {field.base} has no DDS mapping here"
            )
        if field.array == "fixed":
            return _array[element, field.length]
        if field.array == "bounded":
            return _sequence[element, field.length]
        if field.array == "sequence":
            return _sequence[element]
        return element


def discovery_info_type(gid_bytes: int) -> type[IdlStruct]:
    """`rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_` with GIDs of `gid_bytes` (24 in
    Humble, 16 since Jazzy: `bridge.dds.discovery_info`); the registry knows only Jazzy's."""
    suffix = f"_gid{gid_bytes}"
    gid = make_idl_struct(
        "Gid" + suffix, "rmw_dds_common::msg::dds_::Gid_", {"data": _array[idl.uint8, gid_bytes]}
    )
    node = make_idl_struct(
        "NodeEntitiesInfo" + suffix,
        "rmw_dds_common::msg::dds_::NodeEntitiesInfo_",
        {
            "node_namespace": _bounded_str[256],
            "node_name": _bounded_str[256],
            "reader_gid_seq": _sequence[gid],
            "writer_gid_seq": _sequence[gid],
        },
    )
    return make_idl_struct(
        "ParticipantEntitiesInfo" + suffix,
        "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_",
        {"gid": gid, "node_entities_info_seq": _sequence[node]},
    )
