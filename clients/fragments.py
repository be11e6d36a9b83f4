"""Reassembly of ``fragment`` ops (reference/rosbridge-protocol.md §2.10).

rosbridge cuts the JSON text of a large outgoing message into slices of ``fragment_size``
characters and sends each as ``{"op":"fragment","id","num","total","data"}``. Quirks handled:

- ``total`` is often a float (``(len-1)/size + 1``, e.g. 3.4 for three pieces); the real count
  is its floor, as roslibjs does.
- every fragmented ``publish`` carries fragment id 0, so ids are reused message after message;
  a piece numbered 0 for an id that already holds a piece 0 starts a new message.
- pieces are joined in ``num`` order, whatever order they arrived in.

There is no clock here (sans-I/O): instead of rosbridge's 600 s expiry, at most
``max_partial`` unfinished messages are kept and the oldest is discarded beyond that.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from clients.errors import ProtocolError

DEFAULT_MAX_PARTIAL = 8
"""Unfinished messages kept at once; a server interleaves few (one per fragmenting op)."""


@dataclass(slots=True)
class _Partial:
    total: int
    pieces: dict[int, str] = field(default_factory=dict)
    wire_bytes: int = 0


@dataclass(frozen=True, slots=True)
class Reassembled:
    """The complete JSON text of a fragmented op and the bytes its fragments took on the wire."""

    text: str
    wire_bytes: int


class FragmentAssembler:
    """Collects fragments per id and returns the whole text once every piece is in.

    Not thread-safe: owned by one :class:`clients.protocol.ClientProtocol`.
    """

    def __init__(self, max_partial: int = DEFAULT_MAX_PARTIAL) -> None:
        self._max_partial = max_partial
        self._partials: dict[Any, _Partial] = {}
        self.discarded = 0
        """Unfinished messages thrown away (superseded or evicted)."""

    def add(self, op: dict[str, Any], wire_bytes: int) -> Reassembled | None:
        """Store one fragment op; return the reassembled text when it completes a message."""
        key, num, total, data = _fields(op)
        partial = self._partials.get(key)
        if partial is not None and (partial.total != total or num in partial.pieces):
            self.discarded += 1
            partial = None
        if partial is None:
            partial = self._start(key, total)
        partial.pieces[num] = data
        partial.wire_bytes += wire_bytes
        if len(partial.pieces) < partial.total:
            return None
        del self._partials[key]
        text = "".join(partial.pieces[i] for i in range(partial.total))
        return Reassembled(text, partial.wire_bytes)

    def _start(self, key: Any, total: int) -> _Partial:
        self._partials.pop(key, None)
        while len(self._partials) >= self._max_partial:
            oldest = next(iter(self._partials))
            del self._partials[oldest]
            self.discarded += 1
        partial = _Partial(total)
        self._partials[key] = partial
        return partial

    @property
    def pending(self) -> int:
        """Number of messages with some but not all pieces received."""
        return len(self._partials)


def _fields(op: dict[str, Any]) -> tuple[Any, int, int, str]:
    """Validate a fragment op and return (id, num, total, data) with an integer piece count."""
    try:
        key, num, total, data = op["id"], op["num"], op["total"], op["data"]
    except KeyError as exc:
        raise ProtocolError(f"fragment without {exc.args[0]!r}") from exc
    if not isinstance(data, str) or not isinstance(num, int) or isinstance(num, bool):
        raise ProtocolError("fragment needs an integer num and a string data")
    if not isinstance(total, int | float) or isinstance(total, bool) or not math.isfinite(total):
        raise ProtocolError(f"fragment total {total!r} is not a number")
    count = math.floor(total)
    if count < 1 or not 0 <= num < count:
        raise ProtocolError(f"fragment num {num} outside 0..{count - 1}")
    if isinstance(key, list | dict):
        raise ProtocolError("fragment id must be a scalar")
    return key, num, count, data
