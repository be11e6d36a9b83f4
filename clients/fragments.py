"""Reassembly of ``fragment`` ops (reference/rosbridge-protocol.md §2.10).

rosbridge cuts the JSON text of a large outgoing message into slices of ``fragment_size``
characters and sends each as ``{"op":"fragment","id","num","total","data"}``. Quirks handled:

- ``total`` is often a float (``(len-1)/size + 1``, e.g. 3.4 for three pieces); the real count
  is its floor, as roslibjs does.
- every fragmented ``publish`` carries fragment id 0, so ids are reused message after message;
  a piece numbered 0 for an id that already holds a piece 0 starts a new message.
- pieces are joined in ``num`` order, whatever order they arrived in.
- pieces of different messages may arrive interleaved, and whole messages between them.
- riverbridge cuts a CBOR frame into binary fragments whose ``data`` is a byte string: their
  join is the CBOR frame (docs/bridge.md, "Over a thin link").

There is no clock here (sans-I/O): instead of rosbridge's 600 s expiry, at most
``max_partial`` unfinished messages are kept and the oldest is discarded beyond that.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from clients.errors import ProtocolError
from schemas.ops import Fragment

DEFAULT_MAX_PARTIAL = 8
"""Unfinished messages kept at once; a server interleaves few (one per fragmenting op)."""


@dataclass(slots=True)
class _Partial:
    total: int
    pieces: dict[int, str | bytes] = field(default_factory=dict)
    wire_bytes: int = 0


@dataclass(frozen=True, slots=True)
class Reassembled:
    """The complete JSON text (or CBOR bytes) of a fragmented op and the bytes its fragments
    took on the wire."""

    text: str | bytes
    wire_bytes: int


class FragmentAssembler:
    """Collects fragments per id and returns the whole text once every piece is in.

    Not thread-safe: owned by one :class:`clients.protocol.ClientProtocol`.
    """

    def __init__(self, max_partial: int = DEFAULT_MAX_PARTIAL) -> None:
        self._max_partial = max_partial
        self._partials: dict[str | int, _Partial] = {}
        self.discarded = 0
        """Unfinished messages thrown away (superseded or evicted)."""

    def add(self, fragment: Fragment, wire_bytes: int) -> Reassembled | None:
        """Store one fragment; return the reassembled text when it completes a message.

        The model has checked the types and floored a float ``total``; a ``num`` outside
        ``0..total-1`` raises :class:`ProtocolError`.
        """
        key, num, total, data = fragment.id, fragment.num, fragment.total, fragment.data
        if not 0 <= num < total:
            raise ProtocolError(f"fragment num {num} outside 0..{total - 1}")
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
        pieces = [partial.pieces[i] for i in range(partial.total)]
        if all(isinstance(piece, bytes) for piece in pieces):
            return Reassembled(b"".join(pieces), partial.wire_bytes)  # type: ignore[arg-type]
        if all(isinstance(piece, str) for piece in pieces):
            return Reassembled("".join(pieces), partial.wire_bytes)  # type: ignore[arg-type]
        raise ProtocolError(f"fragments of {key!r} mix text and bytes")

    def _start(self, key: str | int, total: int) -> _Partial:
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
