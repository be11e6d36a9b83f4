"""Refuse at the door what could never be stored, logged or sent again; echo input safely.

A decoded frame may hold values that nothing downstream can carry: strings with lone
surrogates (no UTF-8 form, so no JSON, CBOR or log line), integers beyond 64 bits, CBOR
``undefined``, simple values, sets, non-string keys, tags riverbridge does not use (dates,
decimals, regexes...), or nesting deeper than the JSON encoder can write back.
:func:`frame_problem` finds them with one orjson pass at C speed, skipping ``bytes`` and
ndarrays instead of walking them, so a 4 MB scan costs microseconds. Only a refused frame is
walked in Python (with a step budget) to name the offending field.

:func:`echo` renders client input for log lines and error texts: one line, ASCII escapes for
surrogates and control characters, at most ~200 characters, and it never raises (Python
refuses to print integers over 4,300 digits).
"""

from __future__ import annotations

import math
import reprlib
from collections.abc import Mapping
from typing import Any

import numpy as np
import orjson

#: Nesting orjson can still write (with the op envelope around it); deeper frames are refused.
MAX_DEPTH = 254
#: Characters of client input quoted in a log line or an error text.
ECHO_CHARS = 200
_LOCATE_BUDGET = 20_000  # nodes walked to name a refused frame's field; beyond, say less
_OPTIONS = orjson.OPT_PASSTHROUGH_DATETIME  # CBOR tags 0/1 become datetimes: refuse them


def _opaque(value: Any) -> None:
    """Bulk data is skipped, not walked; anything else orjson cannot write is refused."""
    if isinstance(value, bytes | bytearray | memoryview | np.ndarray):
        return None
    raise TypeError(f"unsupported value {type(value).__name__}")


def frame_problem(obj: Any) -> str | None:
    """None if ``obj`` (a decoded frame) can be carried anywhere; else a one-line reason.

    The reason names the field where it can, e.g. ``"field 'msg.data': a string with a lone
    surrogate (no UTF-8 form)"``.
    """
    try:
        orjson.dumps(obj, default=_opaque, option=_OPTIONS)
    except (orjson.JSONEncodeError, TypeError) as exc:
        found = _locate(obj)
        return found if found is not None else f"unusable value: {exc}"
    return None


def describe_value(value: Any) -> str | None:
    """Why one value cannot be carried (None if it can, or is a container to look into)."""
    if isinstance(value, str):
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:
            return "a string with a lone surrogate (no UTF-8 form)"
        return None
    if isinstance(value, bool | float | bytes | bytearray | memoryview | np.ndarray):
        return None
    if isinstance(value, int):
        if -(2**63) <= value < 2**64:
            return None
        return f"an integer of {value.bit_length()} bits (at most 64)"
    if value is None or isinstance(value, dict | list | tuple):
        return None
    return f"a value of type {type(value).__name__} (CBOR tag, set or undefined)"


def _locate(obj: Any) -> str | None:
    """Walk a refused frame breadth-first to name the first bad field (bounded work)."""
    queue: list[tuple[Any, str, int]] = [(obj, "", 0)]
    for index in range(_LOCATE_BUDGET):
        if index >= len(queue):
            return None
        value, path, depth = queue[index]
        where = f"field '{safe_text(path, 80)}': " if path else ""
        if depth > MAX_DEPTH:
            return f"{where}nesting deeper than {MAX_DEPTH} levels"
        problem = describe_value(value)
        if problem is not None:
            return where + problem
        if isinstance(value, Mapping):
            for key, item in value.items():
                if not isinstance(key, str) or describe_value(key) is not None:
                    return f"{where}a map key {echo(key, 40)} that is not a UTF-8 string"
                queue.append((item, f"{path}.{key}" if path else key, depth + 1))
        elif isinstance(value, list | tuple):
            queue.extend((item, f"{path}[{i}]", depth + 1) for i, item in enumerate(value))
    return None


class _Echo(reprlib.Repr):
    """reprlib with limits for client input: short strings, few items, huge ints named."""

    def __init__(self) -> None:
        super().__init__()
        self.maxlevel, self.maxdict, self.maxlist, self.maxtuple = 3, 6, 6, 6
        self.maxset, self.maxfrozenset = 6, 6
        self.maxstring, self.maxother, self.maxlong = ECHO_CHARS, 80, 40

    def repr_int(self, x: int, level: int) -> str:
        if x.bit_length() > 128:
            return f"<integer of {x.bit_length()} bits>"
        return super().repr_int(x, level)

    def repr_float(self, x: float, level: int) -> str:
        return repr(x) if math.isfinite(x) else str(x)

    def repr_bytes(self, x: bytes, level: int) -> str:
        return repr(x[:40]) + ("..." if len(x) > 40 else "")

    def repr_ndarray(self, x: np.ndarray, level: int) -> str:
        return f"<array of {x.size} {x.dtype}>"

    def repr_instance(self, x: Any, level: int) -> str:
        try:
            return super().repr_instance(x, level)
        except Exception:  # a hostile object's repr may raise
            return f"<{type(x).__name__}>"


_ECHO = _Echo()


def echo(value: Any, limit: int = ECHO_CHARS) -> str:
    """``value`` as a short, one-line, never-raising repr for logs and error texts."""
    try:
        text = _ECHO.repr(value)
    except Exception:
        text = f"<{type(value).__name__}>"
    return safe_text(text, limit)


def safe_text(text: str, limit: int = 2 * ECHO_CHARS) -> str:
    """``text`` on one line, encodable as UTF-8 and at most ``limit`` characters."""
    if not (text.isprintable() and len(text) <= limit):
        text = text.encode("utf-8", "backslashreplace").decode("utf-8")
        text = "".join(c if c.isprintable() else ascii(c)[1:-1] for c in text[: 2 * limit])
    if len(text) > limit:
        text = text[: limit - 3] + "..."
    return text
