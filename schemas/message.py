"""Bring a JSON- or CBOR-decoded message into the canonical form of docs/messages.md.

:func:`normalize` applies rosbridge's JSON -> ROS rules (protocol reference §3.2): missing
fields take defaults, unknown fields are errors, ints are accepted for floats but not the
other way round, bools are strict, integers are range-checked, ``null`` for a float is NaN,
``uint8[]`` may come as base64 or a list, Time accepts ``sec``/``nanosec``, ``secs``/``nsecs``
or ``"now"``, a ``Header`` given without ``stamp`` is stamped ``now_ns``, and ROS 1's
``header.seq`` is dropped. Arrays that
already have the canonical type (``bytes``, an ndarray of the exact dtype) pass through
without a copy, so a 4 MB PointCloud2 costs microseconds.
"""

from __future__ import annotations

import binascii
import math
from collections.abc import Callable, Mapping
from typing import Any, cast

import numpy as np
import pybase64

from schemas import primitives, specs
from schemas.errors import MessageValidationError
from schemas.safety import echo
from schemas.specs import FieldSpec, MessageSpec
from schemas.values import JsonValue, Message

_NS_PER_S = 1_000_000_000
_MISSING = object()
_SEC_RANGE = primitives.INT_RANGES["int32"]
_NANOSEC_RANGE = primitives.INT_RANGES["uint32"]


_Normalizer = Callable[[FieldSpec, Any, int], Any]


class _FieldError(Exception):
    """Raised deep inside the walk; each level on the way out adds its field name."""

    def __init__(self, problem: str, parts: list[str] | None = None) -> None:
        super().__init__(problem)
        self.problem = problem
        self.parts = parts if parts is not None else []

    def path(self) -> str:
        text = ""
        for part in reversed(self.parts):
            text += part if part.startswith("[") or not text else "." + part
        return text


def _describe(value: Any) -> str:
    """``float 42.0``, ``str 'fast'``: what a rejected value was, kept to one short line."""
    return f"{type(value).__name__} {echo(value, 40)}"


# -- time -------------------------------------------------------------------------------------


def stamp_to_ns(stamp: Mapping[str, Any]) -> int:
    """``{"sec", "nanosec"}`` (or ``secs``/``nsecs``) -> integer nanoseconds."""
    sec = stamp.get("sec", stamp.get("secs", 0))
    nanosec = stamp.get("nanosec", stamp.get("nsecs", 0))
    return int(sec) * _NS_PER_S + int(nanosec)


def ns_to_stamp(ns: int) -> dict[str, int]:
    """Integer nanoseconds -> ``{"sec": int, "nanosec": int}`` with ``0 <= nanosec < 1e9``."""
    sec, nanosec = divmod(int(ns), _NS_PER_S)
    return {"sec": sec, "nanosec": nanosec}


def _checked_time_int(value: object, bounds: tuple[int, int], type_name: str) -> int:
    if type(value) is not int:
        if isinstance(value, np.integer) and not isinstance(value, bool):
            value = int(value)
        else:
            raise _FieldError(f"expected {type_name}, got {_describe(value)}")
    if not bounds[0] <= value <= bounds[1]:
        raise _FieldError(f"value {value} out of range for {type_name} {list(bounds)}")
    return value


def _time(spec: MessageSpec, raw: JsonValue, now_ns: int) -> dict[str, int]:
    if raw == "now" and spec.name.endswith("/Time"):
        return ns_to_stamp(now_ns)
    if not isinstance(raw, Mapping):
        raise _FieldError(f"expected an object with sec/nanosec, got {_describe(raw)}")
    sec, nanosec = 0, 0
    for key, value in raw.items():
        try:
            if key in ("sec", "secs"):
                sec = _checked_time_int(value, _SEC_RANGE, "int32")
            elif key in ("nanosec", "nsecs"):
                nanosec = _checked_time_int(value, _NANOSEC_RANGE, "uint32")
            else:
                raise _FieldError(f"no such field in {spec.name}")
        except _FieldError as exc:
            exc.parts.append(str(key))
            raise
    return {"sec": sec, "nanosec": nanosec}


# -- scalars ----------------------------------------------------------------------------------


def _bool(field: FieldSpec, value: Any, now_ns: int) -> bool:
    if value is True or value is False:
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    raise _FieldError(f"expected bool, got {_describe(value)}")


def _int(field: FieldSpec, value: object, now_ns: int) -> int:
    if type(value) is not int:
        if isinstance(value, np.integer):
            value = int(value)
        else:
            raise _FieldError(f"expected {field.base}, got {_describe(value)}")
    low, high = primitives.INT_RANGES[field.base]
    if not low <= value <= high:
        raise _FieldError(f"value {value} out of range for {field.base} [{low}, {high}]")
    return value


def _float(field: FieldSpec, value: object, now_ns: int) -> float:
    if type(value) is not float:
        if value is None:  # roslibjs sends NaN and ±Inf as null
            return math.nan
        if type(value) is bool or isinstance(value, np.bool_):
            raise _FieldError(f"expected {field.base}, got {_describe(value)}")
        if not isinstance(value, int | float | np.integer | np.floating):
            raise _FieldError(f"expected {field.base}, got {_describe(value)}")
        try:
            value = float(value)
        except OverflowError:
            raise _FieldError(f"value {value} out of range for {field.base}") from None
    if field.base == "float32":
        if abs(value) > primitives.FLOAT32_MAX and math.isfinite(value):
            raise _FieldError(f"value {value} out of range for float32")
        value = float(np.float32(value))
    return value


def _string(field: FieldSpec, value: Any, now_ns: int) -> str:
    if type(value) is not str:
        raise _FieldError(f"expected string, got {_describe(value)}")
    if field.string_bound and len(value) > field.string_bound:
        raise _FieldError(f"string longer than its bound {field.string_bound}")
    return value


# -- arrays -----------------------------------------------------------------------------------


def _check_length(field: FieldSpec, length: int) -> None:
    if field.array == "fixed" and length != field.length:
        raise _FieldError(f"expected exactly {field.length} elements, got {length}")
    if field.array == "bounded" and length > field.length:
        raise _FieldError(f"expected at most {field.length} elements, got {length}")


def _bytes(field: FieldSpec, value: Any, now_ns: int) -> bytes:
    """uint8/byte/char arrays: bytes, base64 text, a list of ints or an integer ndarray."""
    if type(value) is bytes:
        out = value
    elif isinstance(value, bytearray | memoryview):
        out = bytes(value)
    elif isinstance(value, str):
        try:
            out = pybase64.b64decode(value, validate=True)
        except (binascii.Error, ValueError):
            raise _FieldError("expected base64 text or a list of ints 0..255") from None
    elif isinstance(value, list | tuple):
        try:
            out = bytes(value)
        except (TypeError, ValueError):
            raise _FieldError("expected a list of ints 0..255") from None
    elif isinstance(value, np.ndarray):
        out = _integer_array(field, value, np.dtype(np.uint8)).tobytes()
    else:
        raise _FieldError(f"expected bytes, base64 or a list of ints, got {_describe(value)}")
    _check_length(field, len(out))
    return out


def _integer_array(field: FieldSpec, array: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """Cast an ndarray to integer ``dtype``; floats and bools are errors, range is checked."""
    if array.ndim != 1:
        raise _FieldError(f"expected a 1-D array, got shape {array.shape}")
    if array.dtype == dtype:
        return array
    if array.dtype.kind not in "iu":
        raise _FieldError(f"expected {field.base} values, got a {array.dtype} array")
    if array.size:
        low, high = primitives.INT_RANGES[dtype.name]
        if int(array.min()) < low or int(array.max()) > high:
            raise _FieldError(f"values out of range for {field.base} [{low}, {high}]")
    return array.astype(dtype)


def _float_array(field: FieldSpec, array: np.ndarray, dtype: np.dtype) -> np.ndarray:
    if array.ndim != 1:
        raise _FieldError(f"expected a 1-D array, got shape {array.shape}")
    if array.dtype == dtype:
        return array
    if array.dtype.kind not in "iuf":
        raise _FieldError(f"expected {field.base} values, got a {array.dtype} array")
    return array.astype(dtype)


def _list_to_array(
    field: FieldSpec, items: list[Any] | tuple[Any, ...], dtype: np.dtype[Any]
) -> np.ndarray:
    """A JSON list -> ndarray of ``dtype`` with the scalar rules (no float for int, no bool)."""
    if not items:
        return np.empty(0, dtype=dtype)
    try:
        probe = np.asarray(items)
    except (TypeError, ValueError):  # ragged nesting
        raise _FieldError(f"expected a flat list of {field.base} numbers") from None
    if probe.ndim != 1:
        raise _FieldError(f"expected a flat list of {field.base} numbers")
    if dtype.kind == "f":
        if probe.dtype.kind in "iuf":
            return probe.astype(dtype)
        if probe.dtype.kind == "O":  # null among the numbers -> NaN
            try:
                return np.array(items, dtype=dtype)
            except (TypeError, ValueError):
                pass
        raise _FieldError(f"expected a list of {field.base} numbers")
    if probe.dtype.kind in "iu":
        return _integer_array(field, probe, dtype)
    # Floats, or ints beyond int64 that numpy inferred as float/object: only ints may pass.
    if probe.dtype.kind in "fO" and all(type(item) is int for item in items):
        try:
            return np.array(items, dtype=dtype)
        except OverflowError:
            low, high = primitives.INT_RANGES[field.base]
            raise _FieldError(f"values out of range for {field.base} [{low}, {high}]") from None
    raise _FieldError(f"expected a list of {field.base} integers")


def _numeric_array(field: FieldSpec, value: Any) -> np.ndarray:
    dtype = cast(np.dtype, field.dtype)  # set for every numeric field
    if isinstance(value, list | tuple):
        return _list_to_array(field, value, dtype)
    if isinstance(value, str | bytes | bytearray | Mapping) or value is None:
        raise _FieldError(f"expected a list of {field.base}, got {_describe(value)}")
    try:
        array = np.asarray(value)  # ndarray, array.array, memoryview: no copy
    except (TypeError, ValueError):
        raise _FieldError(f"expected a list of {field.base}, got {_describe(value)}") from None
    if dtype.kind == "f":
        return _float_array(field, array, dtype)
    return _integer_array(field, array, dtype)


def _numeric_sequence(field: FieldSpec, value: Any, now_ns: int) -> np.ndarray:
    if type(value) is np.ndarray and value.dtype == field.dtype and value.ndim == 1:
        out = value  # the fast path: already canonical, no copy
    else:
        out = _numeric_array(field, value)
    _check_length(field, out.shape[0])
    return out


def _numeric_fixed(field: FieldSpec, value: JsonValue, now_ns: int) -> list[Any]:
    out: list[Any] = _numeric_array(field, value).tolist()
    _check_length(field, len(out))
    return out


def _each(field: FieldSpec, value: JsonValue, convert: _Normalizer, now_ns: int) -> list[Any]:
    if not isinstance(value, list | tuple | np.ndarray):
        raise _FieldError(f"expected a list, got {_describe(value)}")
    out = []
    for index, item in enumerate(value):
        try:
            out.append(convert(field, item, now_ns))
        except _FieldError as exc:
            exc.parts.append(f"[{index}]")
            raise
    _check_length(field, len(out))
    return out


def _bool_array(field: FieldSpec, value: JsonValue, now_ns: int) -> list[Any]:
    return _each(field, value, _bool, now_ns)


def _string_array(field: FieldSpec, value: JsonValue, now_ns: int) -> list[Any]:
    return _each(field, value, _string, now_ns)


def _message_array(field: FieldSpec, value: JsonValue, now_ns: int) -> list[Any]:
    return _each(field, value, _message_field, now_ns)


def _message_field(field: FieldSpec, value: JsonValue, now_ns: int) -> Message:
    return _message(cast(MessageSpec, field.message), value, now_ns)


_NORMALIZERS: dict[str, _Normalizer] = {
    specs.BOOL: _bool,
    specs.INT: _int,
    specs.FLOAT: _float,
    specs.STRING: _string,
    specs.MESSAGE: _message_field,
    specs.BYTES: _bytes,
    specs.NUMERIC_SEQUENCE: _numeric_sequence,
    specs.NUMERIC_FIXED: _numeric_fixed,
    specs.BOOL_ARRAY: _bool_array,
    specs.STRING_ARRAY: _string_array,
    specs.MESSAGE_ARRAY: _message_array,
}


# -- messages ---------------------------------------------------------------------------------


def _message(spec: MessageSpec, raw: JsonValue, now_ns: int) -> Message:
    if spec.name in primitives.TIME_TYPES:
        return _time(spec, raw, now_ns)
    if type(raw) is not dict and not isinstance(raw, Mapping):
        raise _FieldError(f"expected an object for {spec.name}, got {_describe(raw)}")
    stamp_now = spec.name == primitives.HEADER_TYPE
    out = {}
    used = 0
    for field in spec.fields:
        value = raw.get(field.name, _MISSING)
        if value is _MISSING:
            if stamp_now and field.name == "stamp":
                out["stamp"] = ns_to_stamp(now_ns)
            else:
                out[field.name] = _fresh_default(field)
            continue
        used += 1
        try:
            out[field.name] = _NORMALIZERS[field.category](field, value, now_ns)
        except _FieldError as exc:
            exc.parts.append(field.name)
            raise
    if used != len(raw):
        unknown = [key for key in raw if key not in spec.by_name]
        if not (stamp_now and unknown == [ROS1_HEADER_SEQ]):
            raise _FieldError(f"no such field in {spec.name}", [str(unknown[0])])
    return out


# ROS 1's Header had a sequence number; ROS 2's has none. roslibpy's `Header(seq=...)` still
# sends it: accepted and dropped (the bridge says so once per client, `has_ros1_header_seq`).
ROS1_HEADER_SEQ = "seq"


def has_ros1_header_seq(raw: JsonValue) -> bool:
    """Whether a published message's top-level `header` carries ROS 1's `seq`."""
    header = raw.get("header") if isinstance(raw, Mapping) else None
    return isinstance(header, Mapping) and ROS1_HEADER_SEQ in header


def normalize(spec: MessageSpec, raw: JsonValue, *, now_ns: int) -> Message:
    """Validate ``raw`` against ``spec`` and return the canonical message dict.

    ``raw`` is what a JSON or CBOR decoder produced (or a canonical message); ``None`` and
    ``{}`` give the default message. ``now_ns`` (wall clock, ns) fills ``"now"`` times and
    the stamp of a ``Header`` given without one. Raises :class:`MessageValidationError`
    naming the type and the field path, e.g. ``"std_srvs/srv/SetBool_Request field 'data':
    expected bool, got float 42.0"``.
    """
    if raw is None:
        return default_message(spec)
    check = spec.compiled_check
    if check is not None and (message := check(raw)) is not None:
        return message
    try:
        return _message(spec, raw, now_ns)
    except _FieldError as exc:
        if exc.parts:
            text = f"{spec.name} field '{exc.path()}': {exc.problem}"
        else:
            text = f"{spec.name}: {exc.problem}"
        raise MessageValidationError(text) from None


def _fresh_default(field: FieldSpec) -> Any:
    """A default value of ``field`` that the caller may keep and mutate."""
    category = field.category
    if category == specs.MESSAGE:
        return default_message(cast(MessageSpec, field.message))
    if category == specs.MESSAGE_ARRAY:
        count = field.length if field.array == "fixed" else 0
        return [default_message(cast(MessageSpec, field.message)) for _ in range(count)]
    if category == specs.NUMERIC_SEQUENCE:
        return np.empty(0, dtype=field.dtype)
    if isinstance(field.default, list):
        return list(field.default)
    return field.default


def default_message(spec: MessageSpec) -> Message:
    """The all-defaults canonical message of ``spec`` (zeros, empty arrays, stamp 0)."""
    return {field.name: _fresh_default(field) for field in spec.fields}


def payload_bytes(value: Any) -> int:
    """Rough byte count of the bulk data of a canonical message: its bytes and ndarrays. What
    bridge and client ask before deciding whether checking or encoding a message is worth a
    worker thread (strings are not bulk: base64 text is what makes a check costly).

    Walks message structure only (dicts and lists of dicts, bytes or arrays), never the
    elements of numeric arrays, so its cost does not grow with the points a message carries.
    """
    if isinstance(value, _BYTES):
        return len(value)
    if isinstance(value, np.ndarray):
        return int(value.nbytes)
    if isinstance(value, dict):
        total = 0
        for item in value.values():
            if isinstance(item, _CONTAINERS):
                total += payload_bytes(item)
        return total
    if isinstance(value, list) and value and isinstance(value[0], _BULK_ITEMS):
        return sum(payload_bytes(item) for item in value)
    return 0


# (tuples, not `a | b` unions: a union is built anew on every call)
_BYTES = (bytes, bytearray)
_CONTAINERS = (bytes, bytearray, np.ndarray, dict, list)
_BULK_ITEMS = (dict, bytes, np.ndarray)
