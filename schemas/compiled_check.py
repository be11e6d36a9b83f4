"""A compiled fast path for `schemas.message.normalize`: msgspec checks a message against a
Struct built from its ROS type, in C.

`normalize` walks a message field by field in Python: ~13 µs for a ``sensor_msgs/Imu``,
which is a third of what the bridge spends relaying one. msgspec's ``convert`` checks the
same dict against a Struct type in ~1.5 µs, and ``to_builtins`` gives it back as a dict in
another ~1.5 µs (issue 21; ``benchmarks/validators.py``).

It is only ever a shortcut, never a second definition of the rules: a Struct accepts a
subset of what `normalize` accepts and gives the same canonical message for it. Whatever it
refuses (an error, or one of the forms only `normalize` knows: ``null`` for NaN, ``"now"``
and ``secs``/``nsecs`` times, a ``Header`` without a stamp, ROS 1's ``header.seq``, bools or
numpy values among numbers, uint64 values past int64) goes to `normalize`'s own walk, which
accepts it or names the problem exactly as before. ``float32`` values are range-checked by
the Struct and rounded to float32 afterwards, as `normalize` does. Types with bytes or
numeric sequences (canonical as ``bytes`` and ndarrays) are not compiled at all
(`compile_check` gives None).
"""

from __future__ import annotations

from array import array
from collections.abc import Callable
from types import GenericAlias
from typing import Annotated, Any

import msgspec
import numpy as np

from schemas import primitives, specs
from schemas.specs import FieldSpec, MessageSpec
from schemas.values import Message

#: A compiled check: the canonical message, or None when `normalize` must decide.
Check = Callable[[Any], Message | None]

# msgspec bounds an integer within int64; larger uint64 values fall back to `normalize`.
_INT64_MAX = 2**63 - 1
# Types of at most this many scalar fields are left to the walk (std_msgs/String: 0.5 µs
# walked, 0.6 µs compiled; benchmarks/validators.py).
_FLAT_WALK_FIELDS = 4
_SCALARS = (specs.BOOL, specs.INT, specs.FLOAT, specs.STRING)
# Numbers whose float64 value is exact if they came as ints.
_EXACT_FLOAT = Annotated[float, msgspec.Meta(ge=-(2**53), le=2**53)]


class _NotCompiled(Exception):
    """The type needs `normalize`'s walk (see the module docstring)."""


def compile_check(spec: MessageSpec) -> Check | None:
    """The compiled check of `spec`, or None if its messages need `normalize`'s walk (or are
    so flat that the walk is quicker: a few scalars take a dict lookup each, less than
    building a Struct and a dict again)."""
    flat = all(field.category in _SCALARS for field in spec.fields)
    if flat and len(spec.fields) <= _FLAT_WALK_FIELDS:
        return None
    try:
        struct = _struct(spec, {})
    except _NotCompiled:
        return None
    convert, to_builtins = msgspec.convert, msgspec.to_builtins
    narrow = _float32_narrower(spec)

    def check(raw: Any) -> Message | None:
        try:
            message: Message = to_builtins(convert(raw, struct))
        except Exception:  # refused, or not a form msgspec reads: `normalize` decides
            return None
        if narrow is not None:
            narrow([message])
        return message

    return check


Narrow = Callable[[list[dict[str, Any]]], None]


def _float32_narrower(spec: MessageSpec) -> Narrow | None:
    """What rounds the float32 values of checked messages of `spec` to float32, in place, as
    `normalize` does (the Struct checks their range, not their precision); None if they have
    none. It takes a list of messages and works a field at a time over all of them, so the
    detections of an array are rounded by one C call per field, not one per value."""
    steps: list[tuple[str, str, Narrow | None]] = []
    for field in spec.fields:
        if field.base == "float32" and field.category in (specs.FLOAT, specs.NUMERIC_FIXED):
            steps.append((field.name, field.category, None))
        elif field.category in (specs.MESSAGE, specs.MESSAGE_ARRAY) and field.message:
            inner = _float32_narrower(field.message)
            if inner is not None:
                steps.append((field.name, field.category, inner))
    if not steps:
        return None

    def narrow(messages: list[dict[str, Any]]) -> None:
        for name, category, inner in steps:
            if inner is None:
                if category == specs.FLOAT:  # (finite and in range: the Struct checked)
                    column = array("f", [message[name] for message in messages]).tolist()
                    for message, value in zip(messages, column, strict=True):
                        message[name] = value
                else:  # a fixed array: cast as `normalize` casts it (no range check)
                    for message in messages:
                        message[name] = np.asarray(message[name]).astype(np.float32).tolist()
            elif category == specs.MESSAGE:
                inner([message[name] for message in messages])
            else:
                inner([item for message in messages for item in message[name]])

    return narrow


def _struct(spec: MessageSpec, made: dict[str, Any]) -> Any:
    """The Struct type of `spec` (nested types built once per compile, in `made`)."""
    if spec.name in made:
        return made[spec.name]
    if spec.name in primitives.TIME_TYPES:
        sec = _int_type("int32")
        nanosec = _int_type("uint32")
        fields: list[tuple[str, Any, Any]] = [
            ("sec", sec, msgspec.field(default=0, name="sec")),
            ("nanosec", nanosec, msgspec.field(default=0, name="nanosec")),
        ]
    else:
        fields = [
            (f"f{index}", _field_type(field, made), _field_default(spec, field, made))
            for index, field in enumerate(spec.fields)
        ]
    struct = msgspec.defstruct(
        "ROS_" + spec.name.replace("/", "_"),
        fields,
        kw_only=True,
        forbid_unknown_fields=True,
    )
    made[spec.name] = struct
    return struct


def _field_type(field: FieldSpec, made: dict[str, Any]) -> Any:
    category = field.category
    if category == specs.BOOL:
        return bool
    if category == specs.STRING:
        return _string_type(field)
    if category == specs.INT:
        return _int_type(field.base)
    if category == specs.FLOAT:
        return _float_type(field.base)
    if category == specs.MESSAGE:
        return _struct(_message_spec(field), made)
    if category == specs.NUMERIC_FIXED:
        element = None
        if field.base == "float32":  # (cast by `normalize`, no range check; past 2**53 an
            element = _EXACT_FLOAT  # int would be rounded twice here: left to the walk)
        elif field.base == "float64":
            element = float
        return _sized(_list_of(element or _int_type(field.base)), field)
    if category == specs.BOOL_ARRAY:
        return _sized(list[bool], field)
    if category == specs.STRING_ARRAY:
        return _sized(_list_of(_string_type(field)), field)
    if category == specs.MESSAGE_ARRAY:
        return _sized(_list_of(_struct(_message_spec(field), made)), field)
    raise _NotCompiled(category)  # bytes, numeric sequences: canonical as bytes and ndarrays


def _field_default(spec: MessageSpec, field: FieldSpec, made: dict[str, Any]) -> Any:
    """The default of a missing field: `normalize`'s `_fresh_default`, built fresh each time."""
    name = field.name
    if spec.name == primitives.HEADER_TYPE and name == "stamp":
        return msgspec.field(name=name)  # required: a Header without one is stamped `now`
    if field.category == specs.MESSAGE:
        factory = _default_factory(_message_spec(field), made)
        return msgspec.field(default_factory=factory, name=name)
    if field.category == specs.MESSAGE_ARRAY:
        element = _default_factory(_message_spec(field), made)
        count = field.length if field.array == "fixed" else 0
        return msgspec.field(default_factory=lambda: [element() for _ in range(count)], name=name)
    default = field.default
    if isinstance(default, list):
        return msgspec.field(default_factory=lambda: list(default), name=name)
    return msgspec.field(default=default, name=name)


def _default_factory(spec: MessageSpec, made: dict[str, Any]) -> Callable[[], Any]:
    """A factory of `spec`'s all-defaults Struct (a Header's zero stamp given explicitly)."""
    struct = _struct(spec, made)
    if spec.name != primitives.HEADER_TYPE:
        return struct  # type: ignore[no-any-return]
    index = [field.name for field in spec.fields].index("stamp")
    stamp = _struct(_message_spec(spec.fields[index]), made)
    return lambda: struct(**{f"f{index}": stamp()})


def _message_spec(field: FieldSpec) -> MessageSpec:
    if field.message is None:
        raise _NotCompiled(field.name)
    return field.message


def _int_type(base: str) -> Any:
    low, high = primitives.INT_RANGES[base]
    return Annotated[int, msgspec.Meta(ge=low, le=min(high, _INT64_MAX))]


def _float_type(base: str) -> Any:
    if base == "float32":  # range-checked here, rounded by `_float32_narrower`
        limit = primitives.FLOAT32_MAX
        return Annotated[float, msgspec.Meta(ge=-limit, le=limit)]
    return float


def _string_type(field: FieldSpec) -> Any:
    if field.string_bound:
        return Annotated[str, msgspec.Meta(max_length=field.string_bound)]
    return str


def _list_of(element: Any) -> Any:
    """``list[element]`` for an element type made at run time."""
    return GenericAlias(list, (element,))


def _sized(kind: Any, field: FieldSpec) -> Any:
    if field.array == "fixed":
        return Annotated[kind, msgspec.Meta(min_length=field.length, max_length=field.length)]
    if field.array == "bounded":
        return Annotated[kind, msgspec.Meta(max_length=field.length)]
    return kind
