"""CDR (the ROS 2 wire format, for ``cbor-raw`` and DDS) through rosbags' generated codecs.

Canonical dict <-> rosbags message object is the only code here: ``bytes`` become uint8
array views, numeric sequences pass as they are, fixed arrays become small ndarrays; the
serialization itself is rosbags' ``serialize_cdr``/``deserialize_cdr``. The bytes include
the 4-byte encapsulation header (``00 01 00 00``, little-endian CDR).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from schemas import specs
from schemas.errors import DecodeError, EncodeError
from schemas.specs import FieldSpec, MessageSpec
from schemas.values import Message

if TYPE_CHECKING:
    from schemas.registry import TypeRegistry


# -- canonical -> rosbags ---------------------------------------------------------------------


def _to_object(classes: Any, spec: MessageSpec, msg: Message) -> Any:
    values = {}
    for field in spec.fields:
        values[field.name] = _TO_ROSBAGS[field.category](classes, field, msg[field.name])
    return classes[spec.name](**values)


def _same(classes: Any, field: FieldSpec, value: Any) -> Any:
    return value


def _octet(classes: Any, field: FieldSpec, value: int) -> int:
    # rosbags packs a scalar ``byte`` as a signed char; ROS 2 octets are 0..255, same bits.
    return value - 256 if value > 127 and field.base == "byte" else value


def _bytes_to_array(classes: Any, field: FieldSpec, value: bytes) -> np.ndarray:
    return np.frombuffer(value, dtype=np.uint8)


def _contiguous(classes: Any, field: FieldSpec, value: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(value, dtype=field.dtype)


def _bools(classes: Any, field: FieldSpec, value: list[bool]) -> np.ndarray:
    return np.array(value, dtype=np.bool_)


def _nested(classes: Any, field: FieldSpec, value: Message) -> Any:
    return _to_object(classes, cast(MessageSpec, field.message), value)


def _nested_list(classes: Any, field: FieldSpec, value: list[Message]) -> list[Any]:
    spec = cast(MessageSpec, field.message)
    return [_to_object(classes, spec, item) for item in value]


# rosbags' message classes and objects are generated at run time: typed Any here.
_ToRosbags = Callable[[Any, FieldSpec, Any], Any]
_FromRosbags = Callable[[FieldSpec, Any], Any]

_TO_ROSBAGS: dict[str, _ToRosbags] = {
    specs.BOOL: _same,
    specs.INT: _octet,
    specs.FLOAT: _same,
    specs.STRING: _same,
    specs.MESSAGE: _nested,
    specs.BYTES: _bytes_to_array,
    specs.NUMERIC_SEQUENCE: _contiguous,
    specs.NUMERIC_FIXED: _contiguous,
    specs.BOOL_ARRAY: _bools,
    specs.STRING_ARRAY: _same,
    specs.MESSAGE_ARRAY: _nested_list,
}


# -- rosbags -> canonical ---------------------------------------------------------------------


def _to_canonical(spec: MessageSpec, obj: Any) -> Message:
    return {
        field.name: _FROM_ROSBAGS[field.category](field, getattr(obj, field.name))
        for field in spec.fields
    }


def _exact_array(field: FieldSpec, value: np.ndarray) -> np.ndarray:
    return value if value.dtype == field.dtype else value.astype(field.dtype)


def _nested_canonical(field: FieldSpec, value: Any) -> Message:
    return _to_canonical(cast(MessageSpec, field.message), value)


def _nested_canonical_list(field: FieldSpec, value: Any) -> list[Message]:
    spec = cast(MessageSpec, field.message)
    return [_to_canonical(spec, item) for item in value]


_FROM_ROSBAGS: dict[str, _FromRosbags] = {
    specs.BOOL: lambda field, value: bool(value),
    specs.INT: lambda field, value: int(value) & 0xFF if field.base == "byte" else int(value),
    specs.FLOAT: lambda field, value: float(value),
    specs.STRING: lambda field, value: str(value),
    specs.MESSAGE: _nested_canonical,
    specs.BYTES: lambda field, value: np.asarray(value, dtype=np.uint8).tobytes(),
    specs.NUMERIC_SEQUENCE: _exact_array,
    specs.NUMERIC_FIXED: lambda field, value: np.asarray(value).tolist(),
    specs.BOOL_ARRAY: lambda field, value: [bool(item) for item in value],
    specs.STRING_ARRAY: lambda field, value: list(value),
    specs.MESSAGE_ARRAY: _nested_canonical_list,
}


# -- public -----------------------------------------------------------------------------------


def to_cdr(registry: TypeRegistry, type_name: str, msg: Message) -> bytes:
    """Serialize a canonical message to CDR, 4-byte encapsulation header included."""
    spec = registry.message(type_name)
    store = registry.typestore
    try:
        obj = _to_object(store.types, spec, msg)
        return bytes(store.serialize_cdr(obj, spec.name))
    except (KeyError, TypeError, ValueError, AttributeError, OverflowError) as exc:
        raise EncodeError(f"cannot encode {spec.name} as CDR: {exc!r}") from None


def from_cdr(registry: TypeRegistry, type_name: str, data: bytes) -> Message:
    """Parse CDR bytes (with header) into the canonical message of ``type_name``."""
    spec = registry.message(type_name)
    try:
        obj = registry.typestore.deserialize_cdr(data, spec.name)
    except Exception as exc:  # rosbags raises assorted errors on short or corrupt data
        raise DecodeError(f"invalid CDR for {spec.name}: {exc!r}") from None
    return _to_canonical(spec, obj)


def cdr_size(registry: TypeRegistry, type_name: str, msg: Message) -> int:
    """Serialized size of ``msg`` in bytes (4-byte header included), without serializing.

    Uses rosbags' size function on zero-copy views of the arrays: ~10 µs for a 4 MB cloud
    where :func:`to_cdr` takes ~2 ms.
    """
    spec = registry.message(type_name)
    store = registry.typestore
    obj = _to_object(store.types, spec, msg)
    return 4 + int(store.get_msgdef(spec.name).getsize_cdr(0, obj, store))
