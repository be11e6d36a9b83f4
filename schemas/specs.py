"""Message, service and action types as plain frozen data.

A :class:`MessageSpec` is what every codec walks: fields in declaration order, each
classified once (:attr:`FieldSpec.category`) so that encoders and the normaliser dispatch
through tables instead of re-reading type strings for every value.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

if TYPE_CHECKING:
    from schemas.compiled_check import Check

ArrayKind = Literal[None, "fixed", "bounded", "sequence"]

# Field categories: how a field's value looks in the canonical form (docs/messages.md).
BOOL = "bool"
INT = "int"
FLOAT = "float"
STRING = "string"
MESSAGE = "message"
BYTES = "bytes"  # uint8/byte/char arrays of any length kind -> bytes
NUMERIC_SEQUENCE = "numeric_sequence"  # other numeric sequences -> 1-D ndarray, exact dtype
NUMERIC_FIXED = "numeric_fixed"  # other numeric fixed arrays -> list of N Python numbers
BOOL_ARRAY = "bool_array"  # -> list[bool]
STRING_ARRAY = "string_array"  # -> list[str]
MESSAGE_ARRAY = "message_array"  # -> list[dict]


@dataclass(frozen=True)
class FieldSpec:
    """One field of a message type.

    ``base`` is the primitive name (``'float64'``, ``'uint8'``, ``'string'``, ``'bool'``, ...)
    or, when ``is_message``, the element's message type ``'pkg/msg/T'``. ``length`` is N for
    ``fixed``/``bounded`` arrays and 0 otherwise. ``default`` is the canonical default of a
    primitive field (scalar, ``bytes``, empty array or list of N zeros); it is ``None`` for
    message fields and message arrays, whose defaults come from ``message``. Callers must not
    mutate it: :func:`schemas.message.default_message` hands out fresh copies.
    """

    name: str
    base: str
    is_message: bool
    array: ArrayKind
    length: int
    default: Any
    message: MessageSpec | None
    category: str = STRING
    dtype: np.dtype | None = None  # element dtype of numeric primitives, else None
    string_bound: int = 0  # N of ``string<=N`` (0: unbounded)


@dataclass(frozen=True)
class MessageSpec:
    """A message type ``'pkg/msg/T'`` with its fields and ``(name, type, value)`` constants."""

    name: str
    fields: tuple[FieldSpec, ...]
    constants: tuple[tuple[str, str, Any], ...] = ()
    by_name: MappingProxyType[str, FieldSpec] = field(
        default_factory=lambda: MappingProxyType({}), compare=False, hash=False, repr=False
    )

    def __post_init__(self) -> None:
        if not self.by_name and self.fields:
            object.__setattr__(self, "by_name", MappingProxyType({f.name: f for f in self.fields}))

    @cached_property
    def bulk_free(self) -> bool:
        """No bytes and no numeric sequences at any depth: its canonical messages hold no
        ndarray and no ``bytes``, so per-message walks for bulk data (payload size, float32
        widening for JSON) can be skipped, which matters for the small messages that
        dominate message rates (std_msgs, Imu, Twist)."""
        return all(
            f.category not in (BYTES, NUMERIC_SEQUENCE)
            and (f.message is None or f.message.bulk_free)
            for f in self.fields
        )

    @cached_property
    def compiled_check(self) -> Check | None:
        """The compiled shortcut of `schemas.message.normalize` for this type, or None
        (`schemas.compiled_check`), built on first use."""
        from schemas.compiled_check import compile_check  # (it imports this module)

        return compile_check(self)

    @cached_property
    def has_float32_sequence(self) -> bool:
        """A ``float32[]`` at any depth (an ndarray that JSON must widen to float64)."""
        return any(
            (f.category == NUMERIC_SEQUENCE and f.base == "float32")
            or (f.message is not None and f.message.has_float32_sequence)
            for f in self.fields
        )


@dataclass(frozen=True)
class ServiceSpec:
    """A service type ``'pkg/srv/T'``; its parts are the messages ``T_Request``, ``T_Response``."""

    name: str
    request: MessageSpec
    response: MessageSpec


@dataclass(frozen=True)
class ActionSpec:
    """An action type ``'pkg/action/T'`` with its goal, result and feedback messages."""

    name: str
    goal: MessageSpec
    result: MessageSpec
    feedback: MessageSpec
