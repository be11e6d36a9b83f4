"""A client's websocket byte stream split at frame boundaries (RFC 6455 §5.2), sans-I/O.

websockets parses every frame through a chain of generators (`Frame.parse`,
`StreamReader.read_exact`), several microseconds a frame, as much as the bridge spends on a
small publish. Nearly every frame a client sends is a plain data frame: final, no reserved
bits, masked, text or binary. `FrameScanner` reads those headers itself and unmasks their
payload with websockets' own C unmasking. Every other frame (control, continuation, non-final,
reserved bits) is handed on whole, as its raw bytes, for websockets' parser: that parser then
only ever receives whole frames, so it waits at a frame boundary whenever the scanner does and
the two can share one connection. While a fragmented message is open every frame is handed on,
so the message's frames keep their order. A frame websockets refuses from its header alone
(unmasked, or longer than `max_size`) makes the scanner hand on everything from there, for
good: nothing is buffered beyond `max_size`, and websockets fails the connection as it would.
"""

from __future__ import annotations

from enum import Enum

try:
    from websockets.speedups import apply_mask
except ImportError:  # websockets built without its C extension
    from websockets.utils import apply_mask


class Kind(Enum):
    """What a scanned frame is: raw bytes for websockets, or a message's payload."""

    RAW = 0
    TEXT = 1
    BINARY = 2


RAW, TEXT, BINARY = Kind.RAW, Kind.TEXT, Kind.BINARY
ScannedFrame = tuple[Kind, bytes]

_FIN_TEXT = 0x81  # first header byte of a final text frame without reserved bits
_FIN_BINARY = 0x82
_PLAIN_DATA = frozenset((_FIN_TEXT, _FIN_BINARY))
_MASK_BIT = 0x80
_OPCODE_CONT = 0x0
_OPCODE_TEXT, _OPCODE_BINARY = 0x1, 0x2
_FIN_BIT = 0x80
# A payload at least this long is unmasked through a view of the buffer rather than a copy.
_VIEW_BYTES = 65536


class FrameScanner:
    """Splits a client's bytes into frames: `feed` what the socket gave, then `next_frame`
    until it returns None (the rest is a partial frame, kept until more bytes come)."""

    def __init__(self, max_size: int | None) -> None:
        self._max_size = max_size
        self._buffer = b""
        self._offset = 0  # where the unscanned bytes of `_buffer` start
        self._later: list[bytes] = []  # chunks that came after `_buffer`
        self._later_bytes = 0
        self._need = 2  # unscanned bytes the next frame needs at least
        self._fragmented = False  # websockets holds a message whose final frame is to come
        self.handing_on = False  # a frame websockets refuses at its header was seen

    def feed(self, data: bytes) -> None:
        if self._offset == len(self._buffer) and not self._later:
            self._buffer, self._offset = data, 0
        else:
            self._later.append(data)
            self._later_bytes += len(data)

    def take_rest(self) -> bytes:
        """The bytes not scanned yet (a partial frame), which leave the scanner."""
        rest = b"".join([self._buffer[self._offset :], *self._later])
        self._buffer, self._offset, self._later, self._later_bytes = b"", 0, [], 0
        self._need = 2
        return rest

    def next_frame(self) -> ScannedFrame | None:
        """The next complete frame: a plain data frame's unmasked payload as TEXT or BINARY,
        any other frame as RAW bytes; None while the next frame is incomplete."""
        while True:
            if self.handing_on:
                rest = self.take_rest()
                return (RAW, rest) if rest else None
            available = len(self._buffer) - self._offset
            if available < self._need:
                if available + self._later_bytes < self._need:
                    return None
                need = self._need
                self._buffer, self._offset = self.take_rest(), 0
                self._need = need
            frame = self._scan()
            if frame is not None:
                return frame

    def _scan(self) -> ScannedFrame | None:
        """The frame at `_offset` if it is all there; else None with `_need` raised."""
        buffer, start = self._buffer, self._offset
        head, second = buffer[start], buffer[start + 1]
        length = second & 0x7F
        header = 6  # two bytes, then the mask
        if length >= 126:
            header = 8 if length == 126 else 14
            if len(buffer) - start < header - 4:
                self._need = header - 4
                return None
            length = int.from_bytes(buffer[start + 2 : start + header - 4], "big")
        if not second & _MASK_BIT or (self._max_size is not None and length > self._max_size):
            self.handing_on = True
            return RAW, self.take_rest()
        end = start + header + length
        if end > len(buffer):
            self._need = end - start
            return None
        self._offset, self._need = end, 2
        if head in _PLAIN_DATA and not self._fragmented:
            mask = buffer[start + header - 4 : start + header]
            if length < _VIEW_BYTES:
                payload = apply_mask(buffer[start + header : end], mask)
            else:
                payload = apply_mask(memoryview(buffer)[start + header : end], mask)
            return (TEXT if head == _FIN_TEXT else BINARY), payload
        self._follow_fragments(head)
        return RAW, buffer[start:end]

    def _follow_fragments(self, head: int) -> None:
        """Track websockets' fragmented message from the headers of the frames it gets."""
        opcode = head & 0x0F
        if opcode in (_OPCODE_TEXT, _OPCODE_BINARY):
            self._fragmented = not head & _FIN_BIT
        elif opcode == _OPCODE_CONT and head & _FIN_BIT:
            self._fragmented = False
